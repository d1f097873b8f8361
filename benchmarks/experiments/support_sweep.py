"""wcsph's continuity density at several kernel supports h = k dx (the default
k = 3; docs/method-wcsph.md, "The kernel's support"): the validation cases'
errors at two resolutions each, every case set up as `sphfluid validate` sets
it up but for the smoothing length, and the time per step on the benchmark's
10k dam break at the bench's fixed time step (the same dt for every k; each
k in a fresh process, the k's in turn in each round, medians over the rounds),
beside the summed density's (k = 2).

    python benchmarks/experiments/support_sweep.py accuracy 2,2.5,3,3.5 [CASE:N/N,...]
    python benchmarks/experiments/support_sweep.py cost 2,2.5,3,3.5 [ROUNDS]

One JSON line per run. The accuracy's cases and resolutions are PLAN's unless
given, e.g. `wall_pressure:20/40,wave_maker:10/20,basin:30`.
"""
from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time

PLAN = [("taylor_green", (25, 50)), ("poiseuille", (20, 40)), ("hydrostatic", (20, 40)),
        ("dam_break", (20, 40)), ("cavity", (25, 50))]
METRICS = ("decay rate error", "max |v| / sqrt(gH)", "99.9 % of |rho/rho0 - 1| within, collapse",
           "99.9 % of |rho/rho0 - 1| within, impact",
           "mean |dZ|, best shift", "splashed out of the basin")


def parse_plan(text: str) -> list[tuple[str, tuple[int, ...]]]:
    """"case:20/40,case:30" as PLAN's entries."""
    plan = []
    for item in text.split(","):
        name, _, ns = item.partition(":")
        plan.append((name, tuple(int(n) for n in ns.split("/"))))
    return plan


def accuracy(ratios: list[float], plan=PLAN) -> None:
    from sphfluid.validation import cases

    for name, resolutions in plan:
        base = type(cases.CASES[name])
        for k in ratios:
            class Case(base):
                def scene(self, n, method, _k=k):
                    d = super().scene(n, method)
                    d["resolution"]["smoothing_length"] = _k * d["resolution"]["spacing"]
                    return d

            for n in resolutions:
                r = Case().run(n, "wcsph", threads=2)
                row = {"case": name, "k": k, "n": n,
                       "error": None if r.failure else round(r.error, 5),
                       "wall": round(r.wall, 2), "steps": r.steps, "failure": r.failure[:100]}
                row.update({m: round(v, 5) for m, v in r.metrics.items() if m in METRICS})
                print(json.dumps(row), flush=True)


def step_time(k: str, steps: int = 1000) -> float:
    """Microseconds per step of the 10k dam break at the bench's fixed dt, 2 threads
    (k = "sum": the summed density at its own support)."""
    from sphfluid import Simulation, load_scene
    from sphfluid.bench import bench_scene

    d = bench_scene(10_000, "wcsph")
    if k == "sum":
        d["solver"]["density"] = "summation"
    else:
        d["resolution"]["smoothing_length"] = float(k) * d["resolution"]["spacing"]
    sim = Simulation(load_scene(d), threads=2)
    sim.step(300)
    start = time.perf_counter()
    sim.step(steps)
    return 1e6 * (time.perf_counter() - start) / steps


def cost(ratios: list[str], rounds: int) -> None:
    times: dict[str, list[float]] = {}
    for _ in range(rounds):
        for k in ["sum", *ratios]:
            out = subprocess.run([sys.executable, __file__, "_one", k], capture_output=True,
                                 text=True, check=True).stdout
            times.setdefault(k, []).append(float(out))
    for k, us in times.items():
        print(json.dumps({"k": k, "us_per_step": round(statistics.median(us), 1),
                          "runs": [round(u, 1) for u in us]}), flush=True)


if __name__ == "__main__":
    what, ks = sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "2,2.5,3,3.5"
    if what == "_one":
        print(step_time(ks))
    elif what == "accuracy":
        accuracy([float(k) for k in ks.split(",")],
                 parse_plan(sys.argv[3]) if len(sys.argv) > 3 else PLAN)
    elif what == "cost":
        cost(ks.split(","), int(sys.argv[3]) if len(sys.argv) > 3 else 3)
    else:
        sys.exit(__doc__)
