"""The peer driver (sphfluid.peers): availability, clean refusals, crash and timeout
reports, and (marker `bench`) real runs of the installed peers at a coarse spacing.

Everything but the `bench` test runs without PySPH or SPlisHSPlasH installed: a fake
peer (a short script speaking the driver's protocol) stands in for them.
"""
from __future__ import annotations

import dataclasses
import math

import pytest
from sphfluid import peers

FAKE_START = r'''
import json, os, sys, time
cfg = json.loads(sys.argv[1])
def emit(kind, **fields):
    print(cfg["tag"], kind, json.dumps(fields), flush=True)
print("a line of the peer's own output")
emit("start", method="FAKE", version="0.1", particles=100)
for k in range(1, 41):  # 10 steps and 1 ms per sample, front 1 cm further each time
    emit("sample", t=k * cfg["sample_every"], z=1.0 + 0.01 * k, steps=10 * k, wall=1e-3 * k)
'''


def fake_peer(monkeypatch, ending: str, name: str = "fake") -> str:
    """Register a peer that runs FAKE_START then `ending`; returns its name."""
    spec = peers._Peer(module="json", probe="pass", requirement="fake", methods=("FAKE",),
                       script=FAKE_START + ending, note=lambda method, dx: "a fake peer.")
    monkeypatch.setitem(peers._PEER_SPECS, name, spec)
    return name


def test_available_reports_every_peer():
    reasons = peers.available()
    assert set(reasons) == set(peers.PEERS)
    for reason in reasons.values():
        assert reason is None or (reason and "\n" not in reason)


def test_missing_peer_is_skipped_with_a_reason_and_refused(monkeypatch):
    missing = dataclasses.replace(peers._PEER_SPECS["pysph"], module="sphfluid_no_such_peer")
    monkeypatch.setitem(peers._PEER_SPECS, "pysph", missing)
    reason = peers.available()["pysph"]
    assert reason.startswith("not installed") and "pysph==1.0b2" in reason
    with pytest.raises(peers.PeerUnavailableError, match="pysph: not installed"):
        peers.run_peer("pysph", spacing=0.05, end_time=0.3)


@pytest.mark.parametrize(("probe", "expected"), [
    ("import sphfluid_no_such_peer", "exit code 1: ModuleNotFoundError"),
    ("import os; os.abort()", "killed by SIGABRT"),
])
def test_failing_import_is_reported(monkeypatch, probe, expected):
    broken = dataclasses.replace(peers._PEER_SPECS["splishsplash"], module="json", probe=probe)
    monkeypatch.setitem(peers._PEER_SPECS, "splishsplash", broken)
    reason = peers.available()["splishsplash"]
    assert reason.startswith(f"`{probe}` failed") and expected in reason
    with pytest.raises(peers.PeerUnavailableError, match=expected):
        peers.run_peer("splishsplash", spacing=0.05, end_time=0.3)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="unknown peer"):
        peers.run_peer("dualsphysics", spacing=0.05, end_time=0.3)
    with pytest.raises(ValueError, match="no method 'IISPH'"):
        peers.run_peer("pysph", spacing=0.05, end_time=0.3, method="IISPH")
    with pytest.raises(ValueError, match="must be positive"):
        peers.run_peer("pysph", spacing=0.0, end_time=0.3)


def test_finished_run_is_parsed(monkeypatch):
    ending = 'emit("done", t=0.4, steps=405, wall=0.0405)\n'
    r = peers.run_peer(fake_peer(monkeypatch, ending), spacing=0.05, end_time=0.4)
    assert (r.method, r.version, r.particles, r.steps) == ("FAKE", "0.1", 100, 405)
    assert r.wall_s == pytest.approx(0.0405)
    assert r.particle_steps_per_s == pytest.approx(100 * 405 / 0.0405)
    assert r.crashed == "" and r.note == "a fake peer."
    assert r.front_t[0] == 0.0 and r.front_z[0] == peers.A and len(r.front_t) == 41
    assert math.isfinite(r.front_error) and r.front_error > 0


def test_crash_keeps_what_was_reached(monkeypatch):
    r = peers.run_peer(fake_peer(monkeypatch, "os.abort()\n"), spacing=0.05, end_time=1.0)
    assert r.crashed == "killed by SIGABRT at t = 0.400 s"
    assert (r.particles, r.steps, r.wall_s) == (100, 400, pytest.approx(0.04))
    assert math.isfinite(r.front_error)  # over the table points up to t = 0.4 s


def test_python_error_is_reported_with_its_message(monkeypatch):
    ending = 'raise RuntimeError("non-finite particle positions")\n'
    r = peers.run_peer(fake_peer(monkeypatch, ending), spacing=0.05, end_time=1.0)
    assert r.crashed == ("exit code 1: RuntimeError: non-finite particle positions "
                         "at t = 0.400 s")


def test_crash_before_any_sample_gives_no_front_error(monkeypatch):
    spec = peers._Peer(module="json", probe="pass", requirement="fake", methods=("FAKE",),
                       script="import os; os.abort()", note=lambda method, dx: "a fake peer.")
    monkeypatch.setitem(peers._PEER_SPECS, "fake", spec)
    r = peers.run_peer("fake", spacing=0.05, end_time=1.0)
    assert r.crashed == "killed by SIGABRT before its first sample"
    assert (r.particles, r.steps, r.wall_s) == (0, 0, 0.0)
    assert math.isnan(r.front_error) and math.isnan(r.particle_steps_per_s)
    assert "Front error n/a" in r.note


def test_hang_times_out(monkeypatch):
    name = fake_peer(monkeypatch, "time.sleep(60)\n")
    r = peers.run_peer(name, spacing=0.05, end_time=1.0, timeout=3.0)
    assert r.crashed == "timed out after 3 s at t = 0.400 s" and r.steps == 400


def test_libgl_fix_env_preloads_the_system_gl(monkeypatch):
    monkeypatch.setattr(peers, "find_library", lambda name: f"lib{name}.so.0")
    base = {"LD_PRELOAD": "libmine.so", "OTHER": "1"}
    env = peers.libgl_fix_env(base)
    assert env["LD_PRELOAD"] == "libGLdispatch.so.0:libGLX.so.0:libOpenGL.so.0:libmine.so"
    assert env["OTHER"] == "1" and base["LD_PRELOAD"] == "libmine.so"


def test_libgl_fix_env_without_system_gl_changes_nothing(monkeypatch):
    monkeypatch.setattr(peers, "find_library", lambda name: None)
    assert peers.libgl_fix_env({"PATH": "/bin"}) == {"PATH": "/bin"}


@pytest.mark.bench
@pytest.mark.parametrize("name", peers.PEERS)
def test_installed_peer_runs_the_dam_break(name):
    reason = peers.available()[name]
    if reason is not None:
        pytest.skip(f"{name}: {reason}")
    r = peers.run_peer(name, spacing=0.05, end_time=0.3, threads=2)
    print(f"\n{r.name} {r.version} {r.method}: {r.particles} particles, {r.steps} steps in "
          f"{r.wall_s:.2f} s, {r.particle_steps_per_s / 1e6:.2f} M particle-steps/s, "
          f"front error {r.front_error:.3f}")
    assert r.crashed == ""
    assert r.particles == 20 * 40  # our lattice at dx = 0.05
    assert r.steps > 0 and r.wall_s > 0
    assert math.isfinite(r.front_error)
