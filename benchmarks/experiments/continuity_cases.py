"""wcsph on a validation case with its scene's shifting coefficient replaced:
the case's scene as `sphfluid validate` builds it (the continuity density
with its defaults, docs/method-wcsph.md W17-W28), with "solver.shifting" set
to K when given (a number, or "auto", the default), the other
(summation) density with "summation". docs/method-wcsph.md quotes its output.

    python benchmarks/experiments/continuity_cases.py taylor_green 25,50,100 [K]
    python benchmarks/experiments/continuity_cases.py dam_break 10,20 0
    python benchmarks/experiments/continuity_cases.py droplet 10,20 8
    python benchmarks/experiments/continuity_cases.py droplet 10,20 summation
"""
from __future__ import annotations

import json
import sys
import time

from sphfluid.scene import load_scene
from sphfluid.simulation import InstabilityError, Simulation
from sphfluid.validation import cases


def run(name: str, n: int, *, shifting: float | str | None = None, threads: int = 2) -> dict:
    """The case at n with wcsph's defaults; shifting: k, "auto", or "summation"
    (the summation density), if not the default."""
    case = cases.CASES[name]
    d = case.scene(n, "wcsph")
    if shifting == "summation":
        d["solver"]["density"] = "summation"
    elif shifting is not None:
        d["solver"]["shifting"] = shifting
    scene = load_scene(d)
    sim = Simulation(scene, threads=threads)
    case.start(sim)
    result = cases.Result(name, "wcsph", n, scene.spacing, particles=sim.n_particles)
    times = case.sample_times()
    samples = []
    begin = time.perf_counter()
    try:
        for t in times:
            sim.advance_to(float(t))
            samples.append(case.sample(sim))
    except InstabilityError as e:
        return {"case": name, "n": n, "failure": str(e)}
    result.wall = time.perf_counter() - begin
    case.score(samples, times, result)
    metrics = {k: round(v, 5) for k, v in result.metrics.items() if isinstance(v, float)}
    return {"case": name, "n": n, "error": round(result.error, 5), **metrics,
            "steps": sim.step_count, "wall s": round(result.wall, 2)}


def _shifting(arg: str) -> float | str:
    return arg if arg in ("auto", "summation") else float(arg)


if __name__ == "__main__":
    k = _shifting(sys.argv[3]) if len(sys.argv) > 3 else None
    for n in (int(x) for x in sys.argv[2].split(",")):
        print(json.dumps(run(sys.argv[1], n, shifting=k)), flush=True)
