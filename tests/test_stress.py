"""The stress classifier: stable, caught by the guard, or silent failure."""
from __future__ import annotations

import copy

from conftest import BASE_SCENE
from sphfluid.stress import CAUGHT, SILENT, STABLE, run_one, tank_scene


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
