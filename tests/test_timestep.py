"""Adaptive time step ("time_step": "auto"): each stability condition limits dt
on a state crafted so that it is the smallest."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sphfluid
from sphfluid import _core

H = 0.1


def lone_particle(v=(0.0, 0.0), gravity=(0.0, 0.0), eta=0.0, k=100.0, cfl=0.4, dt_max=0.0):
    p = _core.SimParams()
    p.h, p.mass, p.rho0, p.k, p.eta = H, 1.0, 100.0, k, eta
    p.gravity, p.cfl, p.dt_max = gravity, cfl, dt_max
    p.domain_min, p.domain_max = (-1e6, -1e6), (1e6, 1e6)
    return _core.Solver(p, np.zeros((1, 2)), np.array([v]), np.zeros((0, 2, 2)))


def test_cfl_limit_uses_sound_speed_plus_flow_speed():
    s = lone_particle(v=(3.0, 4.0), k=100.0, cfl=0.3)
    s.step_adaptive(1)
    assert s.last_dt_limit == "cfl"
    assert s.last_dt == pytest.approx(0.3 * H / (math.sqrt(100.0) + 5.0), rel=1e-14)


def test_force_limit():
    s = lone_particle(gravity=(0.0, -1e6))
    s.step_adaptive(1)
    assert s.last_dt_limit == "force"
    assert s.last_dt == pytest.approx(0.25 * math.sqrt(H / 1e6), rel=1e-14)


def test_viscous_limit():
    s = lone_particle(eta=1e4)
    s.step_adaptive(1)
    assert s.last_dt_limit == "viscous"
    assert s.last_dt == pytest.approx(0.125 * H * H * 100.0 / 1e4, rel=1e-14)


def test_dt_max_caps_the_step():
    s = lone_particle(dt_max=1e-5)
    s.step_adaptive(3)
    assert s.last_dt_limit == "dt_max" and s.last_dt == 1e-5
    assert s.time == pytest.approx(3e-5)


def test_the_smallest_condition_wins_when_several_apply():
    s = lone_particle(v=(1.0, 0.0), gravity=(0.0, -50.0), eta=0.5)
    s.step_adaptive(1)
    cfl = 0.4 * H / (10.0 + 1.0)  # c = sqrt(k) = 10 m/s, |v| = 1 m/s before the step
    force = 0.25 * math.sqrt(H / 50.0)
    visc = 0.125 * H * H * 100.0 / 0.5
    assert s.last_dt == pytest.approx(min(cfl, force, visc), rel=1e-14)


def test_advance_lands_on_the_end_time():
    s = lone_particle(v=(1.0, 0.0))
    n = s.advance_adaptive(0.01234, 10**6)
    assert s.time == pytest.approx(0.01234, abs=1e-15)
    assert n == s.step_count == math.ceil(0.01234 / (0.4 * H / 11.0))


def test_fixed_steps_report_fixed(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    sim.step(2)
    assert sim.dt == 0.001 and sim.dt_limit == "fixed"


def test_auto_scene_runs_and_reports_its_step(scene_dict):
    scene_dict["solver"] = {"method": "seed", "time_step": "auto", "cfl": 0.3}
    sim = sphfluid.Simulation(scene_dict)
    assert sim.adaptive
    sim.run(0.05)
    assert sim.time == pytest.approx(0.05)
    st = sim.stats()
    assert st["dt_limit"] in ("cfl", "force", "viscous") and st["dt"] > 0
    # The bound holds for the step actually taken.
    c = math.sqrt(scene_dict["fluid"]["gas_constant"])
    assert sim.step_count >= 0.05 / (0.3 * 0.1 / c)


@pytest.mark.parametrize("solver,message", [
    ({"time_step": "fast"}, r'solver.time_step: expected a number of seconds or "auto", got "fast"'),
    ({"time_step": "auto", "cfl": 1.5}, r"solver.cfl: must be <= 1, got 1.5"),
    ({"time_step": "auto", "cfl": 0}, r"solver.cfl: must be > 0, got 0"),
    ({"time_step": 0.001, "cfl": 0.3}, r'solver.cfl: only applies with "time_step": "auto"'),
])
def test_bad_time_step_settings(scene_dict, solver, message):
    scene_dict["solver"] = {"method": "seed", **solver}
    with pytest.raises(sphfluid.SceneError, match=message):
        sphfluid.load_scene(scene_dict)
