"""wcsph's pressure kernel (`solver.pressure_kernel`, docs/method-wcsph.md, W31):
the validation's cases, each set up as `sphfluid validate` sets it up but for
that key, and the time per step on the benchmark's dam break.

    python benchmarks/experiments/pressure_kernel.py accuracy KERNEL CASE:N/N,...
    python benchmarks/experiments/pressure_kernel.py cost [PARTICLES] [ROUNDS]

KERNEL is "wendland" (the default) or "quintic". `accuracy` prints one JSON
line per run (the case's error and metrics); `cost` times 400 steps of the
benchmark's dam break (the bench's fixed step, 2 threads) with each kernel in
turn, ROUNDS times, and prints the medians of the step and its phases in
microseconds.
"""
from __future__ import annotations

import json
import statistics
import sys
import time


def accuracy(kernel: str, plan: str) -> None:
    from sphfluid.validation import cases

    for item in plan.split(","):
        name, _, ns = item.partition(":")
        base = type(cases.CASES[name])

        class Case(base):
            def scene(self, n, method):
                d = super().scene(n, method)
                d["solver"]["pressure_kernel"] = kernel
                return d

        for n in (int(v) for v in ns.split("/")):
            r = Case().run(n, "wcsph", threads=2)
            row = {"case": name, "kernel": kernel, "n": n,
                   "error": None if r.failure else round(r.error, 5), "wall": round(r.wall, 2),
                   "steps": r.steps, "failure": r.failure[:100]}
            row.update({m: round(v, 5) if isinstance(v, float) else v
                        for m, v in r.metrics.items()})
            print(json.dumps(row), flush=True)


def cost(particles: int, rounds: int) -> None:
    import sphfluid
    from sphfluid.bench import dam_break_scene

    times: dict[str, list[dict[str, float]]] = {"wendland": [], "quintic": []}
    for _ in range(rounds):
        for kernel in times:
            d = dam_break_scene(particles, "wcsph")
            d["solver"]["pressure_kernel"] = kernel
            sim = sphfluid.Simulation(sphfluid.load_scene(d), threads=2)
            sim.step(100)  # warm-up
            sim._solver.reset_phase_seconds()
            start = time.perf_counter()
            sim.step(400)
            row = {"step": (time.perf_counter() - start) / 400 * 1e6}
            row.update({k: v / 400 * 1e6 for k, v in sim._solver.phase_seconds().items()})
            times[kernel].append(row)
    for kernel, rows in times.items():
        med = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
        print(f"{kernel}: " + ", ".join(f"{k} {v:.0f}" for k, v in med.items() if v >= 0.5)
              + " us")


if __name__ == "__main__":
    mode = sys.argv[1] if len(sys.argv) > 1 else "cost"
    if mode == "accuracy":
        accuracy(sys.argv[2], sys.argv[3])
    elif mode == "cost":
        cost(int(sys.argv[2]) if len(sys.argv) > 2 else 10_000,
             int(sys.argv[3]) if len(sys.argv) > 3 else 3)
    else:
        sys.exit(f"unknown mode {mode!r}: accuracy or cost")
