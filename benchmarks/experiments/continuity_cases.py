"""wcsph with the continuity density (docs/method-wcsph.md, W17-W28) on the
validation cases, each scene as the validation suite builds it for wcsph with
these changes: "density": "continuity" with its defaults (support, shifting,
diffusion), no artificial viscosity or background pressure set by the case
(W28 decides the first), and the plain lattice (the tank's squeezed start is
not used). docs/method-wcsph.md quotes its output.

    python benchmarks/experiments/continuity_cases.py taylor_green 25,50,100 [K]
    python benchmarks/experiments/continuity_cases.py poiseuille 10,20,40 [K]
    python benchmarks/experiments/continuity_cases.py hydrostatic 10,20,40 [K]
    python benchmarks/experiments/continuity_cases.py dam_break 10,20 [K]
    python benchmarks/experiments/continuity_cases.py cavity 25,50,100 [K]
    python benchmarks/experiments/continuity_cases.py droplet 10,20 [K]

K: the shifting coefficient (solver.shifting), if not the default.
"""
from __future__ import annotations

import json
import sys
import time

from sphfluid.scene import load_scene
from sphfluid.simulation import InstabilityError, Simulation
from sphfluid.validation import cases


def run(name: str, n: int, *, shifting: float | None = None, threads: int = 2) -> dict:
    """The case at n with the continuity density's defaults (shifting: k, if
    not the default)."""
    case = cases.CASES[name]
    d = case.scene(n, "wcsph")
    d["resolution"].pop("smoothing_length", None)  # the continuity density's default
    d["solver"]["density"] = "continuity"
    if shifting is not None:
        d["solver"]["shifting"] = shifting
    for key in ("background_pressure", "artificial_viscosity"):
        d["fluid"].pop(key, None)
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
    k = float(sys.argv[3]) if len(sys.argv) > 3 else None
    for n in (int(x) for x in sys.argv[2].split(",")):
        print(json.dumps(run(sys.argv[1], n, shifting=k)), flush=True)
