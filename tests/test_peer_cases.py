"""PySPH's examples on our validation cases (benchmarks/peers/pysph_cases.py).

The scoring is checked on exact fields without PySPH: the PySPH output goes
through our cases' own sample() and score(), with the parameters of the PySPH run.
The subprocess' handling (reports as they come, timeouts, crashes, Ctrl-C: no
process left behind) is checked with a fake subprocess speaking the same protocol.
One real run of the cheapest case (Poiseuille, 10 particles across the gap, one
thread: seconds, a minute with PySPH's first compilation), marked slow, is skipped
when PySPH is not installed.
"""
from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import benchmark_module
from sphfluid.validation import reference as ref
from sphfluid.validation.cases import CASES

cases = benchmark_module("peers/pysph_cases.py")

# What the examples run with (see pysph_cases.py): Taylor-Green and the hydrostatic
# tank in our units; Poiseuille non-dimensional (gap 1, nu 0.01, --re 0.025).
TAYLOR_GREEN = {"length": 1.0, "speed": 1.0, "nu": 0.01}
POISEUILLE = {"length": 1.0, "nu": 0.01, "force": 2e-5, "time_scale": 100.0}
HYDROSTATIC = {"depth": 1.0, "rho0": 1000.0, "g": 9.81}


def lattice(n: int, width: float = 1.0, height: float = 1.0):
    """Particles at ((i + 1/2) dx, (j + 1/2) dx), dx = height / n."""
    dx = height / n
    x, y = np.meshgrid(np.arange(round(width / dx)) + 0.5, np.arange(n) + 0.5)
    return x.ravel() * dx, y.ravel() * dx


def snapshot(t, x, y, u, v, p=None, rho=None):
    zeros = np.zeros_like(x)
    return cases.Snapshot(t=float(t), x=x, y=y, u=u, v=v,
                          p=zeros if p is None else p, rho=zeros + 1.0 if rho is None else rho,
                          mass=1.0, ids=np.arange(len(x)))


def taylor_green_snapshots(n: int, factor: float = 1.0):
    """The exact vortex on the lattice at the sample times, its velocity x factor."""
    x, y = lattice(n)
    out = []
    for t in cases.our_case("taylor_green", TAYLOR_GREEN).sample_times():
        u, v = ref.taylor_green_velocity(x, y, t, nu=TAYLOR_GREEN["nu"])
        out.append(snapshot(t, x, y, factor * u, factor * v))
    return out


def test_exact_taylor_green_scores_zero():
    r = cases.score("taylor_green", taylor_green_snapshots(25), 25, TAYLOR_GREEN)
    assert r["failure"] == ""
    assert r["error"] < 1e-12
    assert r["metrics"]["decay rate error"] < 1e-9


def test_taylor_green_error_is_relative_to_the_exact_max_speed():
    r = cases.score("taylor_green", taylor_green_snapshots(25, factor=1.1), 25, TAYLOR_GREEN)
    x, y = lattice(25)
    u, v = ref.taylor_green_velocity(x, y, 1.0, nu=0.01)
    expected = 0.1 * np.sqrt(u**2 + v**2).max() / ref.taylor_green_decay(1.0, nu=0.01)
    assert r["error"] == pytest.approx(expected, rel=1e-9)
    assert r["metrics"]["decay rate error"] < 1e-9  # a constant factor keeps the slope


def test_poiseuille_runs_our_flow_in_the_examples_units():
    c = cases.our_case("poiseuille", POISEUILLE)
    assert c.sample_times() == pytest.approx([2.25, 4.5, 11.25, 22.5, 100.0])
    # the example's v_max gap / nu is our Re (Morris et al.: 2.5e-5 m/s x 1 mm / 1e-6)
    assert cases._reynolds("poiseuille") == pytest.approx(0.025)
    v0 = ref.poiseuille_centre_max(1.0, 0.01, 2e-5)
    assert v0 * 1.0 / 0.01 == pytest.approx(0.025)
    eta = np.linspace(0.0, 1.0, 11)
    for t_ours, t_example in zip(CASES["poiseuille"].times, c.sample_times()):
        ours = ref.poiseuille_velocity(eta * 1e-3, t_ours, gap=1e-3, nu=1e-6, force=2e-4)
        example = ref.poiseuille_velocity(eta, t_example, gap=1.0, nu=0.01, force=2e-5)
        np.testing.assert_allclose(example / v0, ours / 2.5e-5, atol=1e-12)


def test_exact_poiseuille_scores_zero_and_an_offset_its_size():
    c = cases.our_case("poiseuille", POISEUILLE)
    x, y = lattice(10, width=0.4)
    v0 = ref.poiseuille_centre_max(1.0, 0.01, 2e-5)
    for offset in (0.0, 0.03):
        snaps = [snapshot(t, x, y, ref.poiseuille_velocity(y, t, gap=1.0, nu=0.01, force=2e-5)
                          + offset * v0, np.zeros_like(x)) for t in c.sample_times()]
        r = cases.score("poiseuille", snaps, 10, POISEUILLE)
        assert r["error"] == pytest.approx(offset, abs=1e-12)


def test_exact_hydrostatic_pressure_scores_zero():
    x, y = lattice(10)
    p = ref.hydrostatic_pressure(y, depth=1.0, rho0=1000.0)
    times = cases.our_case("hydrostatic", HYDROSTATIC).sample_times()
    snaps = [snapshot(t, x, y, np.zeros_like(x), np.zeros_like(x), p=p, rho=p * 0 + 1000.0)
             for t in times]
    r = cases.score("hydrostatic", snaps, 10, HYDROSTATIC)
    assert r["failure"] == "" and r["error"] < 1e-12
    assert r["metrics"]["max |v| / sqrt(gH)"] == 0.0


def test_hydrostatic_score_refuses_other_units():
    with pytest.raises(ValueError, match="rho0 = 1000"):
        cases.our_case("hydrostatic", {**HYDROSTATIC, "g": 1.0})


def test_non_finite_velocities_fail():
    snaps = taylor_green_snapshots(10)
    snaps[-1].u[3] = np.nan
    r = cases.score("taylor_green", snaps, 10, TAYLOR_GREEN)
    assert math.isnan(r["error"]) and r["failure"] == "non-finite velocities"


@pytest.mark.parametrize(("case", "scheme"), list(cases.PAIRS))
def test_every_pair_has_a_subprocess_configuration(case, scheme):
    cfg = cases._child_config(case, scheme, 10, "/nonexistent", None)
    assert cfg["options"][:len(cases.PAIRS[case, scheme])] == list(cases.PAIRS[case, scheme])
    assert cfg["times"] == sorted(cfg["times"]) and cfg["times"][0] > 0
    assert cfg["times"][-1] == {"taylor_green": 1.0, "poiseuille": 1.0, "hydrostatic": 5.0,
                                "cavity": 30.0}[case]
    if case in ("taylor_green", "cavity"):
        assert cfg["options"][cfg["options"].index("--re") + 1] == "100"
    if case == "poiseuille":
        assert cfg["options"] == ["--re", "0.025"] and cfg["viscous_time"] == 1.0
    if case == "hydrostatic":
        assert cfg["tank"] == {"width": 1.0, "wall_top": 1.5, "depth": 1.0, "g": 9.81,
                               "duration": 5.0}


def test_unknown_pairs_are_refused(capsys):
    with pytest.raises(ValueError, match="no PySPH run"):
        cases.run_case("dam_break", "wcsph", 10)
    with pytest.raises(ValueError, match="cavity only"):
        cases.run_case("taylor_green", "edac", 10, end_time=10.0)
    assert cases.main(["--list"]) == 0
    listed = capsys.readouterr().out.split("\n")
    assert "taylor_green edac" in listed and "poiseuille tvf" in listed


def test_what_validate_peers_runs():
    assert cases.schemes("taylor_green") == ("edac", "tvf", "wcsph")
    assert cases.schemes("hydrostatic") == ("adami", "monaghan_kajtar", "dynamic")
    assert cases.schemes("dam_break") == ()
    for case in {c for c, _ in cases.PAIRS}:  # ours, the full mode's finest capped
        assert cases.resolutions(case, "quick") == CASES[case].resolutions["quick"]
        top = cases.FULL_MAX_N.get(case, math.inf)
        assert cases.resolutions(case, "full") == tuple(
            n for n in CASES[case].resolutions["full"] if n <= top)
    assert cases.resolutions("cavity", "full") == (25, 50)
    assert cases.resolutions("taylor_green", "full") == (25, 50, 100)
    with pytest.raises(ValueError, match="no PySPH peer"):
        cases.resolutions("droplet", "quick")
    assert cases.label("edac", "1.0b2") == "PySPH 1.0b2 EDAC"
    assert cases.label("adami", "1.0b2") == "PySPH 1.0b2 WCSPH, Adami walls"
    assert cases.label("tvf", "") == "PySPH TVF"
    assert set(cases.SCHEME_NAMES) == {s for _, s in cases.PAIRS}


# A stand-in for the subprocess: the report lines of a run of 100 particles to
# t_end = 2, then what FAKE_MODE says. It writes its pid and its own child's
# (a sleeper in the same session) to $FAKE_PIDS.
FAKE_CHILD = r'''
import json, os, subprocess, sys, time
TAG = "@pysph-case"
def report(kind, **fields):
    print(TAG, kind, json.dumps(fields), flush=True)
sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
with open(os.environ["FAKE_PIDS"], "w") as f:
    f.write(f"{os.getpid()} {sleeper.pid}")
print("the example's own output")
report("start", version="0.0", particles=100, setup_s=0.5, t_end=2.0)
mode = os.environ["FAKE_MODE"]
if mode == "abort":
    os.abort()
if mode == "no report":
    sys.exit(0)
report("progress", t=1.0, steps=40, wall_s=0.25)
print(TAG, "progress {\"t\": 1.5, \"st", flush=True)  # cut short: ignored
time.sleep(60)
'''


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has ended
    except FileNotFoundError:
        return False


@pytest.fixture
def fake_child(monkeypatch, tmp_path):
    """The driver's subprocess replaced by FAKE_CHILD; returns a function giving the
    pids it wrote. PySPH need not be installed (json is found in its place)."""
    script = tmp_path / "fake_child.py"
    script.write_text(FAKE_CHILD)
    pids = tmp_path / "pids"
    monkeypatch.setattr(cases, "PEER_MODULE", "json")
    monkeypatch.setattr(cases, "_child_command",
                        lambda config: [sys.executable, str(script), str(config)])
    monkeypatch.setenv("FAKE_PIDS", str(pids))

    def ended() -> bool:
        """Whether the fake and its sleeper have both ended (within 5 s)."""
        found = [int(p) for p in pids.read_text().split()]
        deadline = time.monotonic() + 5.0
        while any(_alive(p) for p in found) and time.monotonic() < deadline:
            time.sleep(0.05)
        return len(found) == 2 and not any(_alive(p) for p in found)

    return ended


def test_a_timed_out_run_keeps_what_it_reported_and_leaves_no_process(fake_child,
                                                                       monkeypatch):
    monkeypatch.setenv("FAKE_MODE", "sleep")
    seen = []
    r = cases.run_case("taylor_green", "edac", 10, timeout=3.0,
                       progress=lambda done, s: seen.append(done))
    assert r["failure"] == "timed out after 3 s at 50 % of its simulated time"
    assert (r["version"], r["particles"], r["steps"], r["wall_s"]) == ("0.0", 100, 40, 0.25)
    assert math.isnan(r["error"])
    assert seen == [0.5]
    assert fake_child()


@pytest.mark.parametrize(("mode", "failure"), [
    ("abort", "killed by SIGABRT before its first output"),
    ("no report", "ended without its report before its first output"),
])
def test_a_run_that_dies_is_a_failure(fake_child, monkeypatch, mode, failure):
    monkeypatch.setenv("FAKE_MODE", mode)
    r = cases.run_case("taylor_green", "edac", 10, timeout=60.0)
    assert r["failure"] == failure and r["particles"] == 100
    assert fake_child()


def test_an_interrupted_caller_kills_the_run(fake_child, monkeypatch, tmp_path):
    monkeypatch.setenv("FAKE_MODE", "sleep")

    class Interrupted(subprocess.Popen):
        def wait(self, timeout=None):
            if timeout is None:  # the kill's wait
                return super().wait()
            deadline = time.monotonic() + 30.0  # the run is under way: Ctrl-C
            while not (tmp_path / "pids").exists() and time.monotonic() < deadline:
                time.sleep(0.05)
            raise KeyboardInterrupt

    monkeypatch.setattr(cases.subprocess, "Popen", Interrupted)
    with pytest.raises(KeyboardInterrupt):
        cases.run_case("taylor_green", "edac", 10, timeout=60.0)
    assert fake_child()


def test_availability_without_pysph(monkeypatch):
    monkeypatch.setattr(cases, "PEER_MODULE", "sphfluid_no_such_peer")
    assert cases.availability() == ("", "sphfluid_no_such_peer is not installed "
                                        "(pip install pysph==1.0b2; docs/peers.md)")
    r = cases.run_case("poiseuille", "tvf", 10)
    assert r["failure"].startswith("sphfluid_no_such_peer is not installed")


@pytest.mark.slow
def test_pysph_poiseuille_at_ten_particles():
    pytest.importorskip("pysph")
    version, reason = cases.availability()
    assert reason == "" and version == "1.0b2"
    seen = []
    r = cases.run_case("poiseuille", "tvf", 10, threads=1, timeout=300,
                       progress=lambda done, s: seen.append(done))
    assert r["failure"] == "", r["failure"]
    assert r["peer"] == "pysph" and r["version"] == version
    assert r["particles"] == 40  # 10 rows, the example's width 0.4 gap
    assert r["steps"] > 0 and r["wall_s"] > 0
    assert seen[0] == 0.0 and seen[-1] == pytest.approx(1.0) and seen == sorted(seen)
    # 2.0 % measured (PySPH 1.0b2); ours is of the same order at this resolution
    assert 0.002 < r["error"] < 0.1
