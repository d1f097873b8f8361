"""Checkpoints (sphfluid.checkpoint): a run resumed from one continues bit for
bit as the run that wrote it, for each method and density, fixed and adaptive
time steps, one thread and two; another scene, another version and files that
are not checkpoints are refused; a writer killed mid-file leaves the last
whole checkpoint."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import ROOT
from sphfluid import Simulation, _core
from sphfluid.checkpoint import CheckpointError, read
from sphfluid.validation.cases import CASES

FIELDS = ("positions", "velocities", "accelerations", "densities", "pressures", "ids")


def case_scene(case, method, n, time_step=None, density=None, **solver):
    d = CASES[case].scene(n, method)
    d["solver"].update(solver)
    if time_step is not None:
        d["solver"]["time_step"] = time_step
        d["solver"].pop("cfl", None)
    if density is not None:
        d["solver"]["density"] = density
    return d


# Each method and density, with walls, a sliding lid and periodic axes among
# them; above 1,000 particles, so that two threads run the loops.
RUNS = {
    "seed dam break, fixed dt": (case_scene("dam_break", "seed", 24, time_step=2e-4), 0.01),
    "wcsph continuity dam break": (case_scene("dam_break", "wcsph", 24), 0.02),
    "wcsph continuity dam break, W30": (
        case_scene("dam_break", "wcsph", 24, viscosity_reconstruction=True), 0.02),
    "wcsph summation dam break, fixed dt": (
        case_scene("dam_break", "wcsph", 24, time_step=2e-4, density="summation"), 0.01),
    "wcsph continuity cavity, shifting": (case_scene("cavity", "wcsph", 32), 0.01),
    "wcsph continuity Taylor-Green, periodic": (case_scene("taylor_green", "wcsph", 32), 0.01),
}


def same_state(a, b):
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS) and \
        (a.time, a.step_count, a.wall_crossings) == (b.time, b.step_count, b.wall_crossings)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("run", list(RUNS))
def test_a_resumed_run_continues_bit_for_bit(run, threads, tmp_path):
    scene, t = RUNS[run]
    a = Simulation(scene, threads=threads)
    assert a.n_particles > 1000
    a.advance_to(t)
    a.save_state(tmp_path / "c.npz")
    a.advance_to(2 * t)
    b = Simulation.from_checkpoint(tmp_path / "c.npz", threads=threads)
    assert b.time == t
    b.advance_to(2 * t)
    assert b.step_count > a.step_count / 2 + 5  # steps were taken after the checkpoint
    assert same_state(a, b)
    c = Simulation(scene, threads=3 - threads)  # the other thread count, into a running one
    c.advance_to(0.5 * t)
    c.load_state(tmp_path / "c.npz")
    c.advance_to(2 * t)
    assert same_state(a, c)


@pytest.mark.parametrize("spoil", ["method's numbers", "kernel sums"])
def test_what_the_checkpoint_holds_besides_the_state_matters(spoil, tmp_path):
    """The cavity (shifting, a sliding lid) resumed with the method's numbers
    (whether the next drift shifts) or its kernel sums (the free-surface test
    of the next shift) spoilt takes another path: the test above can fail."""
    scene, t = RUNS["wcsph continuity cavity, shifting"]
    a = Simulation(scene, threads=1)
    a.advance_to(t)
    a.save_state(tmp_path / "c.npz")
    a.advance_to(2 * t)
    meta, fields = read(tmp_path / "c.npz")
    snap = {**meta["solver"], "fields": fields}
    if spoil == "kernel sums":
        fields["kernel_sum"] = np.zeros_like(fields["kernel_sum"])
    else:
        snap["method"] = [*snap["method"][:2], 0.0, *snap["method"][3:]]
    b = Simulation(scene, threads=1)
    b._solver.restore(snap)
    b.advance_to(2 * t)
    assert not same_state(a, b)


def test_the_file_reads_as_a_reader_expects(tmp_path):
    sim = Simulation(RUNS["wcsph continuity cavity, shifting"][0], threads=1)
    sim.advance_to(0.005)
    sim.save_state(tmp_path / "c.npz")
    with np.load(tmp_path / "c.npz") as z:
        np.testing.assert_array_equal(z["positions"], sim.positions)
        np.testing.assert_array_equal(z["ids"], sim.ids)
        assert float(z["time"]) == sim.time and int(z["step_count"]) == sim.step_count
        assert {"field_shift", "field_kernel_sum"} <= set(z.files)
        meta = json.loads(str(z["checkpoint"][()]))
    assert meta["format"] == "sphfluid-checkpoint/1"
    assert meta["sphfluid_version"] == _core.__version__
    assert meta["method"] == "wcsph" and meta["threads"] == 1
    assert meta["scene"]["name"] == "validation: lid-driven cavity"
    assert len(meta["scene_hash"]) == 64
    assert [f for f in os.listdir(tmp_path)] == ["c.npz"]  # no temporary file left


def test_another_scene_is_refused_and_nothing_changes(tmp_path):
    a = Simulation(RUNS["wcsph continuity cavity, shifting"][0], threads=1)
    a.advance_to(0.005)
    a.save_state(tmp_path / "c.npz")
    other = case_scene("cavity", "wcsph", 30)
    b = Simulation(other, threads=1)
    before = b.positions.copy()
    with pytest.raises(CheckpointError, match=r"c\.npz: written for another scene "
                       r"\('validation: lid-driven cavity'.*Simulation\.from_checkpoint"):
        b.load_state(tmp_path / "c.npz")
    np.testing.assert_array_equal(b.positions, before)
    assert b.time == 0


def _rewrite_meta(src, dst, change):
    with np.load(src) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["checkpoint"][()]))
    change(meta)
    arrays["checkpoint"] = np.array(json.dumps(meta))
    np.savez(dst, **arrays)


def test_another_version_and_other_files_are_refused(tmp_path):
    a = Simulation(RUNS["wcsph continuity dam break"][0], threads=1)
    a.save_state(tmp_path / "c.npz")
    _rewrite_meta(tmp_path / "c.npz", tmp_path / "old.npz",
                  lambda m: m.update(sphfluid_version="0.0.1"))
    with pytest.raises(CheckpointError, match=r"written by sphfluid 0\.0\.1, this is "):
        Simulation.from_checkpoint(tmp_path / "old.npz")
    np.savez(tmp_path / "frame.npz", positions=a.positions)
    with pytest.raises(CheckpointError, match="not a sphfluid checkpoint"):
        a.load_state(tmp_path / "frame.npz")
    (tmp_path / "torn.npz").write_bytes((tmp_path / "c.npz").read_bytes()[:5000])
    with pytest.raises(CheckpointError, match="cannot be read as a checkpoint"):
        a.load_state(tmp_path / "torn.npz")
    _rewrite_meta(tmp_path / "c.npz", tmp_path / "seed.npz",
                  lambda m: m["solver"].update(method=[]))
    with pytest.raises(CheckpointError, match="carries 5 numbers, not 0"):
        a.load_state(tmp_path / "seed.npz")
    with pytest.raises(CheckpointError, match="cannot be read"):
        a.load_state(tmp_path / "missing.npz")


WRITER = """
import sys
from sphfluid import Simulation
sim = Simulation(sys.argv[1], threads=1)
sim.save_state(sys.argv[2])
print("first", flush=True)
while True:
    sim.step(1)
    sim.save_state(sys.argv[2])
"""


def test_a_writer_killed_mid_file_leaves_a_whole_checkpoint(tmp_path):
    """A process saving checkpoints of a 3,300-particle scene over and over is
    killed at eight moments: the file is always a whole checkpoint (written
    in place instead, it was torn in each of three such runs)."""
    path = tmp_path / "c.npz"
    for delay in (0.05, 0.08, 0.13, 0.17, 0.21, 0.26, 0.31, 0.37):
        with subprocess.Popen([sys.executable, "-c", WRITER,
                               str(ROOT / "scenes" / "water" / "dam_break.json"), str(path)],
                              stdout=subprocess.PIPE, text=True) as proc:
            assert proc.stdout.readline().strip() == "first"
            time.sleep(delay)
            proc.send_signal(signal.SIGKILL)
        meta, fields = read(path)
        assert len(fields["position"]) == len(fields["id"]) > 3000
        Simulation.from_checkpoint(path).step(1)


def _cli(*args):
    from sphfluid.cli import main
    return main([str(a) for a in args])


@pytest.mark.parametrize("fmt", ["npz", "vtk"])
def test_a_run_resumed_from_the_command_line_ends_as_one_run(fmt, tmp_path, capsys):
    """`run --checkpoint-every` to t = 0.06 s, then `--resume` to 0.12 s: the
    frames after the checkpoint and the last checkpoint are those of one run to
    0.12 s, and the frames continue the same collection."""
    scene = ROOT / "scenes" / "water" / "dam_break.json"
    common = ["--checkpoint-every", 0.06, "--every", 0.02, "--format", fmt, "--quiet",
              "--threads", 2]
    assert _cli("run", scene, "--duration", 0.12, "--out", tmp_path / "one", *common) == 0
    assert _cli("run", scene, "--duration", 0.06, "--out", tmp_path / "two", *common) == 0
    assert _cli("run", scene, "--duration", 0.12, "--out", tmp_path / "two", *common,
                "--resume", tmp_path / "two" / "checkpoint.npz") == 0
    out = capsys.readouterr().out
    assert "(from t = 0.06 s to 0.12 s)" in out and "checkpoint.npz (t = 0.12 s" in out
    one, two = tmp_path / "one", tmp_path / "two"
    assert sorted(p.name for p in one.glob("frame_*")) == \
        sorted(p.name for p in two.glob("frame_*"))
    if fmt == "npz":
        for name in ("frame_00005.npz", "frame_00006.npz"):
            with np.load(one / name) as a, np.load(two / name) as b:
                for key in ("time", "positions", "velocities", "densities", "ids"):
                    np.testing.assert_array_equal(a[key], b[key])
    else:
        from sphfluid.output import read_vtu
        a, b = read_vtu(one / "frame_00006.vtu"), read_vtu(two / "frame_00006.vtu")
        np.testing.assert_array_equal(a["points"], b["points"])
        for key in a["point_data"]:
            np.testing.assert_array_equal(a["point_data"][key], b["point_data"][key])

        def frames(folder):
            import xml.etree.ElementTree as ET
            return [(d.get("timestep"), d.get("file"))
                    for d in ET.parse(folder / "frames.pvd").getroot().iter("DataSet")
                    if d.get("part") == "0"]
        assert frames(one) == frames(two) and len(frames(one)) == 7
    ma, fa = read(one / "checkpoint.npz")
    mb, fb = read(two / "checkpoint.npz")
    assert ma["solver"] == mb["solver"] and ma["solver"]["time"] == 0.12
    assert all(np.array_equal(fa[k], fb[k]) for k in fa)


def test_the_command_line_refuses_what_it_cannot_resume(tmp_path, capsys):
    scene = ROOT / "scenes" / "water" / "dam_break.json"
    assert _cli("run", scene, "--duration", 0.01, "--checkpoint-every", 0.01) == 2
    assert "--checkpoint-every needs --out DIR" in capsys.readouterr().err
    assert _cli("run", scene, "--duration", 0.01, "--out", tmp_path, "--checkpoint-every",
                0.01, "--quiet") == 0
    capsys.readouterr()
    assert _cli("run", scene, "--duration", 0.01, "--resume", tmp_path / "checkpoint.npz") == 2
    assert "at or past the end of the run (t = 0.01 s); pass a longer --duration" in \
        capsys.readouterr().err
    other = ROOT / "scenes" / "water" / "hydrostatic.json"
    assert _cli("run", other, "--duration", 1, "--resume", tmp_path / "checkpoint.npz") == 2
    assert "written for another scene" in capsys.readouterr().err
    assert _cli("run", scene, "--resume", tmp_path / "scene.json") == 2
    assert "cannot be read as a checkpoint" in capsys.readouterr().err
