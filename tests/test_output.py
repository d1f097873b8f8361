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


def test_git_commit_is_the_checkout_head(fresh_git_state):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    commit, dirty = md.git_state()
    assert commit == head and dirty in (True, False)


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

