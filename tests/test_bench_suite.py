"""bench --suite's pieces on a small case (the suite itself is a long run)."""
from __future__ import annotations

from types import SimpleNamespace

import pytest
from conftest import BENCHMARKS
from sphfluid import bench_suite
from sphfluid.bench import BENCHMARKS_ENV


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


def _peer_result(name, configuration, wall, error, crashed=""):
    return SimpleNamespace(name=name, configuration=configuration, method=configuration.upper(),
                           version="1.0", particles=10_011, steps=1000, wall_s=wall,
                           particle_steps_per_s=10_011 * 1000 / wall, front_error=error,
                           crashed=crashed, note=f"{configuration} note.")


def test_peer_table_has_a_row_per_configuration_and_names_each_peers_fastest():
    results = {("a", "slow"): _peer_result("a", "slow", 60.0, 0.24),
               ("a", "fast"): _peer_result("a", "fast", 17.0, 0.31),
               ("a", "faster-but-crashed"): _peer_result("a", "faster-but-crashed", 5.0, 0.2,
                                                         "killed by SIGSEGV at t = 0.5 s"),
               ("b", "only"): _peer_result("b", "only", 40.0, 0.25, "killed by SIGSEGV")}
    harness = SimpleNamespace(
        available=lambda: {"a": None, "b": None, "c": "not installed"},
        configurations=lambda name: tuple(c for p, c in results if p == name),
        run_peer=lambda name, configuration, **kw: results[(name, configuration)])
    ours = [{"method": "seed", "particles": 990, "steps": 663, "wall": 0.03, "error": 0.26},
            {"method": "wcsph", "particles": 10_011, "steps": 12_216, "wall": 5.2, "error": 0.16}]
    lines = bench_suite.run_peers(harness, 10_000, 1.0, ours, log=lambda line: None)
    rows = [line for line in lines if line.startswith("| a ") or line.startswith("| b ")]
    assert [r.split(" | ")[1] for r in rows] == ["slow", "fast", "faster-but-crashed", "only"]
    assert "| 17.0 |" in rows[1] and "| 0.310 |" in rows[1]
    # ours to an error no worse than 0.31: the seed at 990 particles; than 0.24: wcsph
    assert "0.03 (seed, 990 particles; 567x faster)" in rows[1]
    assert "5.20 (wcsph, 10,011 particles; 12x faster)" in rows[0]
    assert any(line.startswith("| c |") and "skipped: not installed" in line for line in lines)
    fastest = [line for line in lines if line.startswith("- ")]
    assert fastest[0].startswith("- a: `fast`, 17.0 s at front error 0.310")
    assert fastest[1] == "- b: no configuration reached the end time."
    assert "Ours at the same particle count: wcsph 5.20 s" in lines[-1]


def test_suite_finds_the_peer_harness_in_a_source_checkout(monkeypatch):
    monkeypatch.delenv(BENCHMARKS_ENV, raising=False)
    peers = bench_suite.load_peers()
    assert peers.__file__ == str(BENCHMARKS / "peers" / "peers.py")
    assert set(peers.PEERS) == {"pysph", "splishsplash"}
    assert bench_suite.load_peers() is peers  # loaded once
    monkeypatch.setenv(BENCHMARKS_ENV, str(BENCHMARKS))
    assert bench_suite.load_peers() is peers


def test_benchmarks_found_from_a_checkouts_root_with_the_package_installed(
        monkeypatch, tmp_path):
    """A non-editable install run from the checkout's root finds its benchmarks/."""
    from sphfluid import bench

    monkeypatch.delenv(BENCHMARKS_ENV, raising=False)
    monkeypatch.setattr(bench, "__file__", str(tmp_path / "site-packages" / "sphfluid" / "bench.py"))
    monkeypatch.chdir(BENCHMARKS.parent)
    assert bench.benchmarks_dir().resolve() == BENCHMARKS.resolve()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(bench.BenchmarksNotFoundError, match="run from the checkout's root"):
        bench.benchmarks_dir()


def test_suite_with_peers_and_no_benchmarks_folder_exits_2_before_running(
        monkeypatch, tmp_path, capsys):
    """An installed wheel has no benchmarks/: say so, no traceback, nothing run."""
    from sphfluid import bench
    from sphfluid.cli import main

    monkeypatch.setattr(bench_suite, "run_throughput",
                        lambda *a, **k: pytest.fail("the suite ran"))
    monkeypatch.delenv(BENCHMARKS_ENV, raising=False)
    monkeypatch.chdir(tmp_path)  # not a checkout's root
    wheel = tmp_path / "site-packages" / "sphfluid"
    monkeypatch.setattr(bench, "__file__", str(wheel / "bench.py"))
    assert main(["bench", "--suite", "--peers"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --peers: no benchmarks/ folder") and "Traceback" not in err
    assert "not in the wheel" in err and "--benchmarks-dir" in err
    assert main(["bench", "--suite", "--peers", "--benchmarks-dir", str(tmp_path / "no")]) == 2
    assert "--benchmarks-dir" in capsys.readouterr().err
    monkeypatch.setenv(BENCHMARKS_ENV, str(tmp_path))  # a folder without the harness
    assert main(["bench", "--suite", "--peers"]) == 2
    assert "peers.py is missing" in capsys.readouterr().err


def test_the_suite_shows_a_bar_over_its_runs(monkeypatch, capsys):
    from sphfluid.cli import main

    row = {"particles": 1000, "steps": 100, "wall": 1.0, "steps_per_s": 100.0,
           "ns_per_ps": 1e4, "bytes_per_particle": 190.0, "error": 0.1}
    monkeypatch.setattr(bench_suite, "run_child", lambda *a, **k: dict(row))
    monkeypatch.setattr(bench_suite, "time_to_solution", lambda *a, **k: dict(row))
    monkeypatch.setattr(bench_suite, "suite_report", lambda *a, **k: "the report")
    assert main(["bench", "--suite", "--sizes", "1000", "--tts-sizes", "1000", "--method",
                 "seed", "--repeat", "2"]) == 0
    err = capsys.readouterr().err
    # 2 rounds of the dam break and the bare loop on 1 and 2 threads, and the
    # time to solution: 10 runs, each with its line above the bar
    assert "| 10/10 runs [" in err and err.count("[2/2] ") == 5


def test_report_names_the_command_that_reproduces_it(tmp_path):
    """The report's command carries every option that chose what was run."""
    from types import SimpleNamespace

    args = SimpleNamespace(out=tmp_path, write=None, sizes="1000,10000", tts_sizes="10000",
                           method="dfsph", method_given=True)
    text = bench_suite.suite_report(args, [], [], 1, 0.0)
    assert ("`sphfluid bench --suite --method dfsph --sizes 1000,10000 --tts-sizes 10000 "
            "--repeat 1`") in text
    args.method_given, args.tts_sizes = False, None
    text = bench_suite.suite_report(args, [], [], 3, 0.0)
    assert "`sphfluid bench --suite --sizes 1000,10000`" in text
