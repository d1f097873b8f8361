"""wcsph with the continuity density (docs/method-wcsph.md, W17-W25) on the
validation cases, each scene as the validation suite builds it for wcsph with
these changes: "density": "continuity", a support of 3 spacings, shifting 16,
no background pressure, and the plain lattice (the tank's squeezed start is not
used). docs/method-wcsph.md quotes its output.

    python benchmarks/experiments/continuity_cases.py taylor_green 25,50,100
    python benchmarks/experiments/continuity_cases.py poiseuille 10,20,40
    python benchmarks/experiments/continuity_cases.py hydrostatic 10,20,40
    python benchmarks/experiments/continuity_cases.py dam_break 10,20
"""
from __future__ import annotations

import json
import sys
import time

from sphfluid.scene import load_scene
from sphfluid.simulation import InstabilityError, Simulation
from sphfluid.validation import cases


def run(name: str, n: int, *, support: float = 3.0, shifting: float = 16.0,
        threads: int = 2) -> dict:
    case = cases.CASES[name]
    d = case.scene(n, "wcsph")
    d["resolution"]["smoothing_length"] = support * d["resolution"]["spacing"]
    d["solver"].update({"density": "continuity", "shifting": shifting})
    d["fluid"].pop("background_pressure", None)
    scene = load_scene(d)
    sim = Simulation(scene, threads=threads)
    if name != "hydrostatic":  # the plain lattice, not the summation's squeezed rows
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


if __name__ == "__main__":
    for n in (int(k) for k in sys.argv[2].split(",")):
        print(json.dumps(run(sys.argv[1], n)), flush=True)
