"""The wheel's cores against a source build, interleaved (docs/install.md).

    python benchmarks/experiments/wheel_cores.py --native PYTHON --wheel PYTHON [--rounds 5]

PYTHON are interpreters with sphfluid installed: --native a source build
(-march=native), --wheel a wheel with a core per SIMD level. Each round runs
`sphfluid bench` on the dam break (2 threads, fixed dt) once per configuration:
the source build, then the wheel with SPHFLUID_SIMD forced to avx512, avx2 and
baseline (the levels this CPU runs), in an order that rotates each round, for
each method and size. Prints the median steps/s of each and, for the wheel's
cores, the median over the rounds of its share of the source build's in the
same round (the machine's speed drifts between rounds), as a Markdown table.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

SIZES = {10_000: (3000, 100), 1_000_000: (60, 10)}  # particles: (steps, warm-up steps)


def steps_per_s(python: str, simd: str | None, method: str, particles: int) -> float:
    steps, warmup = SIZES[particles]
    env = {k: v for k, v in os.environ.items() if k != "SPHFLUID_SIMD"}
    if simd is not None:
        env["SPHFLUID_SIMD"] = simd
    out = subprocess.run([python, "-m", "sphfluid", "bench", "--method", method,
                          "--particles", str(particles), "--threads", "2", "--steps", str(steps),
                          "--warmup", str(warmup), "--repeat", "1"],
                         env=env, capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) > 12 and cells[1] == "2" and cells[2] == "double":
            # steps / wall s: the steps/s column is rounded to a whole number
            return float(cells[4].replace(",", "")) / float(cells[5])
    raise RuntimeError(f"no 2-thread row in:\n{out}")


def levels(python: str) -> list[str]:
    code = "import sphfluid._cpu as c; f = c.features(); print(*[k for k in ('avx512', 'avx2') if f[k]])"
    found = subprocess.run([python, "-c", code], capture_output=True, text=True,
                           check=True).stdout.split()
    return [*found, "baseline"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--native", required=True)
    ap.add_argument("--wheel", required=True)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--methods", default="seed,wcsph")
    ap.add_argument("--sizes", default="10000,1000000")
    args = ap.parse_args()
    configs = [("source build (-march=native)", args.native, None)]
    configs += [(f"wheel, {lv} core", args.wheel, lv) for lv in levels(args.wheel)]
    cases = [(m, int(n)) for m in args.methods.split(",") for n in args.sizes.split(",")]
    times: dict[tuple, list[float]] = {}
    for r in range(args.rounds):
        for method, n in cases:
            order = configs[r % len(configs):] + configs[:r % len(configs)]
            for name, python, simd in order:
                s = steps_per_s(python, simd, method, n)
                times.setdefault((method, n, name), []).append(s)
                print(f"round {r + 1}: {method} {n:,} {name}: {s:,.1f} steps/s", file=sys.stderr)
    print(f"Medians of {args.rounds} interleaved rounds, 2 threads: steps/s (the median of "
          "each round's share of the source build's):\n")
    print("| method | particles | " + " | ".join(name for name, _, _ in configs) + " |")
    print("|---|---:|" + "---:|" * len(configs))
    for method, n in cases:
        base = times[(method, n, configs[0][0])]
        cells = []
        for name, _, _ in configs:
            mine = times[(method, n, name)]
            share = statistics.median(a / b for a, b in zip(mine, base))
            cells.append(f"{statistics.median(mine):,.1f}"
                         + (f" ({share:.1%})" if name != configs[0][0] else ""))
        print(f"| {method} | {n:,} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
