"""Timing of the dam break at a geometric range of N (marker `bench`, off by default).

Run with `pytest -m bench -s benchmarks`. Prints particle-steps/s next to
the front position against Martin & Moyce; asserts nothing about speed (this
machine is shared and noisy: compare ratios within one run).
"""
from __future__ import annotations

import pytest
import sphfluid
from sphfluid.bench import run_case


@pytest.mark.bench
@pytest.mark.parametrize("n", [1_000, 3_000, 10_000, 30_000])
@pytest.mark.parametrize("threads", [1, 2])
def test_dam_break_speed(n, threads):
    r = run_case(n, threads, steps=300, warmup=30)
    print(f"\n{sphfluid._core.build_info} threads={threads} N={r['particles']:,}: "
          f"{r['steps_per_s']:,.0f} steps/s, {r['pps'] / 1e6:.2f} M particle-steps/s, "
          f"{r['ns_per_ps']:.1f} ns/particle-step; front Z {r['Z']:.2f} at T {r['T']:.2f} "
          f"(Martin & Moyce {r['Z_ref']:.2f})")
    assert r["steps"] == 300
