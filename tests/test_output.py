"""Output files: run metadata, npz and VTK frames, the ParaView collection."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import sphfluid
from conftest import BASE_SCENE, ROOT
from sphfluid import Simulation, _core, load_scene
from sphfluid import metadata as md
from sphfluid import output


@pytest.fixture
def fresh_git_state():
    """git_state() recomputed for the test, and again after it."""
    md.git_state.cache_clear()
    yield
    md.git_state.cache_clear()


# -- metadata


def test_scene_hash_is_the_sha256_of_the_canonical_json():
    scene = load_scene(BASE_SCENE)
    h = md.scene_hash(scene)
    assert len(h) == 64 and int(h, 16) >= 0
    # the dict the run writes as scene.json, after a JSON round trip, hashes the same
    assert md.scene_hash(json.loads(json.dumps(scene.to_dict(), indent=2))) == h
    assert md.scene_hash(load_scene(BASE_SCENE)) == h
    changed = dict(BASE_SCENE, gravity=[0.0, -9.8])
    assert md.scene_hash(load_scene(changed)) != h


def test_run_metadata_describes_the_run():
    sim = Simulation(BASE_SCENE, threads=1)
    meta = md.run_metadata(sim)
    assert json.loads(json.dumps(meta)) == meta  # JSON-ready
    assert meta["sphfluid_version"] == sphfluid.__version__
    assert meta["build"] == dict(_core.build_info)
    assert meta["method"] == "seed" and meta["threads"] == 1 and meta["threads_in_use"] == 1
    assert meta["pair_precision"] in ("double", "float")
    assert meta["scene_hash"] == md.scene_hash(sim.scene)
    assert meta["scene_name"] == "test box"


def test_git_commit_is_the_checkouts_head_and_says_when_it_differs(tmp_path, monkeypatch,
                                                                   fresh_git_state):
    """In a checkout (here a new one: the tests may run on an installed package)."""
    if shutil.which("git") is None:
        pytest.skip("no git")

    def git(*args):
        return subprocess.run(["git", "-C", str(tmp_path), "-c", "user.name=t",
                               "-c", "user.email=t@example.org", *args],
                              capture_output=True, text=True, check=True).stdout.strip()

    (tmp_path / "pyproject.toml").write_text("[project]\n")
    git("init", "-q")
    git("add", "pyproject.toml")
    git("commit", "-q", "-m", "start")
    monkeypatch.setattr(md, "_SOURCE_ROOT", tmp_path)
    assert md.git_state() == (git("rev-parse", "HEAD"), False)
    (tmp_path / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    md.git_state.cache_clear()
    assert md.git_state() == (git("rev-parse", "HEAD"), True)
    meta = md.run_metadata(Simulation(BASE_SCENE, threads=1))
    assert meta["git_commit"] == git("rev-parse", "HEAD") and meta["git_dirty"] is True


def test_git_commit_is_none_outside_a_checkout(tmp_path, monkeypatch, fresh_git_state):
    monkeypatch.setattr(md, "_SOURCE_ROOT", tmp_path)  # an installed package's folder
    assert md.git_state() == (None, None)
    meta = md.run_metadata(Simulation(BASE_SCENE, threads=1))
    assert meta["git_commit"] is None and meta["git_dirty"] is None


def test_a_hanging_git_is_not_waited_for(tmp_path, monkeypatch, fresh_git_state):
    (tmp_path / ".git").mkdir()
    (tmp_path / "pyproject.toml").write_text("")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "git"
    fake.write_text(f"#!{sys.executable}\nimport time\ntime.sleep(30)\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", str(bin_dir))
    monkeypatch.setattr(md, "_SOURCE_ROOT", tmp_path)
    monkeypatch.setattr(md, "_GIT_TIMEOUT", 0.5)
    start = time.perf_counter()
    assert md.git_state() == (None, None)
    assert time.perf_counter() - start < 5


# -- the writers

TERRAIN = ROOT / "scenes" / "terrain.json"  # 1,435 particles; 13 walls in 5 polylines


def pvd_datasets(path):
    """(timestep, part, name, file) of each DataSet, as written."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    return [(float(d.get("timestep")), d.get("part"), d.get("name"), d.get("file"))
            for d in root.find("Collection").findall("DataSet")]


def segments(walls_file):
    """The (S, 2, 2) segments of a walls .vtu's polylines, in order."""
    d = output.read_vtu(walls_file)
    assert set(d["types"]) == {4}  # VTK_POLY_LINE
    assert np.array_equal(d["connectivity"], np.arange(len(d["points"])))
    starts = np.concatenate([[0], d["offsets"][:-1]])
    out = []
    for a, b in zip(starts, d["offsets"]):
        line = d["points"][a:b, :2]
        out += [line[k:k + 2] for k in range(len(line) - 1)]
    return np.array(out).reshape(-1, 2, 2)


def test_write_vtu_reads_back_exactly(tmp_path):
    rng = np.random.default_rng(1)
    points = rng.normal(size=(7, 3))
    cells = (np.arange(7), np.array([2, 5, 7]), np.array([3, 4, 4], dtype=np.uint8))
    data = {"v": rng.normal(size=(7, 3)), "s": rng.normal(size=7), "n": np.arange(7) - 3}
    output.write_vtu(tmp_path / "a.vtu", points, cells, point_data=data,
                     field_data={"TimeValue": 0.1 + 0.2, "note": 'say "hi" <&> -- \\n'})
    d = output.read_vtu(tmp_path / "a.vtu")
    assert np.array_equal(d["points"], points)
    for got, want in zip((d["connectivity"], d["offsets"], d["types"]), cells):
        assert np.array_equal(got, want)
    assert d["point_data"].keys() == data.keys()
    assert all(np.array_equal(d["point_data"][k], data[k]) for k in data)
    assert d["field_data"]["TimeValue"][0] == 0.1 + 0.2
    assert d["field_data"]["note"] == ['say "hi" <&> -- \\n']
    assert [p.name for p in tmp_path.iterdir()] == ["a.vtu"]


def test_a_frame_holds_the_simulations_arrays(tmp_path):
    sim = Simulation(load_scene(TERRAIN), threads=1)
    sim.step(20)
    output.frame_writer("vtk", tmp_path, sim).write(sim)
    d = output.read_vtu(tmp_path / "frame_00000.vtu")
    assert np.array_equal(d["points"][:, :2], sim.positions)
    for name in ("velocities", "accelerations"):
        assert np.array_equal(d["point_data"][name][:, :2], getattr(sim, name))
    for name in ("densities", "pressures", "ids"):
        assert np.array_equal(d["point_data"][name], getattr(sim, name))
    assert d["field_data"]["TimeValue"][0] == sim.time


def test_a_failed_write_leaves_whole_files_and_a_valid_collection(tmp_path, monkeypatch):
    from pyevtk import vtk as pyevtk_vtk

    sim = Simulation(load_scene(TERRAIN), threads=1)
    writer = output.frame_writer("vtk", tmp_path, sim)
    writer.write(sim)
    sim.step(10)
    writer.write(sim)
    pvd_before = (tmp_path / "frames.pvd").read_bytes()

    def fail(self):  # the disk fills up with the frame half written
        self.xml.stream.flush()
        raise OSError("No space left on device")

    monkeypatch.setattr(pyevtk_vtk.VtkFile, "save", fail)
    sim.step(10)
    with pytest.raises(OSError, match="No space"):
        writer.write(sim)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frame_00000.vtu", "frame_00001.vtu", "frames.pvd", "walls.vtu"]
    assert (tmp_path / "frames.pvd").read_bytes() == pvd_before
    assert [d[3] for d in pvd_datasets(tmp_path / "frames.pvd") if d[1] == "0"] == [
        "frame_00000.vtu", "frame_00001.vtu"]


def test_no_walls_no_walls_part(tmp_path):
    sim = Simulation(load_scene(ROOT / "scenes" / "droplet.json"), threads=1)
    output.frame_writer("vtk", tmp_path, sim).write(sim)
    assert {d[1] for d in pvd_datasets(tmp_path / "frames.pvd")} == {"0"}
    assert not list(tmp_path.glob("walls*"))


def test_walls_are_written_again_when_they_change(tmp_path):
    sim = Simulation(load_scene(TERRAIN), threads=1)
    writer = output.frame_writer("vtk", tmp_path, sim)
    writer.write(sim)
    writer.write(sim)
    sim.add_wall((0.0, 5.0), (1.0, 5.0))
    writer.write(sim)
    walls = [d[3] for d in pvd_datasets(tmp_path / "frames.pvd") if d[1] == "1"]
    assert walls == ["walls.vtu", "walls.vtu", "walls_00002.vtu"]
    assert np.array_equal(segments(tmp_path / "walls_00002.vtu"), sim.walls)
    assert len(sim.walls) == 14


def test_wall_polylines_join_segments_that_meet():
    walls = [[[0, 1], [0, 0]], [[0, 0], [1, 0]], [[2, 0], [3, 0]], [[3, 0], [3, 1]]]
    lines = output.wall_polylines(walls)
    assert [line.tolist() for line in lines] == [[[0, 1], [0, 0], [1, 0]],
                                                [[2, 0], [3, 0], [3, 1]]]
    assert output.wall_polylines(np.zeros((0, 2, 2))) == []


def test_pvd_comment_survives_a_double_dash_in_the_metadata(tmp_path):
    scene = dict(BASE_SCENE, name="tank -- with a lid --")
    sim = Simulation(scene, threads=1)
    output.frame_writer("vtk", tmp_path, sim).write(sim)
    assert output.read_metadata(tmp_path / "frames.pvd")["scene_name"] == "tank -- with a lid --"
    assert output.read_metadata(tmp_path / "frame_00000.vtu")["scene_name"] == scene["name"]


# -- sphfluid run --out DIR [--format vtk]

FRAME_TIMES = [0.0, 0.005, 0.01, 0.015, 0.02]  # --duration 0.02 --every 0.005


def run_cli(tmp_path, *extra, scene=TERRAIN, out="out"):
    from sphfluid.cli import main

    return main(["run", str(scene), "--duration", "0.02", "--every", "0.005", "--threads", "1",
                 "--out", str(tmp_path / out), "--quiet", *extra])


@pytest.fixture(scope="module")
def vtk_run(tmp_path_factory):
    """One short terrain run with --format vtk, shared by the tests that read it."""
    tmp = tmp_path_factory.mktemp("vtk_run")
    assert run_cli(tmp, "--format", "vtk") == 0
    return tmp / "out"


def test_vtk_frames_hold_the_simulation_state_at_the_frame_times(vtk_run):
    sim = Simulation(load_scene(TERRAIN), threads=1)  # replayed: fixed steps, one thread
    frames = sorted(vtk_run.glob("frame_*.vtu"))
    assert [f.name for f in frames] == [f"frame_{k:05d}.vtu" for k in range(len(FRAME_TIMES))]
    for path, t in zip(frames, FRAME_TIMES):
        sim.advance_to(t)
        d = output.read_vtu(path)
        assert d["field_data"]["TimeValue"][0] == sim.time
        assert d["points"].shape == (sim.n_particles, 3)
        assert np.array_equal(d["points"][:, :2], sim.positions) and not d["points"][:, 2].any()
        pd = d["point_data"]
        for name in ("velocities", "accelerations"):
            assert pd[name].shape == (sim.n_particles, 3)  # vectors to ParaView
            assert np.array_equal(pd[name][:, :2], getattr(sim, name)) and not pd[name][:, 2].any()
        for name in ("densities", "pressures", "ids"):
            assert np.array_equal(pd[name], getattr(sim, name)), name
        assert np.array_equal(d["types"], np.ones(sim.n_particles))  # VTK_VERTEX
        assert np.array_equal(d["offsets"], np.arange(1, sim.n_particles + 1))
    assert sim.step_count == 100  # 0.02 s at dt 0.0002: the frames were not all at t = 0


def test_pvd_lists_every_frame_in_order_with_its_time(vtk_run):
    datasets = pvd_datasets(vtk_run / "frames.pvd")
    particles = [d for d in datasets if d[1] == "0"]
    walls = [d for d in datasets if d[1] == "1"]
    assert [d[3] for d in particles] == [f"frame_{k:05d}.vtu" for k in range(len(FRAME_TIMES))]
    times = [d[0] for d in particles]
    assert times == sorted(times) and times == pytest.approx(FRAME_TIMES, abs=1e-12)
    for t, _, _, name in particles:  # each time is its frame's own
        assert output.read_vtu(vtk_run / name)["field_data"]["TimeValue"][0] == t
    assert [d[0] for d in walls] == times and {d[3] for d in walls} == {"walls.vtu"}
    assert {d[2] for d in particles} == {"particles"} and {d[2] for d in walls} == {"walls"}
    assert all((vtk_run / d[3]).is_file() for d in datasets)
    assert not list(vtk_run.glob(".*"))  # no temporary files left


def test_walls_come_back_as_the_scenes_segments(vtk_run):
    sim = Simulation(load_scene(TERRAIN), threads=1)
    assert np.array_equal(segments(vtk_run / "walls.vtu"), sim.walls)
    assert len(output.read_vtu(vtk_run / "walls.vtu")["offsets"]) == 5  # joined polylines


def test_metadata_is_in_every_vtk_file_and_the_pvd(vtk_run):
    scene = load_scene(TERRAIN)
    expected = md.run_metadata(Simulation(scene, threads=1))
    files = [vtk_run / "frames.pvd", vtk_run / "walls.vtu", *sorted(vtk_run.glob("frame_*.vtu"))]
    for path in files:
        meta = output.read_metadata(path)
        assert meta == expected, path
    assert meta["scene_hash"] == md.scene_hash(json.loads((vtk_run / "scene.json").read_text()))
    assert meta["threads"] == 1 and meta["method"] == "seed"


def test_npz_frames_carry_the_metadata(tmp_path):
    assert run_cli(tmp_path, "--format", "npz") == 0
    frames = sorted((tmp_path / "out").glob("frame_*.npz"))
    assert len(frames) == len(FRAME_TIMES) and not list((tmp_path / "out").glob("*.vtu"))
    expected = md.run_metadata(Simulation(load_scene(TERRAIN), threads=1))
    for path in frames:
        with np.load(path) as f:  # no pickle needed: a plain string
            assert set(f.files) == {"time", "positions", "velocities", "densities",
                                    "pressures", "ids", "metadata"}
        assert output.read_metadata(path) == expected


def test_npz_is_the_default_format(tmp_path):
    assert run_cli(tmp_path) == 0
    assert len(list((tmp_path / "out").glob("frame_*.npz"))) == len(FRAME_TIMES)
    assert not list((tmp_path / "out").glob("*.pvd"))


def test_vtk_without_pyevtk_fails_in_one_line_naming_the_install(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "pyevtk", None)  # import pyevtk raises ImportError
    assert run_cli(tmp_path, "--format", "vtk") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith("error: --format vtk") and 'pip install "pyevtk' in err
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_format_needs_out(capsys):
    from sphfluid.cli import main

    assert main(["run", str(TERRAIN), "--duration", "0.01", "--format", "vtk"]) == 2
    assert "--format needs --out DIR" in capsys.readouterr().err


def test_a_killed_run_leaves_a_valid_collection_of_whole_frames(tmp_path):
    """Killed while it writes frames as fast as it can: the .pvd parses and every
    frame it lists reads back whole."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "sphfluid", "run", str(TERRAIN),
                             "--duration", "2", "--every", "0.0002", "--threads", "1",
                             "--out", str(out), "--format", "vtk", "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if len(list(out.glob("frame_*.vtu"))) >= 8:
                break
            time.sleep(0.01)
    finally:
        proc.kill()
        proc.wait()
    listed = [d for d in pvd_datasets(out / "frames.pvd") if d[1] == "0"]
    assert len(listed) >= 7
    for t, _, _, name in listed:
        d = output.read_vtu(out / name)
        assert d["field_data"]["TimeValue"][0] == t
        assert len(d["point_data"]["ids"]) == len(d["points"]) == 1435


def test_source_line_names_the_version_commit_and_build(fresh_git_state):
    line = md.source_line()
    assert line.startswith(f"sphfluid {sphfluid.__version__} (")
    commit, dirty = md.git_state()
    if commit is not None:
        assert f"commit {commit[:7]}" in line
        assert ("with local changes" in line) == dirty
    assert _core.build_info["compiler"] in line and _core.build_info["real"] in line


def test_sigterm_stops_a_run_with_a_message_and_whole_frames(tmp_path):
    """SIGTERM (a scheduler's stop) ends `run` between steps: exit 143, a line
    saying so, and every npz frame written so far whole."""
    import signal

    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "sphfluid", "run", str(TERRAIN),
                             "--duration", "4", "--every", "0.0002", "--threads", "1",
                             "--out", str(out), "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if len(list(out.glob("frame_*.npz"))) >= 5:
                break
            time.sleep(0.01)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143, err
    assert "terminated (SIGTERM)" in err and "Traceback" not in err
    frames = sorted(out.glob("frame_*.npz"))
    assert len(frames) >= 5 and not list(out.glob(".*tmp*"))
    for f in frames:
        with np.load(f) as d:
            assert d["positions"].shape == (1435, 2)


def test_a_full_disk_is_a_message_and_exit_2_with_the_frames_before_it_whole(
        tmp_path, monkeypatch, capsys):
    """No space left while writing the fourth frame: exit 2 with the reason and
    the file, the three frames before it whole, no temporary file left."""
    import errno

    from sphfluid.cli import main

    real = np.savez
    calls = []

    def savez(f, **arrays):
        calls.append(f)
        if len(calls) == 4:
            real(f, **arrays)  # part of the file is written, then the disk is full
            raise OSError(errno.ENOSPC, "No space left on device", str(f))
        real(f, **arrays)

    monkeypatch.setattr(output.np, "savez", savez)
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    out = tmp_path / "out"
    code = main(["run", str(scene), "--out", str(out), "--every", "0.01", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "error: No space left on device: " in err and "Traceback" not in err
    frames = sorted(out.glob("frame_*.npz"))
    assert len(frames) == 3 and not list(out.glob(".*tmp*"))
    for f in frames:
        with np.load(f) as d:
            assert len(d["positions"]) == len(d["ids"]) > 0


def test_a_signal_during_a_write_is_handled_once_the_file_is_whole(tmp_path):
    """SIGTERM inside a write (here between its two halves) stops the program
    only after the file is in place: raised within numpy's savez it had left
    zipfile unable to close, and `sphfluid run` ended with a traceback."""
    import os
    import signal

    class Stop(Exception):
        pass

    def stop(signum, frame):
        output.raise_or_hold(Stop())  # as the command line's handlers do

    previous = signal.signal(signal.SIGTERM, stop)
    path = tmp_path / "frame.txt"
    try:
        with pytest.raises(Stop):
            with output.replacing(path) as tmp:
                tmp.write_text("first half, ")
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)  # (a signal not held is handled here)
                with open(tmp, "a") as f:
                    f.write("second half")
        assert path.read_text() == "first half, second half"
        assert not list(tmp_path.glob(".*tmp*"))
    finally:
        signal.signal(signal.SIGTERM, previous)
    with pytest.raises(Stop):  # no write open: at once
        output.raise_or_hold(Stop())
