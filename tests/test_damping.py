"""Damping zones (the scene's "damping_zones"; sphfluid/flows.py DampingZone,
cpp/boundary/damping.hpp): the velocity each step keeps along the ramp, for
every method; waves running into a zone die there; the scene format and its
errors; the viewer draws them."""
from __future__ import annotations

import os

import numpy as np
import pytest

import sphfluid
from sphfluid.flows import DampingZone

DT = 1e-3
STRENGTH = 20.0


def lone_particles(method: str, xs, zones) -> dict:
    """Single particles at (x, 0.11 + 0.2 k) for x in xs (on the lattice, out of
    each other's reach), moving at 0.1 m/s along x, without gravity or walls."""
    return {
        "format": "sphfluid-scene/1",
        "gravity": [0.0, 0.0],
        "domain": {"min": [0.0, 0.0], "max": [2.0, 1.0]},
        "fluid": {"rest_density": 1000.0,
                  **({"gas_constant": 10.0} if method == "seed" else {})},
        "resolution": {"spacing": 0.02},
        "fluid_regions": [{"shape": "rectangle", "min": [x - 0.005, 0.105 + 0.2 * k],
                           "max": [x + 0.005, 0.115 + 0.2 * k], "velocity": [0.1, 0.0]}
                          for k, x in enumerate(xs)],
        "walls": [],
        "solver": {"method": method, "time_step": DT},
        "damping_zones": zones,
    }


@pytest.mark.parametrize("method", ["seed", "wcsph", "dfsph"])
def test_each_step_keeps_one_minus_dt_s2_strength_of_the_velocity(method):
    """Before the line nothing changes; half way along the ramp (s = 1/2) a step
    keeps 1 - dt strength / 4, at and beyond 'to' 1 - dt strength; the factor
    compounds over steps, and matches DampingZone.factor at the step's end
    positions (the zones act after the drift)."""
    zone = {"from": [1.01, 0.0], "to": [1.41, 0.0], "strength": STRENGTH}
    xs = [0.51, 1.21, 1.41, 1.81]  # before, half way, at 'to', beyond
    sim = sphfluid.Simulation(lone_particles(method, xs, [zone]), threads=1)
    order = np.argsort(sim.positions[:, 1])
    steps = 5
    speeds = [sim.velocities[order, 0].copy()]
    for _ in range(steps):
        sim.step(1)
        speeds.append(sim.velocities[order, 0].copy())
        x = sim.positions[order]  # (the zones act after the drift)
        keep = DampingZone((1.01, 0.0), (1.41, 0.0), STRENGTH).factor(x, DT)
        np.testing.assert_allclose(speeds[-1] / speeds[-2], keep, rtol=1e-12)
    expected = 0.1 * np.array([1.0, 1 - DT * STRENGTH / 4, 1 - DT * STRENGTH,
                               1 - DT * STRENGTH]) ** steps
    # (the half-way particle moves along the ramp: its factor changes a little)
    np.testing.assert_allclose(speeds[-1], expected, rtol=2e-4)
    assert speeds[-1][0] == 0.1 and speeds[-1][3] < speeds[-1][1] < 0.1


def test_the_strongest_zone_acts_where_zones_overlap_and_nothing_turns_round():
    """Two zones over one particle: it keeps the smaller factor; a strength
    beyond 1 / dt stops particles without reversing them (the factor's floor 0)."""
    zones = [{"from": [1.0, 0.0], "to": [1.1, 0.0], "strength": 5.0},
             {"from": [1.0, 0.0], "to": [1.2, 0.0], "strength": 3.0 / DT}]
    for order in (zones, zones[::-1]):
        sim = sphfluid.Simulation(lone_particles("wcsph", [1.61], order), threads=1)
        sim.step(1)
        assert sim.velocities[0, 0] == 0.0
    weak = [{"from": [1.0, 0.0], "to": [1.1, 0.0], "strength": 5.0},
            {"from": [1.0, 0.0], "to": [1.2, 0.0], "strength": 2.0}]
    for order in (weak, weak[::-1]):  # the smaller factor, whichever comes first
        sim = sphfluid.Simulation(lone_particles("wcsph", [1.61], order), threads=1)
        sim.step(1)
        assert sim.velocities[0, 0] == pytest.approx(0.1 * (1 - DT * 5.0), rel=1e-12)


def test_a_zone_along_any_direction_ramps_with_the_distance_past_its_line():
    """A zone sloping down-left: the factor depends on the projection on from -> to
    only, 1 on the far side of the line."""
    z = DampingZone((1.0, 1.0), (0.6, 0.7), 10.0)
    axis = np.subtract(z.end, z.start)
    across = np.array([-axis[1], axis[0]])
    pts = np.array([z.start, np.add(z.start, 0.5 * axis), np.add(z.start, 0.5 * axis + across),
                    np.add(z.start, 2 * axis), np.subtract(z.start, 0.1 * axis)])
    np.testing.assert_allclose(z.factor(pts, 0.01), [1.0, 0.975, 0.975, 0.9, 1.0])


def test_waves_running_into_a_zone_die_there():
    """A tank 2 m long, water 0.2 m deep with a surge to the right (0.2 m/s),
    wcsph: without a zone it sloshes on; with one over its right half (the
    default strength) the kinetic energy over 2-4 s is under a fifth of that
    without (measured: 0.13 of it)."""
    d = {
        "format": "sphfluid-scene/1",
        "domain": {"min": [0.0, 0.0], "max": [2.0, 0.6]},
        "fluid": {"rest_density": 1000.0, "viscosity": 1e-3},
        "resolution": {"spacing": 0.02},
        "fluid_regions": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [2.0, 0.2],
                           "velocity": [0.2, 0.0]}],
        "walls": [[[0.0, 0.0], [2.0, 0.0]], [[0.0, 0.0], [0.0, 0.6]],
                  [[2.0, 0.0], [2.0, 0.6]]],
        "solver": {"method": "wcsph", "time_step": "auto"},
    }
    energies = []
    for zones in ([], [{"from": [1.0, 0.0], "to": [1.8, 0.0]}]):
        d["damping_zones"] = zones
        sim = sphfluid.Simulation(d, threads=2)
        sim.advance_to(2.0)
        e = 0.0
        for t in np.arange(2.25, 4.01, 0.25):
            sim.advance_to(float(t))
            e += 0.5 * (sim.velocities ** 2).sum()
        energies.append(e)
    free, damped = energies
    assert damped < 0.2 * free, energies


def test_the_scene_round_trips_and_reports_bad_zones_by_path():
    d = lone_particles("wcsph", [0.51], [{"name": "beach", "from": [1.0, 0.0],
                                         "to": [1.5, 0.0], "strength": 4.0},
                                        {"from": [0.0, 0.8], "to": [0.0, 1.0]}])
    scene = sphfluid.load_scene(d)
    assert scene.damping_zones == (DampingZone((1.0, 0.0), (1.5, 0.0), 4.0, "beach"),
                                   DampingZone((0.0, 0.8), (0.0, 1.0)))
    assert sphfluid.load_scene(scene.to_dict()) == scene
    assert "strength" not in scene.to_dict()["damping_zones"][1]  # the default, 10/s

    def error(zone) -> str:
        with pytest.raises(sphfluid.SceneError) as e:
            sphfluid.load_scene(lone_particles("wcsph", [0.51], [zone]))
        return str(e.value)

    assert "damping_zones[0].to: must differ from 'from'" in error(
        {"from": [1.0, 0.0], "to": [1.0, 0.0]})
    assert "damping_zones[0].strength" in error(
        {"from": [1.0, 0.0], "to": [1.2, 0.0], "strength": 0})
    assert "damping_zones[0].strength" in error(
        {"from": [1.0, 0.0], "to": [1.2, 0.0], "strength": -1})
    assert "damping_zones[0]" in error({"from": [1.0, 0.0]})  # no 'to'
    assert "damping_zones[0].flom" in error({"flom": [1.0, 0.0], "to": [1.2, 0.0]})
    assert "damping_zones[0].from: the zone (beyond [3.0, 0.0]" in error(
        {"from": [3.0, 0.0], "to": [3.5, 0.0]})  # past the domain's right edge
    assert "covers none of the domain" in error(
        {"from": [2.0, 0.0], "to": [2.5, 0.0]})  # on the right edge: no area
    with pytest.raises(ValueError, match="must differ"):  # the core refuses it too
        sphfluid.Simulation(lone_particles("wcsph", [0.51], []))._solver.set_damping(
            [{"from": [1.0, 0.0], "to": [1.0, 0.0], "strength": 1.0}])


def test_the_viewer_draws_where_a_zone_begins_and_reaches_full_strength():
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    pygame = pytest.importorskip("pygame")
    from sphfluid.viewer import DAMPING, Renderer

    pygame.display.init()
    pygame.font.init()
    try:
        def drawn(zones):
            sim = sphfluid.Simulation(lone_particles("wcsph", [0.51], zones), threads=1)
            surface = pygame.Surface((500, 300))
            r = Renderer(sim, (500, 300), "speed")
            r.draw(surface)
            return np.all(pygame.surfarray.array3d(surface) == DAMPING, axis=2), r

        img, r = drawn([{"from": [1.0, 0.0], "to": [1.5, 0.0]}])
        for x in (1.0, 1.5):  # the two lines across the domain
            sx, _ = r.camera.to_screen(np.array([x, 0.5]))
            column = img[round(float(sx)) - 1:round(float(sx)) + 2]
            assert column.any(axis=0).sum() > 100
        assert not drawn([])[0].any()
    finally:
        pygame.quit()
