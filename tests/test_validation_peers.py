"""sphfluid validate --peers: PySPH's runs as rows of our tables and points of our
plots, the verdict on each case (a point of ours with both a lower error and a
lower wall time than each peer scheme's best), progress and timeouts, and the
clean refusal when PySPH cannot run. A stand-in replaces the driver's run_case
(benchmarks/peers/pysph_cases.py), so none of this needs PySPH.
"""
from __future__ import annotations

import math

import pytest
from conftest import BENCHMARKS, benchmark_module
from sphfluid.cli import main
from sphfluid.validation import peers, runner
from sphfluid.validation.cases import CASES, Result

# the module `validate --peers --benchmarks-dir BENCHMARKS` loads (load_benchmark
# returns the same module for the same file)
driver = benchmark_module("peers/pysph_cases.py")
PEERS = ["--peers", "--benchmarks-dir", str(BENCHMARKS)]


def fake_run(error: float = 0.5, wall: float = 100.0, failure: str = "", calls=None,
             cpu_share: float = 1.0):
    """A stand-in for the driver's run_case: error and wall time in proportion to
    10/n and n/10, its threads running `cpu_share` of the time; the run at the
    finest quick n fails with `failure` when it is given."""

    def run_case(case, scheme, n, threads=2, timeout=None, *, progress=None, **_):
        if calls is not None:
            calls.append((case, scheme, n, threads, timeout))
        if progress is not None:
            progress(0.5, 1.0)
        failed = bool(failure) and n == max(CASES[case].resolutions["quick"])
        return {"peer": "pysph", "version": "1.0b2", "case": case, "scheme": scheme, "n": n,
                "threads": threads, "particles": 10 * n, "steps": 100, "wall_s": wall * n / 10,
                "cpu_s": cpu_share * threads * wall * n / 10, "setup_s": 1.0,
                "error": math.nan if failed else error * 10 / n,
                "metrics": {} if failed else {"centreline v / v_max at t = 1 s": 1.01},
                "failure": failure if failed else "", "note": f"the example, n = {n}."}

    return run_case


@pytest.fixture
def fake_pysph(monkeypatch):
    """PySPH 1.0b2 'installed', its runs replaced by fake_run(); returns the calls."""
    calls: list[tuple] = []
    monkeypatch.setattr(driver, "availability", lambda timeout=None: ("1.0b2", ""))
    monkeypatch.setattr(driver, "run_case", fake_run(calls=calls))
    return calls


def validate(tmp_path, *extra: str) -> tuple[int, str]:
    md = tmp_path / "VALIDATION.md"
    code = main(["validate", "--quick", "--case", "poiseuille", "--method", "wcsph",
                 "--out", str(tmp_path / "plots"), "--write", str(md), *extra])
    return code, md.read_text() if md.exists() else ""


def test_peer_rows_are_in_the_same_table_with_their_measurements(tmp_path, fake_pysph,
                                                                 capsys):
    code, text = validate(tmp_path, *PEERS)
    assert code == 0
    # the same resolutions as ours, on every core unless --threads says otherwise
    assert [(c, s, n) for c, s, n, _, _ in fake_pysph] == [
        ("poiseuille", "tvf", n) for n in CASES["poiseuille"].resolutions["quick"]]
    assert all(t == peers.DEFAULT_TIMEOUT for *_, t in fake_pysph)
    table = text[text.index("| method |"):]
    assert "| wcsph | 10 |" in table
    # label, n, our spacing, particles, steps and wall time as measured, the error, no bound
    assert "| PySPH 1.0b2 TVF | 10 | 0.0001 | 100 | 100 | 100.00 | 100 | 0.5 | — | 1.01 |" in table
    assert "| PySPH 1.0b2 TVF | 20 | 5e-05 | 200 | 100 | 200.00 |" in table
    assert "sphfluid validate --quick --case poiseuille --method wcsph --peers" in text
    assert "PySPH 1.0b2 TVF, n = 20: the example, n = 20." in text  # its set-up
    err = capsys.readouterr().err
    assert "poiseuille    PySPH 1.0b2 TVF n=10   running" in err
    assert "    100 particles     100 steps  100.00 s  error 0.5" in err
    runs = 2 * len(CASES["poiseuille"].resolutions["quick"])  # ours and the peer's
    assert "100%|" in err and f"| {runs}/{runs} runs [" in err


def test_peer_points_are_in_the_same_plot(tmp_path, fake_pysph):
    pytest.importorskip("matplotlib")
    ours = [Result("poiseuille", "wcsph", n, 1e-3 / n, wall=0.1 * n, error=0.01 / n)
            for n in (10, 20)]
    theirs = [peers.to_result(fake_run()("poiseuille", "tvf", n), "PySPH 1.0b2 TVF")
              for n in (10, 20)]
    series = runner.error_time_series(ours + theirs)
    assert [(label, style) for label, style, _, _ in series] == [
        ("wcsph", "o-"), ("PySPH 1.0b2 TVF", "s--")]
    assert [r.wall for r in series[1][3]] == [100.0, 200.0]
    png = tmp_path / "plot.png"
    assert runner.plot_case("poiseuille", ours + theirs, png)
    assert png.stat().st_size > 10_000
    code, _ = validate(tmp_path, *PEERS)
    assert code == 0 and (tmp_path / "plots" / "validation_poiseuille.png").exists()


def test_the_report_says_a_point_of_ours_beats_the_peers_best(tmp_path, fake_pysph):
    code, text = validate(tmp_path, *PEERS)
    assert code == 0
    # ours (wcsph, quick) is well under 0.25 % in seconds; the stand-in's best is
    # 0.25 in 200 s
    assert "**Against the peers**" in text and ": yes, against all 1." in text
    assert "- PySPH 1.0b2 TVF: best point n = 20, error 0.25 in 200.00 s; beaten by wcsph" \
        in text


def test_a_timed_out_peer_run_is_a_row_not_the_end(tmp_path, monkeypatch):
    monkeypatch.setattr(driver, "availability", lambda timeout=None: ("1.0b2", ""))
    monkeypatch.setattr(driver, "run_case", fake_run(
        failure="timed out after 5 s at 40 % of its simulated time"))
    code, text = validate(tmp_path, *PEERS, "--peer-timeout", "5")
    assert code == 0  # our bounds still decide
    assert "| PySPH 1.0b2 TVF | 20 | 5e-05 | 200 | 100 | 200.00 | 100 | timed out | — |" in text
    assert ("- PySPH 1.0b2 TVF, n = 20: did not complete: `timed out after 5 s at 40 % of "
            "its simulated time`") in text
    assert "--peers --peer-timeout 5" in text
    assert "best point n = 15" in text  # the completed runs still count


def test_long_runs_print_progress(monkeypatch):
    monkeypatch.setattr(peers, "PROGRESS_EVERY", 0.0)
    monkeypatch.setattr(driver, "run_case", fake_run())
    lines: list[str] = []
    results = peers.run_peers(driver, "1.0b2", ["taylor_green", "dam_break"], "quick", 2,
                              60.0, lines.append)
    assert [r.method for r in results] == [
        driver.label(s, "1.0b2") for s in ("edac", "tvf", "wcsph") for _ in (20, 30, 40)]
    assert all(r.peer == "pysph" and r.case == "taylor_green" for r in results)
    assert "taylor_green  PySPH 1.0b2 EDAC n=20   running (2 threads, timeout 60 s)" in lines
    assert "taylor_green  PySPH 1.0b2 EDAC n=20    50 % of its simulated time after 1 s" \
        in lines
    assert "dam_break     PySPH has no example of this case: ours only" in lines


def test_a_peer_run_on_a_busy_machine_is_flagged(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(driver, "availability", lambda timeout=None: ("1.0b2", ""))
    monkeypatch.setattr(driver, "run_case", fake_run(cpu_share=0.3))
    code, text = validate(tmp_path, *PEERS, "--threads", "2")
    assert code == 0
    assert ("- PySPH 1.0b2 TVF, n = 10: its threads ran 30% of its wall time (CPU time / "
            "(threads x wall time)): other jobs held the cores") in text
    assert "error 0.5 (busy: its threads ran 30% of the time)" in capsys.readouterr().err
    monkeypatch.setattr(driver, "run_case", fake_run(cpu_share=0.9))
    code, text = validate(tmp_path, *PEERS)
    assert code == 0 and "other jobs held the cores" not in text


def test_a_case_without_a_pysph_example_says_so(tmp_path, fake_pysph):
    md = tmp_path / "V.md"
    code = main(["validate", "--quick", "--case", "droplet", "--method", "wcsph", *PEERS,
                 "--out", str(tmp_path), "--write", str(md)])
    assert code == 0 and fake_pysph == []
    assert "PySPH has no example of this case: no peer rows." in md.read_text()


def r(method: str, n: int, error: float, wall: float, *, peer: str = "", failure: str = ""):
    return Result("taylor_green", method, n, 1.0 / n, wall=wall, error=error, peer=peer,
                  failure=failure)


def test_beating_needs_both_a_lower_error_and_a_lower_wall_time():
    theirs = [r("P", 25, 0.10, 5.0, peer="pysph"), r("P", 50, 0.05, 20.0, peer="pysph"),
              r("P", 100, math.nan, 0.0, peer="pysph", failure="timed out after 9 s")]
    best = peers.best_point(theirs)
    assert best.n == 50  # its lowest error, not its finest or its fastest run
    slow = r("wcsph", 100, 0.01, 25.0)
    coarse = r("wcsph", 25, 0.08, 2.0)
    equal_time = r("seed", 50, 0.04, 20.0)
    assert peers.beating([slow, coarse, equal_time], best) is None
    fast = r("wcsph", 50, 0.03, 10.0)
    faster = r("seed", 40, 0.049, 8.0)
    assert peers.beating([slow, fast, faster, coarse], best) is faster  # the fastest
    failed = r("wcsph", 60, math.nan, 1.0, failure="[check: energy]")
    assert peers.beating([failed], best) is None
    assert peers.best_point(theirs[2:]) is None


def test_verdict_lines():
    ours = [r("wcsph", 25, 0.05, 1.0), r("wcsph", 50, 0.02, 4.0)]
    edac = [r("PySPH 1.0b2 EDAC", 25, 0.06, 5.0, peer="pysph")]
    tvf = [r("PySPH 1.0b2 TVF", 25, 0.01, 50.0, peer="pysph")]
    gone = [r("PySPH 1.0b2 WCSPH", 25, math.nan, 0.0, peer="pysph", failure="timed out")]
    assert peers.verdict(ours) == []
    text = "\n".join(peers.verdict(ours + edac + gone))
    assert "yes against the 1 that completed a run (PySPH 1.0b2 WCSPH: none completed)" in text
    assert ("- PySPH 1.0b2 EDAC: best point n = 25, error 0.06 in 5.00 s; beaten by wcsph "
            "n = 25, error 0.05 in 1.00 s.") in text
    assert "- PySPH 1.0b2 WCSPH: no completed run to compare with." in text
    text = "\n".join(peers.verdict(ours + edac + tvf))
    assert ": no: not against PySPH 1.0b2 TVF." in text
    assert ("- PySPH 1.0b2 TVF: best point n = 25, error 0.01 in 50.00 s; no point of ours "
            "has both a lower error and a lower wall time (our lowest error: wcsph n = 50, "
            "error 0.02 in 4.00 s).") in text
    assert "not decided: no peer run completed" in "\n".join(peers.verdict(ours + gone))


def test_without_pysph_peers_is_a_one_line_error(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(driver, "PEER_MODULE", "sphfluid_no_such_peer")
    code = main(["validate", "--quick", "--case", "poiseuille", *PEERS, "--out", str(tmp_path)])
    assert code == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing ran
    assert captured.err == ("error: --peers: PySPH cannot run here: sphfluid_no_such_peer is "
                            "not installed (pip install pysph==1.0b2; docs/peers.md)\n")


def test_a_pysph_that_fails_to_import_is_a_one_line_error(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(driver, "PEER_MODULE", "json")  # found, but has no json.solver
    code = main(["validate", "--quick", "--case", "poiseuille", *PEERS, "--out", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --peers: PySPH cannot run here: importing json failed "
                          "(exit code 1: ModuleNotFoundError")
    assert err.count("\n") == 1 and "Traceback" not in err


def test_peer_options_are_refused_without_peers_and_a_missing_driver_folder(capsys,
                                                                            tmp_path):
    assert main(["validate", "--quick", "--peer-timeout", "5"]) == 2
    assert capsys.readouterr().err == ("error: --peer-timeout and --benchmarks-dir go with "
                                       "--peers\n")
    code = main(["validate", "--quick", "--peers", "--benchmarks-dir", str(tmp_path / "no")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --peers: --benchmarks-dir ") and err.count("\n") == 1
