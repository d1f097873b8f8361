"""How a sweep of small runs is best spread over this machine's cores.

Runs one sweep of 20 short dam breaks (2,500 to 5,000 particles, 0.5 s at five
time steps, seed method) with `sphfluid sweep` in each configuration: a plain
loop in one process on 1 and on all threads, and Dask LocalClusters of 1
worker with all threads and of one worker per core with 1 thread each. Each
configuration runs REPEAT times, interleaved; the time is the command's, start
to end (a cluster's start-up included, as a user waits for it). Prints a
Markdown table of the medians.

    python benchmarks/experiments/sweep_engines.py [REPEAT [DURATION]]

DURATION (default 0.5 s) makes the runs longer: the cluster's start-up then
counts for less.
"""
from __future__ import annotations

import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SWEEP = {
    "format": "sphfluid-sweep/1",
    "name": "20 short dam breaks",
    "scene": str(ROOT / "scenes" / "dam_break.json"),
    "vary": {"solver.time_step": {"linspace": [0.0001, 0.0003, 5]},
             "fluid_regions[0].max[1]": {"linspace": [1.0, 2.0, 4]}},
    "duration": 0.5,
}


def main() -> None:
    from sphfluid.sweep import cores

    repeat = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    SWEEP["duration"] = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
    n = cores()
    configs = {
        f"loop in one process, {n} threads a run": ["--workers", "0", "--threads", str(n)],
        "loop in one process, 1 thread a run": ["--workers", "0", "--threads", "1"],
        f"Dask, 1 worker with {n} threads": ["--workers", "1", "--threads", str(n)],
        f"Dask, {n} workers with 1 thread (the default)": [],
    }
    times: dict[str, list[float]] = {k: [] for k in configs}
    runs: dict[str, list[float]] = {k: [] for k in configs}
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "sweep.json"
        spec.write_text(json.dumps(SWEEP))
        for _ in range(repeat):
            for name, options in configs.items():
                out = Path(tmp) / "out"
                shutil.rmtree(out, ignore_errors=True)
                started = time.perf_counter()
                done = subprocess.run([sys.executable, "-m", "sphfluid", "sweep", str(spec),
                                       "--out", str(out), "--quiet", *options], check=True,
                                      stdout=subprocess.PIPE, text=True)
                times[name].append(time.perf_counter() - started)
                # "20 run(s) in 6.1 s (...)": the runs alone, after the cluster started
                runs[name].append(float(re.search(r"run\(s\) in ([0-9.]+) s", done.stdout)[1]))
                print(f"{name}: {times[name][-1]:.2f} s, runs {runs[name][-1]:.2f} s",
                      file=sys.stderr)
    print(f"20 runs of {SWEEP['duration']:g} s:\n")
    print(f"| configuration ({n} cores) | command, s | runs alone, s | runs/s (command) |")
    print("|---|---|---|---|")
    for name, t in times.items():
        m = statistics.median(t)
        print(f"| {name} | {m:.2f} | {statistics.median(runs[name]):.2f} | {20 / m:.2f} |")
    print(f"\n(medians of {repeat}, interleaved; 'runs alone' leaves out the start-up of "
          "Python, the check of the sweep and the cluster's start)")


if __name__ == "__main__":
    main()
