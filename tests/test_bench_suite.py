"""bench --suite's pieces on a small case (the suite itself is a long run)."""
from __future__ import annotations

import pytest

from sphfluid import bench_suite


def test_one_configuration_reports_speed_memory_and_the_front():
    r = bench_suite.measure_one("dam", "seed", 1000, 1)
    assert r["particles"] > 900 and r["steps"] >= 20 and r["steps_per_s"] > 0
    assert 100 < r["bytes_per_particle"] < 5000  # the solver's own arrays
    assert set(r["phases_us"]) >= {"sort", "neighbours", "forces", "integrate"}
    # 2,200 steps of 4.5e-4 s: the front has crossed the 4 m tank by then
    assert abs(r["Z"] - r["Z_ref"]) < 0.3 and r["Z"] <= 4.05


@pytest.mark.parametrize("method,n", [("wcsph", 1000), ("seed", 1000), ("seed", 10000),
                                      ("seed-float", 1000)])
def test_bare_loop_has_no_walls_and_no_viscosity_and_completes(method, n):
    """Timed within the steps the seed's free block holds (it blew up in the
    suite's tables when the bare loop ran 2,200 steps)."""
    scene = bench_suite.bare_scene(n, method)
    assert scene["walls"] == [] and scene["fluid"]["viscosity"] == 0.0
    r = bench_suite.measure_one("bare", method, n, 1)
    assert r["phases_us"]["ghosts"] == 0.0
    assert "Z" not in r
    assert 150 <= r["steps"] <= bench_suite.BARE_STEPS - bench_suite.BARE_STEPS // 10


def test_tables_show_efficiency_against_one_thread():
    one = {"kind": "dam", "method": "seed", "threads": 1, "particles": 1000, "steps": 100,
           "wall": 1.0, "steps_per_s": 100.0, "pps": 1e5, "ns_per_ps": 1e4,
           "phases_us": {"sort": 1.0}, "pairs_per_particle": 10.0, "bytes_per_particle": 190.0,
           "peak_bytes_per_particle": 400.0, "T": 0.1, "Z": 1.0, "Z_ref": 1.0}
    two = dict(one, threads=2, steps_per_s=180.0, wall=100 / 180)
    table = bench_suite.throughput_table([one, two])
    assert "| 90% |" in table
    assert "failed" in bench_suite.throughput_table([{"kind": "dam", "method": "seed",
                                                      "threads": 2, "target": 1000,
                                                      "error": "over the time limit"}])
    # A small scene asked for 2 threads runs on 1: no efficiency, and said so.
    small = bench_suite.throughput_table([one, dict(two, in_use=1, steps_per_s=100.0)])
    assert "| 2 (1 in use) |" in small and "%" not in small
    assert "| 2 (1 in use) |" in bench_suite.phase_table([dict(two, in_use=1)])
    assert bench_suite.steps_for(1_000_000) == (5, 20)
    assert bench_suite.steps_for(1_000)[1] == 2000


def test_repeats_report_the_median_run_and_the_range():
    runs = [{"steps_per_s": v, "wall": 1 / v, "tag": v} for v in (90.0, 120.0, 100.0)]
    m = bench_suite.median_of(runs)
    assert m["tag"] == 100.0 and m["range"] == (90.0, 120.0) and m["failed"] == 0
    # By wall time for the time to solution: the middle run, not the mean.
    w = bench_suite.median_of(runs, key="wall", higher_is_faster=False)
    assert w["tag"] == 100.0
    # A failed run is counted and left out; all failed: the failure itself.
    m = bench_suite.median_of(runs[:2] + [{"error": "crashed"}])
    assert m["failed"] == 1 and m["tag"] == 90.0 and m["range"] == (90.0, 120.0)
    assert "wall" not in bench_suite.median_of([{"error": "crashed"}] * 2)
    # The time to solution's "error" is its front error, not a failure.
    tts = [{"wall": w, "error": 0.2} for w in (0.6, 0.5, 0.7)]
    m = bench_suite.median_of(tts, key="wall", higher_is_faster=False)
    assert m["wall"] == 0.6 and m["failed"] == 0 and m["range"] == (0.5, 0.7)
    row = {"kind": "dam", "method": "seed", "threads": 1, "particles": 1000, "steps": 100,
           "wall": 1.0, "steps_per_s": 100.0, "pps": 1e5, "ns_per_ps": 1e4,
           "phases_us": {"sort": 1.0}, "pairs_per_particle": 10.0, "bytes_per_particle": 190.0,
           "peak_bytes_per_particle": 400.0, "runs": 3, "failed": 1, "range": (90.0, 120.0)}
    assert "| 90.0–120.0 (1 failed) |" in bench_suite.throughput_table([row])
