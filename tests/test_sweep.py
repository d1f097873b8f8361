"""sphfluid sweep: sweep files checked by JSON path, runs as Dask tasks, one row
per run, a blow-up a row, and a sweep run again runs only what is missing."""
from __future__ import annotations

import copy
import json
import os

import pytest
from conftest import BASE_SCENE
from sphfluid.cli import main
from sphfluid.sweep import SweepError, load_sweep, read_results, run_sweep


def _sweep(**extra) -> dict:
    return {"format": "sphfluid-sweep/1", "scene": copy.deepcopy(BASE_SCENE), **extra}


# the fourth run blows up at its first step (test_check's boom scene)
FOUR = _sweep(combine="zip", duration=0.02, vary={
    "fluid.gas_constant": [250.0, 250.0, 300.0, 1e306],
    "fluid.viscosity": [0.5, 0.5, 0.5, 0.0],
    "solver.time_step": [0.001, 0.002, 0.001, 0.01]})


def test_four_runs_on_two_worker_processes_one_blowing_up(tmp_path):
    pytest.importorskip("dask.distributed")
    outcome = run_sweep(load_sweep(FOUR), tmp_path, workers=2, threads=1, progress=False)
    assert outcome.ran == 4 and outcome.statuses == {"ok": 3, "blow-up": 1}
    rows = read_results(tmp_path / "results.csv")
    assert [r["run"] for r in rows] == ["0", "1", "2", "3"]
    assert [r["status"] for r in rows] == ["ok", "ok", "ok", "blow-up"]
    assert all(r["error"] == "" for r in rows[:3]) and "step 1" in rows[3]["error"]  # the guard's
    assert rows[0]["steps"] == "20" and rows[1]["steps"] == "10"  # 0.02 s at 1 and 2 ms
    assert float(rows[2]["param:fluid.gas_constant"]) == 300.0
    assert all(r["particles"] == "100" and r["host"] for r in rows[:3])
    assert all(int(r["pid"]) != os.getpid() for r in rows)  # Dask's worker processes ran them


def test_runs_on_an_existing_cluster_by_its_address(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                                  dashboard_address=":0") as cluster:
        outcome = run_sweep(load_sweep(_sweep(duration=0.01, vary={"fluid.viscosity": [0.4, 0.5]})),
                            tmp_path, scheduler=cluster.scheduler_address, progress=False)
    assert outcome.statuses == {"ok": 2}
    assert all(int(r["pid"]) != os.getpid() for r in read_results(tmp_path / "results.csv"))


def test_rows_match_a_plain_run_of_the_same_scene(tmp_path):
    """A sweep's row holds what `sphfluid run` would say of the same scene."""
    from sphfluid import Simulation, load_scene

    sweep = load_sweep(_sweep(duration=0.02, vary={"solver.time_step": [0.001]}))
    run_sweep(sweep, tmp_path, workers=0, progress=False)
    row = read_results(tmp_path / "results.csv")[0]
    sim = Simulation(load_scene(sweep.runs[0].scene), threads=1)
    sim.advance_to(0.02)
    assert int(row["steps"]) == sim.step_count == 20
    assert float(row["max_speed"]) == sim.stats()["max_speed"]


def test_a_sweep_run_again_runs_only_what_is_missing(tmp_path):
    spec = _sweep(duration=0.01, vary={"solver.time_step": [0.001, 0.002],
                                       "fluid.viscosity": [0.4, 0.5]})
    sweep = load_sweep(spec)
    assert len(sweep.runs) == 4
    first = run_sweep(sweep, tmp_path, workers=0, progress=False)
    assert (first.ran, first.skipped) == (4, 0)
    again = run_sweep(load_sweep(spec), tmp_path, workers=0, progress=False)
    assert (again.ran, again.skipped) == (0, 4)
    # a row lost (or an error) runs again; a new value adds its runs only
    rows = read_results(tmp_path / "results.csv")
    table = (tmp_path / "results.csv").read_text().splitlines()
    (tmp_path / "results.csv").write_text("\n".join(table[:2] + table[3:]) + "\n")
    ran = []
    spec["vary"]["fluid.viscosity"].append(0.6)
    third = run_sweep(load_sweep(spec), tmp_path, workers=0, progress=False,
                      on_row=lambda r: ran.append(r["param:fluid.viscosity"]))
    assert (third.ran, third.skipped) == (3, 3)
    assert sorted(ran) == [0.5, 0.6, 0.6] and rows[1]["param:fluid.viscosity"] == "0.5"
    assert len(read_results(tmp_path / "results.csv")) == 6
    # a run that ended in an error runs again; the others are kept
    text = (tmp_path / "results.csv").read_text().splitlines()
    text[3] = text[3].replace(",ok,", ",error,", 1)
    (tmp_path / "results.csv").write_text("\n".join(text) + "\n")
    fourth = run_sweep(load_sweep(spec), tmp_path, workers=0, progress=False)
    assert (fourth.ran, fourth.skipped) == (1, 5)
    assert [r["status"] for r in read_results(tmp_path / "results.csv")] == ["ok"] * 6


def test_repeats_are_runs_of_their_own_and_kept_rows_take_the_new_parameters(tmp_path):
    spec = _sweep(duration=0.01, vary={"fluid.viscosity": [0.5, 0.5, 0.4]})
    outcome = run_sweep(load_sweep(spec), tmp_path, workers=0, progress=False)
    rows = read_results(tmp_path / "results.csv")
    assert outcome.ran == 3 and len(rows) == 3 and len({r["key"] for r in rows}) == 3
    assert rows[0]["steps"] == rows[1]["steps"]  # the same scene twice
    # a new key whose first value is the base scene's: the kept rows say so
    spec["vary"] = {"fluid.gas_constant": [250.0, 300.0], "fluid.viscosity": [0.5, 0.5, 0.4]}
    again = run_sweep(load_sweep(spec), tmp_path, workers=0, progress=False)
    assert (again.ran, again.skipped) == (3, 3)
    rows = read_results(tmp_path / "results.csv")
    assert [r["param:fluid.gas_constant"] for r in rows] == ["250.0"] * 3 + ["300.0"] * 3


def test_ranges_grids_zips_methods_and_seeded_draws():
    s = load_sweep(_sweep(duration=0.01, vary={
        "solver.time_step": {"logspace": [1e-4, 1e-2, 3]},
        "fluid.viscosity": {"linspace": [0.1, 0.3, 2]}}, methods=["seed"]))
    assert [r.params["solver.time_step"] for r in s.runs[::2]] == pytest.approx([1e-4, 1e-3, 1e-2])
    assert [r.params["fluid.viscosity"] for r in s.runs[:2]] == pytest.approx([0.1, 0.3])
    assert s.columns == ("solver.time_step", "fluid.viscosity", "method")
    assert len({s.key(r) for r in s.runs}) == 6
    spec = _sweep(duration=0.01, samples=3, seed=7, combine="zip",
                  vary={"fluid.viscosity": {"uniform": [0.1, 0.5]}, "solver.time_step": [1e-3] * 3})
    a, b = load_sweep(spec), load_sweep(copy.deepcopy(spec))
    draws = [r.params["fluid.viscosity"] for r in a.runs]
    assert draws == [r.params["fluid.viscosity"] for r in b.runs] and len(set(draws)) == 3
    assert all(0.1 <= v < 0.5 for v in draws)
    spec["seed"] = 8
    assert [r.params["fluid.viscosity"] for r in load_sweep(spec).runs] != draws
    assert a.runs[0].scene["fluid"]["viscosity"] == draws[0]


@pytest.mark.parametrize("change, message", [
    ({"vary": {"fluid_regions[3].max": [[1, 1]]}},
     'vary["fluid_regions[3].max"]: the scene has no fluid_regions[3] (fluid_regions is a list of 1)'),
    ({"vary": {"solver.cfl": []}}, 'vary["solver.cfl"]: expected at least 1 item'),
    ({"vary": {"solver..cfl": [1]}}, 'vary["solver..cfl"]: expected a JSON path into the scene'),
    ({"vary": {"fluid.viscosity": {"uniform": [0.1, 0.5]}}},
     'vary["fluid.viscosity"]: a random key needs "samples"'),
    ({"vary": {"fluid.viscosity": {"linspace": [0.1, 0.5]}}},
     'vary["fluid.viscosity"].linspace: expected at least 3 items'),
    ({"vary": {"fluid.viscosity": {"steps": [1]}}},
     'vary["fluid.viscosity"].steps: unknown key'),
    ({"vary": {"fluid.viscosity": 0.3}}, 'vary["fluid.viscosity"]: expected a list of values'),
    ({"methods": ["seed", "wcsp"]}, 'methods[1]: expected one of "seed", "wcsph", "dfsph", got "wcsp" '
                                    '(did you mean "wcsph"?)'),
    ({"vary": {"fluid.viscosty": [0.1]}},
     'run 0 (fluid.viscosty = 0.1): fluid.viscosty: unknown key (did you mean "viscosity"?)'),
    ({"vary": {"fluid.viscosity": [0.1, -1.0]}},
     "run 1 (fluid.viscosity = -1.0): fluid.viscosity: must be >= 0, got -1"),
    ({"combine": "zip", "vary": {"fluid.viscosity": [0.1, 0.2], "solver.time_step": [1e-3]}},
     'combine: "zip" needs lists of one length, got vary["fluid.viscosity"]: 2, '
     'vary["solver.time_step"]: 1'),
    ({"scene": "missing.json"}, "scene: cannot read"),
    ({"duration": -1}, "duration: must be > 0, got -1"),
    ({"runs": 3}, 'runs: unknown key'),
    ({"vary": {"duration": [1.0, 2.0]}}, 'vary.duration: the runs\' duration is the sweep\'s'),
    ({"scene": [1]}, "scene: expected a string or an object"),
])
def test_bad_sweep_files_are_refused_by_json_path(change, message):
    spec = {**_sweep(duration=0.01), **change}
    with pytest.raises(SweepError) as e:
        load_sweep(spec)
    assert message in str(e.value), str(e.value)


def test_a_scene_file_that_is_not_a_scene_object_is_refused(tmp_path):
    (tmp_path / "l.json").write_text("[1]")
    with pytest.raises(SweepError, match="scene: .*l.json holds a list of 1, not a scene"):
        load_sweep({"scene": str(tmp_path / "l.json"), "duration": 1.0})


def test_a_scene_without_a_duration_needs_one_in_the_sweep():
    scene = copy.deepcopy(BASE_SCENE)
    del scene["duration"]
    with pytest.raises(SweepError, match="duration: the scene gives no duration"):
        load_sweep({"scene": scene})
    assert load_sweep({"scene": scene, "duration": 0.01}).duration == 0.01


def test_the_command_line(tmp_path, capsys):
    scene = tmp_path / "box.json"
    scene.write_text(json.dumps(BASE_SCENE))
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"scene": "box.json", "duration": 0.01, "outputs": ["frames", "checkpoint"],
                                "every": 0.005, "vary": {"solver.time_step": [0.001, 0.0005]}}))
    assert main(["sweep", str(spec), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "run    1" in out and "solver.time_step = 0.0005" in out and "2 runs of 0.01 s" in out
    assert main(["sweep", str(spec), "--workers", "0", "--out", str(tmp_path / "o"), "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert "2 run(s)" in out and "(2 ok)" in out and "%|" not in err
    runs = sorted((tmp_path / "o" / "runs").iterdir())
    assert len(runs) == 2
    for folder in runs:
        names = sorted(p.name for p in folder.iterdir())
        assert names == ["checkpoint.npz", "frame_00000.npz", "frame_00001.npz",
                         "frame_00002.npz", "scene.json"], names
    spec.write_text(json.dumps({"scene": "box.json", "methods": ["sead"]}))
    assert main(["sweep", str(spec)]) == 2
    assert 'methods[0]: expected one of "seed", "wcsph", "dfsph", got "sead"' in capsys.readouterr().err
