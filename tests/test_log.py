"""`sphfluid run --log FILE`: health counters as JSON Lines at the run's output
times, without changing the run."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import sphfluid.simulation
from conftest import BASE_SCENE, write_boom_scene
from sphfluid import Simulation
from sphfluid.cli import main
from sphfluid.metadata import run_metadata, scene_hash

FIELDS = {"time", "step", "dt", "dt_limit", "max_density_error", "max_compression", "max_speed",
          "kinetic_energy", "surface_energy", "energy_budget", "energy_removed", "particles",
          "particles_removed", "wall_crossings", "retried_steps", "guard_density", "guard_speed", "guard_energy",
          "wall_time"}


def write_scene(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps(BASE_SCENE))
    return path


def read_log(path):
    text = path.read_text()
    assert text.endswith("\n")
    return [json.loads(line) for line in text.splitlines()]


@pytest.fixture
def simulations(monkeypatch):
    """The Simulations that `sphfluid run` makes, to look at their end state."""
    made = []

    class Recorded(Simulation):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(sphfluid.simulation, "Simulation", Recorded)
    return made


def test_the_log_holds_metadata_then_health_lines(tmp_path, simulations):
    # Thrown at 2 m/s towards an open side: 10 particles leave the domain by t = 0.1 s.
    d = copy.deepcopy(BASE_SCENE)
    d["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]}]
    d["domain"]["max"] = [0.7, 1.1]
    d["fluid_regions"][0]["velocity"] = [2.0, 0.0]
    d["duration"] = 0.12
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(d))
    log = tmp_path / "run.jsonl"
    assert main(["run", str(scene), "--log", str(log), "--quiet"]) == 0
    sim = simulations[-1]
    first, *lines = read_log(log)
    assert set(first) == {"metadata"}
    assert first["metadata"] == json.loads(json.dumps(run_metadata(sim)))
    assert first["metadata"]["scene_hash"] == scene_hash(sim.scene)

    for line in lines:
        assert set(line) == FIELDS, set(line) ^ FIELDS
    times = [x["time"] for x in lines]
    assert times[0] == 0.0 and times[-1] == pytest.approx(0.12)
    assert all(a < b for a, b in zip(times, times[1:]))
    assert all(a["step"] < b["step"] for a, b in zip(lines, lines[1:]))
    # Without --out: at least every hundredth of the run, at the 25-step samples
    # (here 25 steps are 0.025 s, longer than a hundredth): each sample is a line.
    assert [x["step"] for x in lines] == [0, 25, 50, 75, 100, 120]

    assert lines[0]["dt"] is None and lines[0]["dt_limit"] is None  # no step yet
    for line in lines[1:]:
        assert line["dt"] == 0.001 and line["dt_limit"] == "fixed"
        assert line["energy_budget"] > 0 and line["kinetic_energy"] > 0
        assert line["particles"] + line["particles_removed"] == 100
        for guard in ("guard_density", "guard_speed", "guard_energy"):
            assert 0 < line[guard] < 1, (guard, line)
        assert line["retried_steps"] == 0 and line["surface_energy"] == 0.0
    assert all(a["wall_time"] <= b["wall_time"] for a, b in zip(lines, lines[1:]))

    end, st = lines[-1], sim.stats()
    assert end["time"] == st["time"] and end["step"] == st["step_count"] == 120
    assert end["max_density_error"] == st["max_density_error"]
    assert end["max_compression"] == st["max_compression"]
    assert end["kinetic_energy"] == st["kinetic_energy"]
    assert end["energy_removed"] == st["energy_removed"] > 0
    assert end["particles_removed"] == sim.removed_particles > 0
    assert end["wall_crossings"] == sim.wall_crossings  # (counted: tests/test_walls.py)
    assert all(a["wall_crossings"] <= b["wall_crossings"] for a, b in zip(lines, lines[1:]))
    assert end["particles"] == sim.n_particles
    p = sim._solver.params
    assert end["guard_density"] == pytest.approx(sim.densities.max() / (3 * p.rho0))
    assert end["guard_speed"] == pytest.approx(st["max_speed"] / (10 * p.sound_speed))
    assert end["guard_energy"] == pytest.approx(
        (st["kinetic_energy"] + st["energy_removed"]) / (2 * st["energy_budget"]))


def test_an_adaptive_run_logs_its_time_step_and_limiter(tmp_path, simulations):
    d = copy.deepcopy(BASE_SCENE)
    d["solver"] = {"method": "wcsph", "time_step": "auto"}
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(d))
    log = tmp_path / "run.jsonl"
    assert main(["run", str(scene), "--log", str(log), "--quiet"]) == 0
    lines = read_log(log)[1:]
    assert {x["dt_limit"] for x in lines[1:]} <= {"cfl", "force", "viscous", "dt_max"}
    assert all(0 < x["dt"] < 0.05 for x in lines[1:])
    # a line every hundredth of the run, or at each 25-step sample when that is longer
    gaps = np.diff([x["time"] for x in lines])
    steps = np.diff([x["step"] for x in lines])
    assert ((gaps >= 0.05 / 100 * (1 - 1e-9)) | (steps <= 25))[:-1].all()
    assert lines[-1]["time"] == 0.05 and lines[-1]["step"] == simulations[-1].step_count


def test_one_line_per_frame_and_checkpoint_time(tmp_path):
    scene = write_scene(tmp_path)
    out, log = tmp_path / "out", tmp_path / "run.jsonl"
    assert main(["run", str(scene), "--out", str(out), "--every", "0.01",
                 "--checkpoint-every", "0.025", "--log", str(log), "--quiet"]) == 0
    lines = read_log(log)[1:]
    frame_times = [float(np.load(f)["time"]) for f in sorted(out.glob("frame_*.npz"))]
    assert len(frame_times) == 6  # t = 0, 0.01, ... 0.05
    # the frames' times, and the checkpoint at 0.025 (that at 0.05 is the last frame's)
    times = [x["time"] for x in lines]
    assert len(lines) == 7 and times == pytest.approx(sorted([*frame_times, 0.025]))
    assert set(frame_times) <= set(times)  # the very times the frames hold


@pytest.mark.parametrize("with_out", [True, False])
def test_logging_does_not_change_the_run(tmp_path, simulations, with_out):
    d = copy.deepcopy(BASE_SCENE)
    d["solver"] = {"method": "wcsph", "time_step": "auto"}
    d["duration"] = 0.08
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(d))
    runs = {}
    for name, log in (("plain", []), ("logged", ["--log", str(tmp_path / "run.jsonl")])):
        out = ["--out", str(tmp_path / name), "--every", "0.02"] if with_out else []
        assert main(["run", str(scene), *out, *log, "--quiet"]) == 0
        runs[name] = simulations[-1]
    a, b = runs["plain"], runs["logged"]
    assert (a.time, a.step_count) == (b.time, b.step_count)
    for field in ("positions", "velocities", "densities", "ids"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    if with_out:
        frames = [sorted((tmp_path / name).glob("frame_*.npz")) for name in runs]
        assert len(frames[0]) == len(frames[1]) == 5
        for fa, fb in zip(*frames):
            with np.load(fa) as x, np.load(fb) as y:
                for key in ("time", "positions", "velocities", "densities", "ids"):
                    assert np.array_equal(x[key], y[key]), (fa.name, key)
    assert len(read_log(tmp_path / "run.jsonl")) > 4


def test_a_resumed_run_appends_and_a_new_run_starts_afresh(tmp_path):
    scene = write_scene(tmp_path)
    out, log = tmp_path / "out", tmp_path / "run.jsonl"
    common = ["--out", str(out), "--every", "0.01", "--checkpoint-every", "0.02", "--log",
              str(log), "--quiet"]
    assert main(["run", str(scene), "--duration", "0.03", *common]) == 0
    first = read_log(log)
    assert main(["run", str(scene), "--resume", str(out / "checkpoint.npz"), *common]) == 0
    both = read_log(log)
    assert both[:len(first)] == first  # kept as it was
    again = both[len(first):]
    assert set(again[0]) == {"metadata"}
    # from the checkpoint (t = 0.03, the first run's end) on
    assert [x["time"] for x in again[1:]] == pytest.approx([0.03, 0.04, 0.05])
    assert again[1]["step"] == first[-1]["step"] == 30
    assert main(["run", str(scene), *common]) == 0
    assert len([x for x in read_log(log) if "metadata" in x]) == 1


def test_a_log_that_cannot_be_written_stops_the_run_before_it_starts(tmp_path, capsys):
    scene = write_scene(tmp_path)
    for bad, why in ((tmp_path / "missing" / "run.jsonl", "No such file or directory"),
                     (tmp_path, "Is a directory")):
        assert main(["run", str(scene), "--log", str(bad)]) == 2
        out, err = capsys.readouterr()
        assert err == f"error: --log: cannot write {bad}: {why}\n"
        assert out == ""


def test_a_blow_up_ends_the_log_with_the_last_good_state(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the last good state is saved in the current folder
    scene = write_boom_scene(tmp_path)
    log = tmp_path / "run.jsonl"
    assert main(["run", str(scene), "--log", str(log), "--quiet", "--no-check"]) == 3
    lines = read_log(log)
    assert "non-finite" in lines[-1]["instability"]
    assert set(lines[-1]) == FIELDS | {"instability"}
    assert lines[-1]["step"] == Simulation.from_checkpoint(
        tmp_path / "boom.last_good_state.npz").step_count
    capsys.readouterr()
