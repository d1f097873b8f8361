"""The peer harness (benchmarks/peers/peers.py): availability, clean refusals, crash
and timeout reports, what the drivers are given, and (marker `bench`) real runs of
the installed peers at a coarse spacing.

Everything but the `bench` test runs without PySPH or SPlisHSPlasH installed: a fake
peer (a short driver speaking the harness's protocol) stands in for them.
"""
from __future__ import annotations

import dataclasses
import json
import math

import pytest
from conftest import BENCHMARKS, benchmark_module
from sphfluid.dam_break import GEOMETRY

peers = benchmark_module("peers/peers.py")

FAKE_START = r'''
import json, os, sys, time
with open(sys.argv[1]) as f:
    cfg = json.load(f)
def emit(kind, **fields):
    print(cfg["tag"], kind, json.dumps(fields), flush=True)
print("a line of the peer's own output")
emit("start", method="FAKE", version="0.1", particles=100)
for k in range(1, 41):  # 10 steps and 1 ms per sample, front 1 cm further each time
    emit("sample", t=k * cfg["sample_every"], z=1.0 + 0.01 * k, steps=10 * k, wall=1e-3 * k)
'''

FAKE_CONFIGURATION = peers.Configuration("FAKE", lambda spacing: {"answer": 42},
                                         lambda spacing: "a fake peer.")


def fake_peer(monkeypatch, tmp_path, script: str, name: str = "fake") -> str:
    """Register a peer whose driver is `script`; returns its name."""
    driver = tmp_path / f"{name}_driver.py"
    driver.write_text(script)
    spec = peers._Peer(module="json", probe="pass", requirement="fake", driver=driver,
                       configurations={"fake": FAKE_CONFIGURATION})
    monkeypatch.setitem(peers._PEER_SPECS, name, spec)
    return name


def test_the_drivers_are_files_beside_the_harness():
    for name in peers.PEERS:
        driver = peers._PEER_SPECS[name].driver
        assert driver.parent == BENCHMARKS / "peers" and driver.is_file()
        assert "import child" in driver.read_text() or "from child import" in driver.read_text()


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
    with pytest.raises(ValueError, match="no configuration 'iisph'"):
        peers.run_peer("pysph", spacing=0.05, end_time=0.3, configuration="iisph")
    with pytest.raises(ValueError, match="must be positive"):
        peers.run_peer("pysph", spacing=0.0, end_time=0.3)


def test_splishsplash_has_our_settings_and_the_stiff_one():
    assert peers.configurations("splishsplash") == ("wcsph", "wcsph-stiff", "dfsph")
    assert peers.configurations("pysph") == ("wcsph",)
    specs = peers._PEER_SPECS["splishsplash"].configurations
    dx = 0.0141421356
    ours = specs["wcsph"].settings(dx)
    c0 = peers.our_c0()
    assert ours["time_step"] == {"fixed": pytest.approx(0.3 * dx / c0)}
    assert ours["parameters"]["stiffness"] == pytest.approx(GEOMETRY.rho0 * c0**2 / 7)
    stiff = specs["wcsph-stiff"].settings(dx)
    # the configuration measured in SPlisHSPlasH 2.19: stiffness 280,286, exponent 7,
    # its CFL rule with dt at most 2.5e-4 s
    assert stiff["parameters"] == {"stiffness": pytest.approx(280_286, abs=0.5),
                                   "exponent": 7.0}
    assert stiff["time_step"]["cfl_max"] == 2.5e-4
    assert "280,286" in specs["wcsph-stiff"].note(dx)
    assert specs["dfsph"].method == "DFSPH"


def test_the_driver_gets_the_geometry_and_its_settings_in_a_file(monkeypatch, tmp_path):
    """The driver reads one JSON file: the dam break's numbers from sphfluid's one
    definition, the run, and the configuration's settings."""
    script = ("import json, sys, shutil\n"
              f"shutil.copy(sys.argv[1], {str(tmp_path / 'seen.json')!r})\n")
    name = fake_peer(monkeypatch, tmp_path, script)
    peers.run_peer(name, spacing=0.05, end_time=0.3)
    seen = json.loads((tmp_path / "seen.json").read_text())
    assert (seen["tank"], seen["tank_height"], seen["g"], seen["rho0"]) == (
        GEOMETRY.tank, GEOMETRY.tank_height, GEOMETRY.g, GEOMETRY.rho0)
    assert (seen["columns"], seen["rows"]) == (20, 40)  # a = 1 m, 2a = 2 m at dx = 0.05
    assert (seen["spacing"], seen["end_time"], seen["method"], seen["answer"]) == (
        0.05, 0.3, "FAKE", 42)


def test_finished_run_is_parsed(monkeypatch, tmp_path):
    ending = 'emit("done", t=0.4, steps=405, wall=0.0405)\n'
    r = peers.run_peer(fake_peer(monkeypatch, tmp_path, FAKE_START + ending), spacing=0.05,
                       end_time=0.4)
    assert (r.configuration, r.method, r.version, r.particles, r.steps) == (
        "fake", "FAKE", "0.1", 100, 405)
    assert r.wall_s == pytest.approx(0.0405)
    assert r.particle_steps_per_s == pytest.approx(100 * 405 / 0.0405)
    assert r.crashed == "" and r.note == "a fake peer."
    assert r.front_t[0] == 0.0 and r.front_z[0] == GEOMETRY.a and len(r.front_t) == 41
    assert math.isfinite(r.front_error) and r.front_error > 0


def test_crash_keeps_what_was_reached(monkeypatch, tmp_path):
    r = peers.run_peer(fake_peer(monkeypatch, tmp_path, FAKE_START + "os.abort()\n"),
                       spacing=0.05, end_time=1.0)
    assert r.crashed == "killed by SIGABRT at t = 0.400 s"
    assert (r.particles, r.steps, r.wall_s) == (100, 400, pytest.approx(0.04))
    assert math.isfinite(r.front_error)  # over the table points up to t = 0.4 s


def test_python_error_is_reported_with_its_message(monkeypatch, tmp_path):
    ending = 'raise RuntimeError("non-finite particle positions")\n'
    r = peers.run_peer(fake_peer(monkeypatch, tmp_path, FAKE_START + ending), spacing=0.05,
                       end_time=1.0)
    assert r.crashed == ("exit code 1: RuntimeError: non-finite particle positions "
                         "at t = 0.400 s")


def test_crash_before_any_sample_gives_no_front_error(monkeypatch, tmp_path):
    name = fake_peer(monkeypatch, tmp_path, "import os; os.abort()")
    r = peers.run_peer(name, spacing=0.05, end_time=1.0)
    assert r.crashed == "killed by SIGABRT before its first sample"
    assert (r.particles, r.steps, r.wall_s) == (0, 0, 0.0)
    assert math.isnan(r.front_error) and math.isnan(r.particle_steps_per_s)
    assert "Front error n/a" in r.note


def test_hang_times_out(monkeypatch, tmp_path):
    name = fake_peer(monkeypatch, tmp_path, FAKE_START + "time.sleep(60)\n")
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


def test_command_line_prints_a_row_per_configuration(monkeypatch, tmp_path, capsys):
    ending = 'emit("done", t=0.4, steps=405, wall=0.0405)\n'
    name = fake_peer(monkeypatch, tmp_path, FAKE_START + ending)
    monkeypatch.setattr(peers, "PEERS", (*peers.PEERS, name))
    monkeypatch.setattr(peers, "available", lambda: {name: None})
    assert peers.main(["--spacing", "0.05", "--end-time", "0.4", "--peer", name]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| fake")]
    assert len(rows) == 1 and "| fake 0.1 | fake | FAKE | 100 | 405 |" in rows[0]


@pytest.mark.bench
@pytest.mark.parametrize(("name", "configuration"), [
    (name, c) for name in peers.PEERS for c in peers.configurations(name)])
def test_installed_peer_runs_the_dam_break(name, configuration):
    reason = peers.available()[name]
    if reason is not None:
        pytest.skip(f"{name}: {reason}")
    r = peers.run_peer(name, spacing=0.05, end_time=0.3, threads=2, configuration=configuration)
    print(f"\n{r.name} {r.version} {r.configuration}: {r.particles} particles, {r.steps} "
          f"steps in {r.wall_s:.2f} s, {r.particle_steps_per_s / 1e6:.2f} M particle-steps/s, "
          f"front error {r.front_error:.3f}")
    assert r.crashed == ""
    assert r.particles == 20 * 40  # our lattice at dx = 0.05
    assert r.steps > 0 and r.wall_s > 0
    assert math.isfinite(r.front_error)
