"""Output files: run metadata, npz and VTK frames, the ParaView collection."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time

import pytest
import sphfluid
from conftest import BASE_SCENE, ROOT
from sphfluid import Simulation, _core, load_scene
from sphfluid import metadata as md


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
