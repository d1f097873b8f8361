"""The engine many runs go through (sweep, dataset, stress, validate): one after
another in this process, or on a local Dask cluster, with the same results."""
from __future__ import annotations

import re
import sys

import pytest

from sphfluid import engine, stress
from sphfluid.cli import main


def square(x):
    if x < 0:
        raise ValueError(f"negative: {x}")
    return x * x


def test_in_process_runs_in_order():
    got = []
    engine.execute(square, [3, 1, 2], lambda place, r: got.append((place, r)))
    assert got == [(0, 9), (1, 1), (2, 4)]


def test_on_two_workers_each_result_comes_with_its_place_and_a_failure_is_one_row():
    got = {}
    slots = [0]
    engine.execute(square, [3, -1, 2, 5], got.__setitem__, workers=2, slots=slots,
                   failed=lambda place, e: f"failed: {e}")
    assert got == {0: 9, 1: "failed: negative: -1", 2: 4, 3: 25}
    assert slots[0] == 2
    with pytest.raises(ValueError, match="negative"):  # without `failed`, the error
        engine.execute(square, [-1], lambda place, r: None, workers=1)


def test_without_dask_the_runs_that_need_it_are_refused_before_any_runs(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # (import fails)
    engine.check(0, None)  # in this process: no Dask needed
    with pytest.raises(engine.EngineError, match=r"sphfluid\[sweep\]"):
        engine.check(2, None)
    with pytest.raises(engine.EngineError):
        engine.check(0, "tcp://127.0.0.1:8786")


def test_where_and_the_options_that_say_it():
    assert engine.where(0, 1, None) == "one after another in this process"
    assert engine.where(3, 1, None) == "on 3 local worker process(es)"
    assert engine.where(None, 1, "tcp://h:1") == "on the scheduler at tcp://h:1"
    assert engine.local_workers(None, engine.cores()) == 1
    assert engine.options(0, None, None) == ""
    assert engine.options(2, 1, None) == " --workers 2 --threads 1"
    assert engine.options(0, None, "tcp://h:1") == " --scheduler tcp://h:1"
    assert [engine.threads_per_run(None, 0, None), engine.threads_per_run(None, 2, None),
            engine.threads_per_run(None, 0, "tcp://h:1"), engine.threads_per_run(2, 2, None)] == \
        [None, 1, 1, 2]


def test_only_the_matrix_commands_take_the_engine_options(capsys):
    with pytest.raises(SystemExit):  # (argparse: an unknown option)
        main(["view", "scene.json", "--workers", "2"])
    assert "unrecognized arguments: --workers 2" in capsys.readouterr().err


def _report_without_times(text: str) -> str:
    """The report's tables without what depends on the clock and the command."""
    lines = []
    for line in text.splitlines():
        if line.startswith("Machine:"):
            continue
        cells = line.split(" | ")
        if line.startswith("| ") and len(cells) == 6 and cells[-1].rstrip(" |")[-1:].isdigit():
            line = " | ".join(cells[:-1])  # the wall-time column
        lines.append(line)
    return "\n".join(lines)


def test_stress_on_two_workers_gives_the_tables_of_a_run_in_this_process(
        tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(stress, "plan", lambda full: stress.Plan(
        ks=[100.0, 1e6], dts=[1e-2], spacing=0.1, duration=0.1, max_wall=60.0, tank_steps=200))
    violent = stress.violent_scenes

    def two(tank_steps):
        scenes = violent(tank_steps)
        jet = scenes["jet at 20 m/s into a wall"]
        jet["duration"] = 0.02
        return {"jet at 20 m/s into a wall": jet,
                f"tank at rest, {tank_steps:,} steps": scenes[f"tank at rest, {tank_steps:,} steps"]}

    monkeypatch.setattr(stress, "violent_scenes", two)
    reports = []
    for workers in ("0", "2"):
        code = main(["stress", "--quick", "--out", str(tmp_path), "--threads", "1",
                     "--workers", workers])
        out = capsys.readouterr().out
        assert code == 0
        reports.append(out)
    assert "--workers 2 --threads 1" in reports[1].splitlines()[0]
    assert "caught (" in reports[0]  # k = 1e6 at dt = 1e-2 blows up: the table can tell
    assert _report_without_times(reports[0]) == _report_without_times(reports[1])
    assert len(re.findall(r"^\| (seed|wcsph) \| ", reports[0], re.M)) == 4  # 2 scenes x 2


def test_validate_on_two_workers_gives_the_errors_of_a_run_in_this_process(tmp_path, capsys):
    from sphfluid.validation.runner import run_suite

    names, methods = ["poiseuille", "dam_break"], ["seed", "wcsph"]
    serial = run_suite(names, "quick", methods, 1, lambda line: None)
    pooled = run_suite(names, "quick", methods, 1, lambda line: None, workers=2)
    assert [(r.case, r.method, r.n) for r in serial] == [(r.case, r.method, r.n) for r in pooled]
    assert len(serial) == 2 * 2 * 3
    assert [(r.error, r.steps, r.particles) for r in serial] == \
        [(r.error, r.steps, r.particles) for r in pooled]
    code = main(["validate", "--quick", "--case", "poiseuille", "--method", "wcsph",
                 "--workers", "2", "--out", str(tmp_path)])
    assert code == 0
    assert "sphfluid validate --quick --case poiseuille --method wcsph --workers 2" in \
        capsys.readouterr().out
