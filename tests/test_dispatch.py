"""Which core an import loads: the fastest the CPU runs in a build with a core
per SIMD level (the wheels), SPHFLUID_SIMD to force one, clear errors for a
level the CPU or the build lacks, and the same physics on every level."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sphfluid import _core, _cpu, _dispatch
from sphfluid._dispatch import choose

ALL = {"baseline", "avx2", "avx512"}
DISPATCH = bool(_dispatch.built_levels())
needs_dispatch = pytest.mark.skipif(not DISPATCH, reason="a build with one core (a source build)")


@pytest.mark.parametrize("features, level", [
    ({"avx2": True, "avx512": True}, "avx512"),
    ({"avx2": True, "avx512": False}, "avx2"),  # e.g. a desktop CPU without AVX-512
    ({"avx2": False, "avx512": False}, "baseline"),  # an older or emulated CPU
    ({}, "baseline"),  # not x86-64: nothing detected
])
def test_the_fastest_level_the_cpu_runs_is_chosen(features, level):
    assert choose(features, None, ALL) == level
    assert choose(features, "", ALL) == level  # (an empty SPHFLUID_SIMD is no choice)


def test_only_levels_the_build_has_are_chosen():
    assert choose({"avx2": True, "avx512": True}, None, {"baseline"}) == "baseline"  # (aarch64)
    assert choose({"avx2": True, "avx512": True}, None, {"baseline", "avx2"}) == "avx2"


def test_a_forced_level_is_taken_when_it_can_run():
    cpu = {"avx2": True, "avx512": True}
    assert [choose(cpu, w, ALL) for w in ("baseline", "AVX2", " avx512 ")] == \
        ["baseline", "avx2", "avx512"]


@pytest.mark.parametrize("wanted, features, built, message", [
    ("avx512", {"avx2": True, "avx512": False}, ALL,
     "this CPU cannot run the avx512 core (it runs: avx2, baseline)"),
    ("avx2", {}, ALL, "this CPU cannot run the avx2 core (it runs: baseline)"),
    ("avx2", {"avx2": True}, {"baseline"}, "this build of sphfluid has no avx2 core"),
    ("sse9", {}, ALL, "expected baseline, avx2 or avx512"),
])
def test_a_forced_level_that_cannot_run_is_an_import_error_never_a_crash(
        wanted, features, built, message):
    with pytest.raises(ImportError, match=message.replace("(", r"\(").replace(")", r"\)")):
        choose(features, wanted, built)


def _cpuinfo_flags() -> set[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        pytest.skip("no /proc/cpuinfo")
    for line in text.splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    pytest.skip("no flags in /proc/cpuinfo")


def test_the_core_reads_the_cpu_as_the_kernel_does():
    flags = _cpuinfo_flags()
    v3 = {"avx2", "fma", "bmi1", "bmi2", "f16c", "abm", "movbe"} <= flags  # (abm: lzcnt)
    v4 = v3 and {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"} <= flags
    assert _cpu.features() == {"avx2": v3, "avx512": v4}
    assert _core.build_info["simd"] in ("native", "baseline", "avx2", "avx512")


def _python(code: str, simd: str | None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "SPHFLUID_SIMD"}
    if simd is not None:
        env["SPHFLUID_SIMD"] = simd
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.skipif(DISPATCH, reason="a build with a core per level")
def test_a_single_core_build_refuses_to_be_told_another_level():
    p = _python("import sphfluid", "avx2" if _core.build_info["simd"] != "avx2" else "avx512")
    assert p.returncode != 0
    assert "this build of sphfluid has one core, compiled for" in p.stderr
    assert _python("import sphfluid", _core.build_info["simd"]).returncode == 0


@needs_dispatch
def test_the_chosen_core_is_the_fastest_this_cpu_runs():
    cpu = _cpu.features()
    want = "avx512" if cpu["avx512"] else "avx2" if cpu["avx2"] else "baseline"
    p = _python("import sphfluid._core as c, sphfluid as s; "
                "print(c.build_info['simd'], s._core is c, c.__name__)", None)
    assert p.returncode == 0, p.stderr
    level, same, name = p.stdout.split()
    assert (level, same, name) == (want, "True", f"sphfluid._core_{want}")


@needs_dispatch
def test_a_cpu_without_avx512_gets_the_avx2_core():
    # the detection forced: a stand-in for sphfluid._cpu, in place before the import
    code = ("import sys, types; sys.modules['sphfluid._cpu'] = types.SimpleNamespace("
            "features=lambda: {'avx2': True, 'avx512': False}); "
            "import sphfluid, sphfluid._core as c, sphfluid._core.kernels as k; "
            "print(c.build_info['simd'], sphfluid._core is c, k is c.kernels)")
    p = _python(code, None)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["avx2", "True", "True"]


RUN = """
import json, sphfluid
from sphfluid import Simulation, load_scene
d = json.loads({scene!r})
sim = Simulation(load_scene(d), threads=2)
sim.step({steps})
print(json.dumps({{"simd": sphfluid._core.build_info["simd"],
                  "x": sim.positions.tolist(), "v": sim.velocities.tolist()}}))
"""


@needs_dispatch
@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_every_level_gives_the_same_physics_at_round_off(method):
    from conftest import BASE_SCENE

    d = json.loads(json.dumps(BASE_SCENE))
    d["solver"] = {"method": method, "time_step": 2e-4}
    d["fluid"].update(viscosity=1.0, surface_tension=0.5)
    runs = {}
    for level in sorted(_dispatch.built_levels()):
        if level != "baseline" and not _cpu.features()[level]:
            continue
        p = _python(RUN.format(scene=json.dumps(d), steps=50), level)
        assert p.returncode == 0, p.stderr
        out = json.loads(p.stdout)
        assert out["simd"] == level
        runs[level] = (np.array(out["x"]), np.array(out["v"]))
    assert len(runs) >= 2
    x0, v0 = runs["baseline"]
    for level, (x, v) in runs.items():  # (measured: 1e-16 m and 2e-14 m/s apart after 50 steps)
        assert np.abs(x - x0).max() <= 1e-12, level
        assert np.abs(v - v0).max() <= 1e-12 * max(1.0, np.abs(v0).max()), level


def test_a_scene_path_under_scenes_falls_back_to_the_packaged_copy(tmp_path, monkeypatch, capsys):
    from sphfluid import cli

    package = tmp_path / "site" / "sphfluid"
    (package / "scenes" / "water").mkdir(parents=True)
    (package / "scenes" / "water" / "a.json").write_text("{}")
    monkeypatch.setattr(cli, "__file__", str(package / "cli.py"))
    monkeypatch.chdir(tmp_path)
    assert cli._bundled("scenes/water/a.json") == str(package / "scenes" / "water" / "a.json")
    assert "the copy installed with sphfluid" in capsys.readouterr().err
    for other in ("scenes/water/b.json", "elsewhere/a.json", str(tmp_path / "scenes/a.json")):
        assert cli._bundled(other) == other  # (not packaged, or not under scenes/)
    (tmp_path / "scenes" / "water").mkdir(parents=True)
    (tmp_path / "scenes" / "water" / "a.json").write_text("{}")
    assert cli._bundled("scenes/water/a.json") == "scenes/water/a.json"  # the local one first


@needs_dispatch
def test_the_wheel_runs_the_readme_scene_outside_a_checkout(tmp_path):
    p = subprocess.run([sys.executable, "-m", "sphfluid", "run", "scenes/water/dam_break.json",
                        "--duration", "0.002", "--quiet"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "the copy installed with sphfluid" in p.stderr
