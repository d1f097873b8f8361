"""The stress classifier: stable, caught by the guard, or silent failure."""
from __future__ import annotations

import copy
import json

from conftest import BASE_SCENE
from sphfluid.stress import CAUGHT, SILENT, STABLE, bundled_scenes, run_one, tank_scene


def test_a_calm_run_is_stable():
    d = tank_scene("dam_break", 0.1, 0.1)
    d["fluid"]["gas_constant"] = 100.0
    o = run_one(d, max_wall=60)
    assert o.status == STABLE and o.lost == 0 and o.sim_time > 0.099


def test_a_blow_up_is_caught_with_its_check():
    d = tank_scene("splash", 0.1, 0.2)
    d["fluid"]["gas_constant"] = 1e6
    d["solver"]["time_step"] = 0.01
    o = run_one(d, max_wall=60)
    assert o.status == CAUGHT and o.detail in ("speed", "energy", "density", "finite")


def test_particles_that_leave_without_a_trip_are_a_silent_failure():
    # A drop thrown upwards out of an open-topped box at 8 m/s: far below the
    # speed of sound, so the guard rightly stays quiet, but particles leave the
    # domain. The classifier must call that out.
    d = copy.deepcopy(BASE_SCENE)
    d["fluid"].update(gas_constant=100.0, viscosity=5.0)
    d["fluid_regions"] = [{"shape": "circle", "center": [0.5, 0.5], "radius": 0.1,
                           "velocity": [0.0, 8.0]}]
    d["duration"] = 0.5
    o = run_one(d, max_wall=60)
    assert o.status == SILENT and o.lost > 0


def test_bundled_scenes_run_as_shipped_and_with_each_method(tmp_path):
    d = copy.deepcopy(BASE_SCENE)
    d["solver"] = {"method": "seed", "time_step": 0.001}
    (tmp_path / "a.json").write_text(json.dumps(d))
    runs = bundled_scenes(tmp_path)
    assert list(runs) == [("a.json", "seed, dt as shipped (0.001)"), ("a.json", "seed, auto"),
                          ("a.json", "wcsph, auto"), ("a.json", "dfsph, auto")]
    assert runs[("a.json", "seed, dt as shipped (0.001)")]["solver"]["time_step"] == 0.001
    for how, method in (("seed, auto", "seed"), ("wcsph, auto", "wcsph"), ("dfsph, auto", "dfsph")):
        assert runs[("a.json", how)]["solver"] == {"method": method, "time_step": "auto"}
        assert run_one(runs[("a.json", how)] | {"duration": 0.02}, max_wall=60).status == STABLE


def test_with_precision_sets_the_seeds_pair_forces_only():
    from sphfluid.stress import with_precision

    seed = {"solver": {"method": "seed"}}
    assert with_precision(copy.deepcopy(seed), "float")["solver"]["pair_precision"] == "float"
    assert "pair_precision" not in with_precision(copy.deepcopy(seed), "double")["solver"]
    wcsph = {"solver": {"method": "wcsph"}}
    assert "pair_precision" not in with_precision(wcsph, "float")["solver"]
    assert with_precision({"solver": {}}, "float")["solver"]["pair_precision"] == "float"
