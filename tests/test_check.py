"""The scene check before a run: `sphfluid check`, `sphfluid schema`, "$schema"."""
from __future__ import annotations

import json
from importlib import resources

import pytest
import sphfluid
from sphfluid.cli import main


def write(tmp_path, scene: dict, name: str = "scene.json"):
    path = tmp_path / name
    path.write_text(json.dumps(scene))
    return path


def test_schema_prints_the_shipped_schema(capsys):
    assert main(["schema"]) == 0
    printed = json.loads(capsys.readouterr().out)
    shipped = json.loads(resources.files("sphfluid").joinpath("scene.schema.json").read_text())
    assert printed == shipped
    assert printed["$schema"].startswith("https://json-schema.org/")


def test_a_scene_with_schema_key_loads(tmp_path, scene_dict):
    scene_dict = {"$schema": "./scene.schema.json", **scene_dict}
    scene = sphfluid.load_scene(write(tmp_path, scene_dict))
    assert scene.regions  # loaded as without the key
    bad = {**scene_dict, "$schema": 3}
    with pytest.raises(sphfluid.SceneError, match=r"\$schema: expected a string"):
        sphfluid.load_scene(bad)
    typo = {**scene_dict, "schema": "x"}
    with pytest.raises(sphfluid.SceneError, match=r'schema: unknown key \(did you mean "\$schema"'):
        sphfluid.load_scene(typo)


# ----------------------------------------------------------------- sphfluid check

from conftest import ROOT, SCENE_IDS, SCENES  # noqa: E402
from sphfluid.check import check_scene, step_limit  # noqa: E402


def check(tmp_path, scene: dict, capsys) -> tuple[int, str]:
    code = main(["check", str(write(tmp_path, scene))])
    captured = capsys.readouterr()
    return code, captured.out + captured.err


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_every_bundled_scene_passes(path, capsys):
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "error" not in out.replace("0 error(s)", "")
    assert "warning:" not in out  # none of them has a real one
    assert "particles    " in out and "steps        " in out


def test_a_valid_scene_passes_with_its_numbers(tmp_path, scene_dict, capsys):
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0, out
    assert "particles    100 (~0.0 MiB" in out  # 10 x 10 at 0.05 m
    assert "steps        50 to t = 0.05 s" in out
    assert "run time     about " in out and "50 steps at " in out  # the first ones timed
    assert "0 error(s), 0 warning(s)" in out


def test_a_run_that_blows_up_in_its_first_steps_is_an_error(tmp_path, scene_dict, capsys,
                                                            monkeypatch):
    calls, real = [], sphfluid.Simulation.step

    def step(self, n=1):
        calls.append(n)
        if len(calls) == 4:
            raise sphfluid.InstabilityError("step 4: [check: energy]")
        real(self, n)

    monkeypatch.setattr(sphfluid.Simulation, "step", step)
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 2
    assert "error: solver: the run blows up in its first 4 steps: step 4: [check: energy]" in out
    assert "run time" not in out and "1 error(s)" in out


def test_run_time_scales_with_the_steps(scene_dict):
    """Twice the duration at a fixed step: twice the steps in the estimate."""
    from sphfluid.check import run_time

    lines = []
    for duration in (0.02, 0.04):
        scene_dict["duration"] = duration
        line, error = run_time(sphfluid.load_scene(scene_dict), threads=1)
        assert error is None
        lines.append(line)
    assert " 20 steps at " in lines[0] and " 40 steps at " in lines[1]
    assert "on 1 thread(s)" in lines[0]
    del scene_dict["duration"]
    assert run_time(sphfluid.load_scene(scene_dict)) == (None, None)


@pytest.mark.parametrize("end, warned", [(0.96, True), (1.0, False), (0.8, False)])
def test_a_narrow_gap_between_walls_is_a_warning(scene_dict, end, warned):
    """The tank's right wall as its own segment, the floor stopping short of it:
    a gap of 0.04 m (0.8 spacings) warns; joined, or 0.2 m (a deliberate
    opening, 4 spacings), does not."""
    from sphfluid.check import wall_gaps

    scene_dict["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [end, 0.0]]},
                           [[1.0, 0.0], [1.0, 1.0]]]
    found = wall_gaps(sphfluid.load_scene(scene_dict), scene_dict)
    if warned:
        assert [(f.level, f.path) for f in found] == [("warning", "walls[0]")]
        assert "ends at (0.96, 0), 0.04 m (0.8 spacings) from walls[1]" in found[0].message
    else:
        assert found == []


def test_a_polyline_not_closed_by_a_hair_is_a_gap_to_itself(scene_dict):
    from sphfluid.check import wall_gaps

    box = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.01]]
    scene_dict["walls"] = [{"polyline": box}]
    found = wall_gaps(sphfluid.load_scene(scene_dict), scene_dict)
    assert len(found) == 1 and "from itself" in found[0].message
    scene_dict["walls"] = [{"polyline": box[:-1], "closed": True}]
    assert wall_gaps(sphfluid.load_scene(scene_dict), scene_dict) == []


def test_a_load_error_is_reported_by_path_with_exit_2(tmp_path, scene_dict, capsys):
    scene_dict["fluid"]["rest_density"] = -1
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 2 and "fluid.rest_density: must be > 0" in out


def test_particles_outside_the_domain_are_an_error(scene_dict):
    import dataclasses

    # the loader refuses a region reaching outside; a domain shrunk after loading
    scene = sphfluid.load_scene(scene_dict)
    scene = dataclasses.replace(scene, domain_max=(0.3, 1.1))
    report = check_scene(scene)
    assert [(f.level, f.path) for f in report.findings] == [("error", "fluid_regions[0]")]
    assert "40 of its 100 particles start outside the domain" in report.findings[0].message


def test_particles_on_a_wall_are_a_warning_naming_it(tmp_path, scene_dict, capsys):
    scene_dict["walls"].append([[0.0, 0.225], [1.0, 0.225]])  # along a row of particles
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0
    assert "warning: walls[1]: 10 fluid particle(s) within half a spacing (0.025 m)" in out
    assert "walls[0]" not in out  # the tank: its rows are half a spacing away


def test_a_polyline_is_named_as_one_wall(tmp_path, scene_dict, capsys):
    scene_dict["walls"] = [[[0.0, 1.0], [0.0, 0.0]],
                           {"polyline": [[0.1, 0.9], [0.1, 0.1], [0.9, 0.1]]}]
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0
    # x = 0.1 and y = 0.1 lie between lattice rows (0.075, 0.125): none within 0.025
    assert "warning" not in out.replace("0 warning(s)", "")
    scene_dict["walls"][1]["polyline"] = [[0.125, 0.9], [0.125, 0.125], [0.9, 0.125]]
    code, out = check(tmp_path, scene_dict, capsys)
    assert "warning: walls[1]: " in out and "walls[0]" not in out
    assert "1 warning(s)" in out  # one finding for the polyline's two segments


def test_overlapping_regions_are_a_warning_naming_both(tmp_path, scene_dict, capsys):
    scene_dict["fluid_regions"].append(
        {"shape": "circle", "center": [0.5, 0.5], "radius": 0.1})
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0
    assert "warning: fluid_regions[1]: overlaps fluid_regions[0]: " in out
    scene_dict["fluid_regions"][1]["center"] = [0.8, 0.5]  # beside it, apart
    code, out = check(tmp_path, scene_dict, capsys)
    assert "overlaps" not in out


def test_a_fixed_step_above_the_limit_is_an_error(tmp_path, capsys):
    # the seed dam break blows up at step 2 with dt = 0.01 s (test_cli)
    d = json.loads((ROOT / "scenes" / "dam_break.json").read_text())
    d["solver"]["time_step"] = 0.01
    code, out = check(tmp_path, d, capsys)
    assert code == 2
    assert "error: solver.time_step: 0.01 s is above the stability limit 0.00253 s" in out
    assert "cfl: 1 h / (sqrt(k) + |v|max)" in out and "at most 0.001 s" in out
    d["solver"]["time_step"] = 0.0015  # above the adaptive step's cfl 0.4, below cfl 1
    code, out = check(tmp_path, d, capsys)
    assert code == 0
    assert "warning: solver.time_step: 0.0015 s is above the adaptive step's 0.00101 s" in out
    d["solver"]["time_step"] = 0.0002  # as bundled
    code, out = check(tmp_path, d, capsys)
    assert code == 0 and "solver.time_step" not in out.split("particles")[0]


def test_the_viscous_limit_is_named_when_it_limits(tmp_path, scene_dict, capsys):
    scene_dict["fluid"].update(gas_constant=20.0, viscosity=1500.0)  # test_guard's blow-up
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 2
    assert "solver.time_step: 0.001 s is above the stability limit 0.000833 s" in out
    assert "(viscous: 0.125 h^2 rho0 / eta" in out


def test_the_start_limit_is_the_cores_first_adaptive_step():
    scene = sphfluid.load_scene(ROOT / "scenes" / "water" / "dam_break.json")
    sim = sphfluid.Simulation(scene, threads=1)
    sim.step(1)
    assert sim.dt_limit == "cfl"
    assert step_limit(scene).dt == pytest.approx(sim.dt, rel=1e-9)


def test_the_loader_enforces_whatever_the_schema_says(tmp_path, scene_dict, capsys, monkeypatch):
    # The schema is the format's one statement: a rule added there alone is
    # enforced by load_scene, `check` and `run`, worded from the keyword.
    import copy

    import jsonschema
    from sphfluid import schema as sch

    stricter = copy.deepcopy(sch.scene_schema())
    stricter["properties"]["name"]["maxLength"] = 3
    monkeypatch.setattr(sch, "_validator", lambda name=sch.SCHEMA_FILE: jsonschema.Draft202012Validator(stricter))
    code, out = check(tmp_path, {**scene_dict, "name": "a long name"}, capsys)
    assert code == 2
    assert "name: 'a long name' is too long" in out
    code, _ = check(tmp_path, {**scene_dict, "name": "ok"}, capsys)
    assert code == 0


# ------------------------------------------------------- the check at the start of run/view

def test_run_stops_on_a_check_error_and_prints_warnings(tmp_path, scene_dict, capsys):
    scene_dict["fluid"].update(gas_constant=20.0, viscosity=1500.0)  # the viscous limit
    scene_dict["duration"] = 1.0  # long enough to blow up (test_guard)
    path = write(tmp_path, scene_dict)
    assert main(["run", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "error: solver.time_step: 0.001 s is above the stability limit" in err
    assert "--no-check" in err
    assert main(["run", str(path), "--quiet", "--no-check"]) == 3  # the guard trips

    ok = write(tmp_path, {**scene_dict, "fluid": {"rest_density": 1000.0, "gas_constant": 250.0},
                          "walls": [[[0.0, 0.225], [1.0, 0.225]]]}, "ok.json")
    assert main(["run", str(ok), "--quiet", "--duration", "0.005"]) == 0
    assert "warning: walls[0]: 10 fluid particle(s)" in capsys.readouterr().err


def test_view_stops_on_a_check_error(tmp_path, scene_dict, capsys):
    scene_dict["solver"]["time_step"] = 0.05
    path = write(tmp_path, scene_dict)
    assert main(["view", str(path), "--frames", "1"]) == 2  # before a window opens
    assert "error: solver.time_step: 0.05 s" in capsys.readouterr().err


def test_a_run_of_more_steps_than_sensible_is_refused(tmp_path, scene_dict, capsys):
    scene_dict["solver"]["time_step"] = 1e-12
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 2
    assert f"error: solver.time_step: {scene_dict['duration'] / 1e-12:.3g} steps of 1e-12 s" in out
    scene_dict["solver"]["time_step"] = 5e-324  # a subnormal step: inf steps
    assert check(tmp_path, scene_dict, capsys)[0] == 2
    assert "more than the 1e+09 a run may take" in out
    scene_dict["solver"]["time_step"] = 1e-4
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0 and "steps        " in out


def test_parsed_json_that_is_not_an_object_is_refused():
    for value in ([1, 2], None, 3.5):
        with pytest.raises(sphfluid.SceneError, match="expected a JSON object at the top level"):
            sphfluid.load_scene(value)


@pytest.mark.parametrize("ratio, warned", [(1.5, True), (1.75, True), (2.0, False), (2.5, False)])
def test_a_dfsph_support_below_two_spacings_is_a_warning(tmp_path, scene_dict, capsys, ratio,
                                                         warned):
    scene_dict["fluid"] = {"rest_density": 1000.0, "viscosity": 0.5}
    scene_dict["solver"] = {"method": "dfsph", "time_step": "auto"}
    scene_dict["resolution"]["smoothing_length"] = ratio * scene_dict["resolution"]["spacing"]
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0
    assert ("warning: resolution.smoothing_length:" in out) == warned
    if warned:
        assert f"is {ratio:g} spacings, below the 2 dfsph needs" in out


def test_the_seed_and_wcsph_take_a_support_of_one_and_a_half_spacings(tmp_path, scene_dict,
                                                                       capsys):
    scene_dict["resolution"]["smoothing_length"] = 0.075
    for method in ("seed", "wcsph"):
        scene_dict["solver"]["method"] = method
        code, out = check(tmp_path, scene_dict, capsys)
        assert code == 0 and "smoothing_length" not in out


@pytest.mark.parametrize("gravity, warned", [([0.0, 0.0], True), ([0.0, -9.81], False)])
def test_an_outlets_level_without_gravity_is_a_warning(tmp_path, scene_dict, capsys, gravity,
                                                       warned):
    scene_dict["gravity"] = gravity
    scene_dict["domain"]["max"] = [1.3, 1.1]
    scene_dict["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.3, 0.0]]}]
    scene_dict["outlets"] = [{"at": [0.5, 0.4], "direction": [1, 0], "width": 0.8,
                              "level": 0.3}]
    code, out = check(tmp_path, scene_dict, capsys)
    assert code == 0
    assert ("warning: outlets[0].level: has no effect without gravity" in out) == warned
