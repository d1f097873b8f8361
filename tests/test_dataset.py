"""sphfluid dataset: trajectories in LagrangeBench's layout, opened with h5py
as its loader opens them; seeded, so the same file gives the same dataset."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from conftest import BASE_SCENE
from sphfluid.cli import main

h5py = pytest.importorskip("h5py")


def _spec(samples=5, train=2, valid=1, test=1, **vary) -> dict:
    return {"format": "sphfluid-sweep/1", "scene": copy.deepcopy(BASE_SCENE), "samples": samples,
            "seed": 11, "combine": "zip", "duration": 0.02,
            "vary": {"gravity[0]": {"uniform": [-2.0, 2.0]}, **vary},
            "dataset": {"splits": {"train": train, "valid": valid, "test": test},
                        "every": 0.005, "case": "BOX"}}


def _make(tmp_path, spec, name="d", capsys=None):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(spec))
    code = main(["dataset", str(path), "--out", str(tmp_path / name), "--workers", "0",
                 "--quiet"])
    return code, tmp_path / name


def test_the_layout_lagrangebench_reads(tmp_path):
    code, out = _make(tmp_path, _spec())
    assert code == 0
    meta = json.loads((out / "metadata.json").read_text())
    n_fluid, n_wall = meta["sphfluid"]["fluid_particles"], meta["sphfluid"]["wall_particles"]
    assert n_fluid == 100 and n_wall == 61  # 3 m of wall at 0.05 m: 60 gaps, 61 points
    for split, count in (("train", 2), ("valid", 1), ("test", 1)):
        with h5py.File(out / f"{split}.h5", "r") as f:
            keys = list(f.keys())  # as the loader lists the trajectories
            assert keys == [f"{k:05d}" for k in range(count)]
            assert f["00000/position"].shape[0] == meta["sequence_length_train"] == 5
            for k in keys:
                pos, kind = f[k]["position"], f[k]["particle_type"][:]
                assert pos.shape == (5, n_fluid + n_wall, 2) and pos.dtype == np.float32
                assert pos.compression == "gzip" and kind.dtype == np.int32
                assert (kind[:n_fluid] == 0).all() and (kind[n_fluid:] == 1).all()
                walls = pos[:, n_fluid:]
                assert (walls == walls[0]).all()  # the walls stand still
                assert set(np.round(walls[0, :, 0], 6)) >= {0.0, 1.0}
    for key in ("bounds", "periodic_boundary_conditions", "default_connectivity_radius",
                "num_particles_max", "vel_mean", "vel_std", "acc_mean", "acc_std", "dim", "dt",
                "write_every", "dx"):
        assert key in meta, key
    assert meta["bounds"] == [[-0.1, 1.1], [-0.1, 1.1]] and meta["dim"] == 2
    assert meta["num_particles_max"] == n_fluid + n_wall
    assert meta["dt"] == 0.001 and meta["write_every"] == 5  # a frame every 5 fixed steps
    assert meta["default_connectivity_radius"] == 0.072  # 1.45 dx to two figures


def test_the_statistics_are_the_fluids_motion_per_frame(tmp_path):
    # thrown sideways at different speeds: the trajectories' mean velocities differ
    _, out = _make(tmp_path, _spec(**{"fluid_regions[0].velocity": [
        [1.0, 0.0], [-1.0, 0.0], [0.5, 0.0], [-0.5, 0.0], [0.0, 0.0]]}))
    meta = json.loads((out / "metadata.json").read_text())
    vels = []
    for split in ("train", "valid", "test"):
        with h5py.File(out / f"{split}.h5", "r") as f:
            for k in f:
                fluid = f[k]["position"][:, :100].astype(np.float64)
                vels.append(np.diff(fluid, axis=0).reshape(-1, 2))
    # LagrangeBench's generator: the trajectories' means averaged; the spread
    # about that mean, each trajectory's mean square averaged
    mean = np.mean([v.mean(0) for v in vels], 0)
    std = np.sqrt(np.mean([((v - mean) ** 2).mean(0) for v in vels], 0))
    assert meta["vel_mean"] == pytest.approx(mean, rel=1e-5)
    assert meta["vel_std"] == pytest.approx(std, rel=1e-5)
    # (not the spread about each trajectory's own mean: the trajectories differ)
    own = np.sqrt(np.mean([v.var(0) for v in vels], 0))
    assert not np.allclose(std, own, rtol=1e-3)


def test_runs_that_blow_up_are_left_out_and_replaced(tmp_path):
    # the second run is the boom scene (test_check's): the sixth run takes its place
    spec = _spec(samples=6, **{"fluid.gas_constant": [250.0, 1e306, 250.0, 250.0, 250.0, 250.0],
                              "fluid.viscosity": [0.5, 0.0, 0.5, 0.5, 0.5, 0.5],
                              "solver.time_step": [0.001, 0.01, 0.001, 0.001, 0.001, 0.001]})
    spec["dataset"]["splits"]["train"] = 3
    code, out = _make(tmp_path, spec)
    assert code == 0
    meta = json.loads((out / "metadata.json").read_text())
    assert [x["run"] for x in meta["sphfluid"]["left_out"]] == [1]
    assert meta["sphfluid"]["left_out"][0]["reason"].startswith("blow-up")
    assert meta["sphfluid"]["runs"] == {"train": [0, 2, 3], "valid": [4], "test": [5]}
    # too few good runs: the dataset is written, the command fails and says so
    spec["dataset"]["splits"]["test"] = 2
    spec["samples"] = 7
    for key in ("fluid.gas_constant", "fluid.viscosity", "solver.time_step"):
        spec["vary"][key].append(spec["vary"][key][1])
    code, out = _make(tmp_path, spec, name="short")
    assert code == 1
    assert json.loads((out / "metadata.json").read_text())["sphfluid"]["missing"] == {"test": 1}


def test_the_same_file_gives_the_same_dataset(tmp_path):
    _, a = _make(tmp_path, _spec(), name="a")
    _, b = _make(tmp_path, _spec(), name="b")
    assert (a / "metadata.json").read_text() == (b / "metadata.json").read_text()
    for split in ("train", "valid", "test"):
        with h5py.File(a / f"{split}.h5", "r") as f, h5py.File(b / f"{split}.h5", "r") as g:
            assert list(f) == list(g)
            for k in f:
                assert np.array_equal(f[k]["position"][:], g[k]["position"][:])
    other = _spec()
    other["seed"] = 12
    _, c = _make(tmp_path, other, name="c")
    with h5py.File(a / "train.h5", "r") as f, h5py.File(c / "train.h5", "r") as g:
        assert not np.array_equal(f["00000/position"][:], g["00000/position"][:])


def test_a_sweep_file_without_a_dataset_section_is_refused(tmp_path, capsys):
    spec = _spec()
    del spec["dataset"]
    code, _ = _make(tmp_path, spec)
    assert code == 2
    assert "dataset: required by sphfluid dataset" in capsys.readouterr().err


def test_a_run_that_loses_particles_is_left_out(tmp_path):
    spec = _spec(samples=4, train=1, valid=1, test=1,
                 **{"fluid_regions[0].velocity": [[0.0, 0.0], [12.0, 0.0], [0.0, 0.0], [0.0, 0.0]]})
    spec["scene"]["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]}]
    spec["scene"]["domain"]["max"] = [0.7, 1.1]  # thrown at 12 m/s, some leave by 0.02 s
    code, out = _make(tmp_path, spec)
    assert code == 0
    meta = json.loads((out / "metadata.json").read_text())
    assert [(x["run"], x["reason"].split(" (")[0]) for x in meta["sphfluid"]["left_out"]] == [
        (1, "particles left the domain")]
    assert meta["sphfluid"]["runs"] == {"train": [0], "valid": [2], "test": [3]}


def test_the_worked_example_is_a_sweep_that_loads():
    from pathlib import Path

    from sphfluid.sweep import load_sweep

    path = Path(__file__).resolve().parents[1] / "docs" / "datasets" / "dam_break_2d.json"
    sweep = load_sweep(path)
    assert len(sweep.runs) == 105 and sum(sweep.dataset["splits"].values()) == 100
    assert all(-1.0 <= r.params["gravity[0]"] <= 0.0 for r in sweep.runs)
