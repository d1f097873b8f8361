"""Every bundled scene loads, runs stably for its whole duration with the seed
method, and no particle path ever crosses a fixed wall."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sphfluid
from conftest import SCENE_IDS, SCENES


def crossings(x0, x1, walls):
    """Indices of particles whose straight path x0 -> x1 crosses a wall segment."""
    d = x1 - x0
    hit = np.zeros(len(x0), bool)
    for a, b in walls:
        e = b - a
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        w = a - x0
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (w[:, 0] * e[1] - w[:, 1] * e[0]) / den
            u = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / den
        hit |= (den != 0) & (s > 0) & (s < 1) & (u > 0) & (u < 1)
    return np.flatnonzero(hit)


def test_crossing_check_detects_a_crossing():
    walls = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    x0 = np.array([[0.5, 0.1], [0.5, 0.1]])
    x1 = np.array([[0.5, -0.1], [0.5, 0.05]])
    assert list(crossings(x0, x1, walls)) == [0]


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_scene_runs_a_few_steps(path):
    sim = sphfluid.Simulation(sphfluid.load_scene(path))
    assert sim.n_particles > 100
    sim.step(20)
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))


@pytest.mark.slow
@pytest.mark.parametrize("adaptive", [False, True], ids=["fixed-dt", "auto-dt"])
@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_scene_is_stable_and_walls_hold_for_its_duration(path, adaptive):
    scene = sphfluid.load_scene(path)
    if not adaptive and scene.time_step is None:
        pytest.skip("the scene's own step is the adaptive one (its auto-dt run)")
    if adaptive:
        d = scene.to_dict()
        d["solver"]["time_step"] = "auto"
        scene = sphfluid.load_scene(d)
    sim = sphfluid.Simulation(scene)
    walls = sim.walls
    if scene.wall_motions:  # the fixed walls here (moving ones: tests/test_moving_walls.py)
        walls = walls[[m is None for m in scene.wall_motions]]
    n0 = sim.n_particles
    flows = bool(scene.inlets or scene.outlets or scene.emitters or scene.sinks)
    height = scene.domain_max[1] - scene.domain_min[1]
    speed_limit = 3 * np.sqrt(2 * 9.81 * height)  # well above any free-fall speed here
    chunk = 1 if len(walls) else 50  # with walls every single path is checked
    worst_rho = 0.0
    while sim.time < scene.duration * (1 - 1e-12):
        ids0, x0 = sim.ids.copy(), sim.positions.copy()
        sim.step(chunk)
        if not flows:  # no particle may leave
            assert sim.n_particles == n0, f"t = {sim.time:.3f}: particles left the domain"
        if len(walls):  # every path of a particle there before and after
            _, before, after = np.intersect1d(ids0, sim.ids, assume_unique=True,
                                              return_indices=True)
            bad = after[crossings(x0[before], sim.positions[after], walls)]
            assert len(bad) == 0, (f"step {sim.step_count}: particles {sim.ids[bad][:5]} "
                                   "crossed a wall")
        if sim.step_count % 200 < chunk:
            st = sim.stats()
            assert st["max_speed"] < speed_limit, f"t = {sim.time:.3f}: {st}"
            worst_rho = max(worst_rho, st["max_density_error"])
    assert sim.removed_particles == 0
    assert worst_rho < 1.0  # density stays within (0, 2 rho0)


@pytest.mark.parametrize("stop", [0.1, 0.5])
def test_water_spray_does_not_blow_up_whatever_the_output_stops(stop):
    """The terrain in water with wcsph's defaults, advanced in stops of `stop`
    seconds (each stop changes the steps taken, so the spray differs): W26b's
    pressure floor without its second condition let a clump of stretched
    spray that gathered again pull itself apart at t = 0.8 s in both
    (docs/method-wcsph.md, W26b)."""
    path = Path(__file__).resolve().parents[1] / "scenes" / "water" / "terrain.json"
    sim = sphfluid.Simulation(sphfluid.load_scene(path), threads=1)
    for t in np.arange(stop, 1.0 + 1e-9, stop):
        sim.advance_to(float(t))  # the guard raises on a blow-up
    assert sim.removed_particles == 0
