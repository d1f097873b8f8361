"""The cost of wcsph's continuity density (docs/method-wcsph.md, W17-W25)
against its summation density, on the benchmark's 10k dam break
(`sphfluid.bench.dam_break_scene`) with the adaptive time step: time per
step by phase, and wall time for the first 0.3 s, the two densities run in
turn in each round (this machine's speed drifts), medians over the rounds.
The continuity density takes its default support of 3 spacings (the
summation 2), so its time step is 1.5 times longer; it runs as it is by
default (no shifting: the dam break has a free surface) and with
"shifting": 8.

    python benchmarks/experiments/continuity_cost.py [THREADS] [ROUNDS]
"""
from __future__ import annotations

import statistics
import sys
import time

from sphfluid.bench import dam_break_scene
from sphfluid.scene import load_scene
from sphfluid.simulation import Simulation


def scene(density: str) -> dict:
    d = dam_break_scene(10_000, "wcsph")
    d["solver"]["time_step"] = "auto"
    d["solver"]["density"] = density.split(",")[0]  # each with its default support
    if density == "continuity, shifting 8":
        d["solver"]["shifting"] = 8.0
    return d


def run(density: str, threads: int, end: float = 0.3) -> dict:
    sim = Simulation(load_scene(scene(density)), threads=threads)
    sim._solver.reset_phase_seconds()
    begin = time.perf_counter()
    sim.advance_to(end)
    wall = time.perf_counter() - begin
    steps = sim.step_count
    phases = {k: 1e6 * v / steps for k, v in sim._solver.phase_seconds().items()}
    return {"wall": wall, "steps": steps, "us_per_step": 1e6 * wall / steps, **phases}


def main() -> None:
    threads = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    runs: dict[str, list[dict]] = {"summation": [], "continuity": [],
                                   "continuity, shifting 8": []}
    for _ in range(rounds):
        for density in runs:
            runs[density].append(run(density, threads))
    keys = list(runs["summation"][0])
    print(f"{threads} thread(s), {rounds} rounds, medians; phases in us per step")
    print("| density | " + " | ".join(keys) + " |")
    print("|---|" + "---:|" * len(keys))
    med = {}
    for density, rs in runs.items():
        med[density] = {k: statistics.median(r[k] for r in rs) for k in keys}
        print(f"| {density} | " + " | ".join(f"{med[density][k]:.3g}" for k in keys) + " |")
    for name in ("continuity", "continuity, shifting 8"):
        ratio = [c["wall"] / s["wall"] for c, s in zip(runs[name], runs["summation"])]
        step = [c["us_per_step"] / s["us_per_step"] for c, s in zip(runs[name], runs["summation"])]
        print(f"{name} / summation: {statistics.median(ratio):.2f} per simulated second, "
              f"{statistics.median(step):.2f} per step (medians of each round's ratio)")


if __name__ == "__main__":
    main()
