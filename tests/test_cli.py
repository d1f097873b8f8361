"""The command line: run on every scene, clean failures, view headless."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import sphfluid
from conftest import BASE_SCENE, SCENE_IDS, SCENES, write_boom_scene
from sphfluid.cli import main


def sphfluid_cmd(*args, env=None):
    return subprocess.run([sys.executable, "-m", "sphfluid", *map(str, args)],
                          capture_output=True, text=True, timeout=300, env=env, check=False)


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_run_every_scene_briefly(path, capsys):
    assert main(["run", str(path), "--duration", "0.01", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "particle-steps/s" in out and "max density error" in out
    assert "max compression" in out
    assert "removed particles   0" in out


@pytest.mark.parametrize("solver, why", [
    ({"method": "seed"}, "the summed density falls short"),
    ({"method": "wcsph", "density": "summation"}, "the summed density falls short"),
    ({"method": "wcsph"}, "the carried density stretches"),  # W26b, the default
    ({"method": "wcsph", "free_surface": "density_floor"}, "of the same states)"),
])
def test_run_says_why_a_density_error_can_be_large(tmp_path, capsys, solver, why):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps({**BASE_SCENE, "solver": {**BASE_SCENE.get("solver", {}),
                                                          **solver}}))
    assert main(["run", str(scene), "--duration", "0.005", "--quiet"]) == 0
    line = next(t for t in capsys.readouterr().out.splitlines() if "max density error" in t)
    assert why in line
    assert ("falls short" in line) + ("stretches" in line) == ("states)" not in why)


def test_run_writes_frames(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["run", str(scene), "--duration", "0.02", "--out", str(tmp_path / "out"),
                 "--every", "0.005", "--quiet"]) == 0
    frames = sorted((tmp_path / "out").glob("frame_*.npz"))
    assert len(frames) == 5  # t = 0, 0.005, 0.01, 0.015, 0.02
    last = np.load(frames[-1])
    assert float(last["time"]) == pytest.approx(0.02)
    assert last["positions"].shape == (100, 2) and last["ids"].shape == (100,)
    assert json.loads((tmp_path / "out" / "scene.json").read_text())["format"] == "sphfluid-scene/1"


def test_run_shows_progress_and_summary_in_a_subprocess(tmp_path):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    r = sphfluid_cmd("run", scene)
    assert r.returncode == 0, r.stderr
    header, *bar = r.stderr.splitlines()
    assert "100 particles" in header
    # Not a terminal: each redraw a line of its own (at most one per 30 s), no
    # carriage returns; the first at t = 0, the last at the end.
    assert "\r" not in r.stderr and len(bar) == 2, r.stderr
    assert bar[0].startswith("  0%|") and "t = 0.0000/0.05 s" in bar[0]
    assert bar[1].startswith("100%|") and "t = 0.0500/0.05 s" in bar[1]
    assert re.search(r"dt 0\.001 s, [\d,]+ steps/s\]$", bar[1]), bar[1]
    assert "steps               50" in r.stdout and "%|" not in r.stdout


# 0 columns: a terminal whose size was never set (drawn 80 wide)
@pytest.mark.parametrize("columns", [100, 0])
def test_run_redraws_progress_in_place_on_a_terminal(columns):
    pty = pytest.importorskip("pty")
    import fcntl
    import struct
    import termios

    master, terminal = pty.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, columns, 0, 0))
    # 1,500 steps of the seed's dam break: about half a second
    p = subprocess.Popen([sys.executable, "-m", "sphfluid", "run", str(SCENES[0]),
                          "--duration", "0.3"],
                         stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=terminal)
    os.close(terminal)
    seen = b""
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the child closed its end
            break
        if not data:
            break
        seen += data
    out = p.communicate(timeout=300)[0]
    os.close(master)
    assert p.returncode == 0, seen
    text = seen.decode()
    # A line redrawn in place: carriage returns, the header and the finished bar
    # on lines of their own.
    assert text.count("\r") >= 3, text
    lines = text.replace("\r\n", "\n").split("\n")
    assert len([x for x in lines if x.strip()]) == 2, text
    last = lines[1].split("\r")[-1]
    assert "t = 0.300/0.3 s" in last and last.startswith("100%|"), text
    assert (columns or 80) - 2 <= len(last) <= (columns or 80), last  # the line's width
    assert b"steps               1,500" in out


def test_progress_goes_to_stderr_and_quiet_leaves_it_out(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["run", str(scene)]) == 0
    out, err = capsys.readouterr()
    assert "100%|" in err and "t = 0.0500/0.05 s" in err and "steps/s]" in err
    assert "%|" not in out
    assert main(["run", str(scene), "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert "%|" not in err and "t = 0.0500/" not in err and "%|" not in out
    assert "steps               50" in out


def test_quiet_run_says_once_how_long_a_long_run_takes(tmp_path, capsys, monkeypatch):
    from sphfluid import cli

    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["run", str(scene), "--quiet"]) == 0  # a short run: no note
    assert "note:" not in capsys.readouterr().err
    # the same run, with "long" meaning any time at all: one note, with an estimate
    monkeypatch.setattr(cli._Run, "LONG_RUN", 1e-12)
    monkeypatch.setattr(cli._Run, "NOTE_AFTER", 0.0)
    assert main(["run", str(scene), "--quiet"]) == 0
    out, err = capsys.readouterr()
    notes = [line for line in err.splitlines() if line.startswith("note:")]
    assert len(notes) == 1, err
    assert re.search(r"ends in about [0-9.e-]+ s \(t = [0-9.e-]+ of 0.05 s after", notes[0])
    assert "--checkpoint-every T" in notes[0]
    assert "steps               50" in out  # the same steps as without the note
    assert main(["run", str(scene)]) == 0  # the bar shows the time left: no note
    assert "note:" not in capsys.readouterr().err


def test_runs_bar_counts_the_runs_below_their_lines(capsys):
    from sphfluid.progress import Runs

    with Runs(3) as runs:
        runs.line("starting")
        for k in range(3):
            runs.done(f"run {k} finished")
    err = capsys.readouterr().err.splitlines()
    lines = [line for line in err if "%|" not in line]
    assert lines == ["starting", "run 0 finished", "run 1 finished", "run 2 finished"]
    assert err[0].startswith("  0%|")  # off a terminal: the bar at the start and the end
    assert err[-1].startswith("100%|") and "| 3/3 runs [" in err[-1]


@pytest.mark.parametrize("content,message", [
    ('{"format": "sphfluid-scene/1",\n "name": oops}', r"invalid JSON at line 2, column 10"),
    (json.dumps({**BASE_SCENE, "solvr": {}}), r'solvr: unknown key \(did you mean "solver"\?\)'),
    (json.dumps({**BASE_SCENE, "fluid": {"rest_density": -1, "gas_constant": 1}}),
     r"fluid.rest_density: must be > 0, got -1"),
])
def test_run_fails_cleanly_on_a_broken_scene(tmp_path, content, message):
    scene = tmp_path / "broken.json"
    scene.write_text(content)
    r = sphfluid_cmd("run", scene)
    assert r.returncode == 2
    assert r.stderr.startswith("error: ") and "Traceback" not in r.stderr
    assert __import__("re").search(message, r.stderr), r.stderr


def test_run_fails_cleanly_on_unreadable_inputs(tmp_path, capsys):
    assert main(["run", str(tmp_path / "missing.json")]) == 2
    assert "file not found" in capsys.readouterr().err
    assert main(["run", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps({k: v for k, v in BASE_SCENE.items() if k != "duration"}))
    assert main(["run", str(scene)]) == 2
    assert "pass --duration" in capsys.readouterr().err


def test_run_refuses_a_scene_larger_than_memory(tmp_path, capsys):
    d = json.loads(json.dumps(BASE_SCENE))
    d["domain"] = {"min": [-1, -1], "max": [3000, 3000]}
    d["resolution"] = {"spacing": 0.05, "smoothing_length": 0.6}
    d["fluid_regions"][0]["max"] = [2900, 2900]
    d["walls"] = []
    scene = tmp_path / "huge.json"
    scene.write_text(json.dumps(d))
    assert main(["run", str(scene)]) == 2
    assert "more than memory allows" in capsys.readouterr().err


def test_unstable_run_exits_3_with_the_reason(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the last good state is saved in the current folder
    scene = write_boom_scene(tmp_path)
    assert main(["run", str(scene), "--quiet", "--no-check"]) == 3  # past the check
    err = capsys.readouterr().err
    assert "non-finite" in err
    # what to change, with the scene's values: the seed, a fixed step, no retries
    assert ('what to change: a smaller "solver.time_step" (now 0.01 s), or "auto" for the '
            'largest stable one; more "fluid.viscosity" (now 0 Pa s;') in err
    assert '"solver.method": "wcsph"' in err and '"solver.on_instability": "retry"' in err
    assert (tmp_path / "boom.last_good_state.npz").exists()


def test_bad_arguments_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        main(["run", str(SCENES[0]), "--duration", "-1"])
    assert e.value.code == 2
    assert "must be > 0" in capsys.readouterr().err


def test_view_runs_headless_and_saves_a_screenshot(tmp_path):
    shot = tmp_path / "shot.png"
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    r = sphfluid_cmd("view", SCENES[0], "--frames", "5", "--screenshot", shot,
                     "--size", "400x300", env=env)
    assert r.returncode == 0, r.stderr
    import pygame

    img = pygame.image.load(str(shot))
    assert img.get_size() == (400, 300)
    pixels = pygame.surfarray.array3d(img).reshape(-1, 3)
    # Some pixels carry the particle colours (blue dominant), most the background.
    blue = (pixels[:, 2] > 150) & (pixels[:, 0] < 120)
    assert blue.sum() > 500


def test_stress_full_write_without_the_scenes_is_refused_before_running(tmp_path, capsys):
    """--full --write would replace the report's section without its bundled
    scenes: refused at once, the file untouched."""
    report = tmp_path / "STABILITY.md"
    report.write_text("kept\n")
    code = main(["stress", "--full", "--out", str(tmp_path), "--write", str(report),
                 "--scenes", str(tmp_path / "missing")])
    assert code == 2
    assert "--scenes DIR" in capsys.readouterr().err
    assert report.read_text() == "kept\n"


def test_bench_with_surface_tension_times_the_tensed_dam_break(capsys):
    from sphfluid import Simulation
    from sphfluid.bench import bench_scene

    scene = bench_scene(300, "wcsph", 5.0)
    assert scene["fluid"]["surface_tension"] == 5.0
    assert Simulation(scene).scene.surface_tension == 5.0
    assert "surface_tension" not in bench_scene(300, "wcsph")["fluid"]
    assert main(["bench", "--particles", "300", "--steps", "3", "--warmup", "1", "--threads", "1",
                 "--repeat", "1", "--method", "wcsph", "--surface-tension", "5"]) == 0
    out = capsys.readouterr().out
    assert "--surface-tension 5`" in out and "max compression" in out
    assert main(["bench", "--surface-tension", "-1"]) == 2
    assert main(["bench", "--suite", "--surface-tension", "5"]) == 2


def test_bench_says_when_a_small_scene_steps_on_one_thread(capsys):
    """Below 1,000 particles the 2-thread row runs on one: the table says so."""
    from sphfluid.bench import run_case

    assert run_case(300, 2, 2, 0)["in_use"] == 1
    if not sphfluid.has_openmp:
        return
    assert main(["bench", "--particles", "300", "--steps", "2", "--warmup", "1", "--threads",
                 "1,2", "--repeat", "1"]) == 0
    out = capsys.readouterr().out
    assert "| 2 (1 in use) |" in out and "below 1,000 particles" in out
    assert main(["bench", "--particles", "1200", "--steps", "2", "--warmup", "1", "--threads",
                 "2", "--repeat", "1"]) == 0
    assert "in use" not in capsys.readouterr().out


def test_bench_times_both_pair_precisions_in_one_table(capsys):
    assert main(["bench", "--particles", "300", "--steps", "2", "--warmup", "1", "--threads",
                 "1", "--repeat", "1", "--pair-precision", "double,float"]) == 0
    out = capsys.readouterr().out
    assert "--pair-precision double,float`" in out
    rows = [line for line in out.splitlines() if line.startswith("| 1 |")]
    assert len(rows) == 4  # both precisions, in the throughput and the phase tables
    ran = "float" if _core_float_pairs() else "float (double ran)"
    assert sum(f"| 1 | {ran} |" in r for r in rows) == 2
    assert sum("| 1 | double |" in r for r in rows) == 2
    assert main(["bench", "--pair-precision", "single"]) == 2
    assert main(["bench", "--pair-precision", "float", "--method", "wcsph"]) == 2
    assert "seed method only" in capsys.readouterr().err


def _core_float_pairs() -> bool:
    """Whether this build runs the float pair sums (the cell clusters: AVX-512F, VL)."""
    from sphfluid.bench import bench_scene

    d = bench_scene(300)
    d["solver"]["pair_precision"] = "float"
    return sphfluid.Simulation(d)._solver.float_pairs


def test_run_says_which_precision_the_pair_sums_ran_in(tmp_path, capsys):
    d = json.loads((SCENES[0].parent / "dam_break.json").read_text())
    d["solver"]["pair_precision"] = "float"
    scene = tmp_path / "float.json"
    scene.write_text(json.dumps(d))
    assert main(["run", str(scene), "--duration", "0.002", "--quiet"]) == 0
    err = capsys.readouterr().err
    ran = "float" if _core_float_pairs() else "double: float runs without"
    assert f"method seed (pair forces in {ran}" in err
    d["fluid"]["surface_tension"] = 1.0  # the seed with tension keeps its lists, in double
    scene.write_text(json.dumps(d))
    assert main(["run", str(scene), "--duration", "0.002", "--quiet"]) == 0
    assert "method seed (pair forces in double: float runs without" in capsys.readouterr().err
