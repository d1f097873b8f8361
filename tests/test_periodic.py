"""Periodic boundaries (domain.periodic): particles wrap around the box, and
neighbours, densities and forces are found across the seam (minimum image)."""
from __future__ import annotations

import numpy as np
import pytest
import sphfluid
from reference import seed_forces, wcsph_forces
from sphfluid import _core

NO_WALLS = np.zeros((0, 2, 2))


def params(method="seed", *, h=0.1, periodic=(True, True), box=((0.0, 0.0), (0.5, 0.4)),
           eta=0.0, alpha=0.0, gravity=(0.0, 0.0), threads=0):
    p = _core.SimParams()
    p.method = getattr(_core.Method, method)
    p.h, p.mass, p.rho0, p.k, p.c0 = h, 0.6, 1000.0, 30.0, 20.0
    p.eta, p.alpha, p.gravity = eta, alpha, gravity
    p.domain_min, p.domain_max = box
    p.periodic = periodic
    p.threads = threads
    return p


def random_state(n, box, seed):
    rng = np.random.default_rng(seed)
    (x0, y0), (x1, y1) = box
    x = rng.uniform((x0, y0), (x1, y1), (n, 2))
    return x, rng.normal(0.0, 1.0, (n, 2))


@pytest.mark.parametrize("periodic", [(True, True), (True, False), (False, True)])
@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_native_equals_brute_force_minimum_image(method, periodic):
    box = ((0.0, 0.0), (0.5, 0.4))
    x, v = random_state(300, box, 5)
    p = params(method, periodic=periodic, eta=0.4, alpha=0.3)
    s = _core.Solver(p, x, v, NO_WALLS)
    period = tuple(hi - lo if on else None for lo, hi, on in zip(*box, periodic))
    if method == "seed":
        rho, pr, a = seed_forces(x, v, h=0.1, m=0.6, rho0=1000.0, k=30.0, eta=0.4,
                                 gravity=(0.0, 0.0), period=period)
    else:
        rho, pr, a = wcsph_forces(x, v, h=0.1, m=0.6, rho0=1000.0, c0=20.0, alpha=0.3,
                                  eta=0.4, gravity=(0.0, 0.0), period=period)
    # The seam matters: without minimum images the densities differ.
    plain = seed_forces(x, v, h=0.1, m=0.6, rho0=1000.0, k=30.0)[0] if method == "seed" else (
        wcsph_forces(x, v, h=0.1, m=0.6, rho0=1000.0, c0=20.0, alpha=0.3)[0])
    assert np.abs(plain - rho).max() > 0.1 * rho.mean()
    o = np.argsort(s.ids)
    np.testing.assert_allclose(s.densities[o], rho, rtol=1e-12)
    np.testing.assert_allclose(s.pressures[o], pr, rtol=1e-10, atol=1e-9 * np.abs(pr).max())
    np.testing.assert_allclose(s.accelerations[o], a, rtol=1e-9, atol=1e-9 * np.abs(a).max())


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_filled_periodic_box_has_one_density_everywhere(method):
    # 25 x 20 lattice points fill the 0.5 x 0.4 box: no particle is near a
    # surface, so every density equals the interior one, seam included.
    dx = 0.02
    g = (np.arange(25) + 0.5) * dx, (np.arange(20) + 0.5) * dx
    X, Y = np.meshgrid(*g)
    x = np.c_[X.ravel(), Y.ravel()]
    s = _core.Solver(params(method, h=2.5 * dx), x, np.zeros_like(x), NO_WALLS)
    rho = s.densities
    assert np.ptp(rho) < 1e-9 * rho.mean()
    assert np.abs(s.accelerations).max() < 1e-9


def test_a_particle_leaving_one_side_enters_the_other():
    x = np.array([[0.48, 0.39], [0.25, 0.2]])
    v = np.array([[1.0, 0.5], [-0.3, -3.0]])
    s = _core.Solver(params(), x, v, NO_WALLS)
    s.step(0.01, 10)  # 0.1 s: the first crosses x = 0.5 and y = 0.4, the second y = 0
    o = np.argsort(s.ids)
    assert s.removed_particles == 0
    np.testing.assert_allclose(s.positions[o], [[0.08, 0.04], [0.22, 0.3]], atol=1e-12)
    np.testing.assert_allclose(s.velocities[o], v, atol=1e-12)
    lo, hi = np.array([0.0, 0.0]), np.array([0.5, 0.4])
    assert ((s.positions >= lo) & (s.positions < hi)).all()


def test_a_non_periodic_axis_still_removes_leavers():
    x = np.array([[0.25, 0.39]])
    s = _core.Solver(params(periodic=(True, False)), x, np.array([[0.0, 1.0]]), NO_WALLS)
    s.step(0.01, 5)
    assert s.removed_particles == 1 and len(s.ids) == 0


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_shifting_everything_across_the_seam_changes_nothing(method):
    box = ((0.0, 0.0), (0.5, 0.4))
    x, v = random_state(250, box, 9)
    a = _core.Solver(params(method, eta=0.3), x, v, NO_WALLS)
    shifted = x + np.array([0.23, 0.17])  # the solver wraps positions outside the box
    b = _core.Solver(params(method, eta=0.3), shifted, v, NO_WALLS)
    oa, ob = np.argsort(a.ids), np.argsort(b.ids)
    np.testing.assert_allclose(b.densities[ob], a.densities[oa], rtol=1e-11)
    np.testing.assert_allclose(b.accelerations[ob], a.accelerations[oa], rtol=1e-9,
                               atol=1e-9 * np.abs(a.accelerations).max())


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_momentum_is_conserved_in_a_periodic_box(method):
    box = ((0.0, 0.0), (0.5, 0.4))
    x, v = random_state(300, box, 3)
    s = _core.Solver(params(method, eta=0.3, alpha=0.2), x, 0.2 * v, NO_WALLS)
    p0 = s.velocities.sum(axis=0).copy()
    s.step(2e-4, 200)
    assert s.removed_particles == 0
    crossed = np.abs(s.positions[np.argsort(s.ids)] - x).max()
    assert crossed > 0.2  # some particles did cross a seam
    assert np.abs(s.velocities.sum(axis=0) - p0).max() < 1e-11 * np.abs(s.velocities).sum()


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_one_and_two_threads_agree_bit_for_bit(method):
    box = ((0.0, 0.0), (0.5, 0.4))
    x, v = random_state(300, box, 4)
    runs = []
    for threads in (1, 2):
        s = _core.Solver(params(method, eta=0.3, threads=threads), x, 0.2 * v, NO_WALLS)
        s.step(2e-4, 50)
        o = np.argsort(s.ids)
        runs.append((s.positions[o].copy(), s.velocities[o].copy()))
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


def test_small_periodic_box_of_two_cells_is_handled():
    # 2 h <= length < 3 h: the grid has two cells along x, each the other's
    # neighbour on both sides; no pair may be counted twice.
    box = ((0.0, 0.0), (0.25, 0.5))
    x, v = random_state(120, box, 6)
    s = _core.Solver(params(box=box), x, v, NO_WALLS)
    rho = seed_forces(x, v, h=0.1, m=0.6, rho0=1000.0, k=30.0, period=(0.25, 0.5))[0]
    np.testing.assert_allclose(s.densities[np.argsort(s.ids)], rho, rtol=1e-12)


def test_core_rejects_a_periodic_box_under_two_smoothing_lengths():
    with pytest.raises(ValueError, match="at least 2 h wide"):
        _core.Solver(params(box=((0.0, 0.0), (0.15, 1.0))), np.zeros((0, 2)),
                     np.zeros((0, 2)), NO_WALLS)


def test_scene_key_round_trips_and_reaches_the_core(scene_dict):
    d = scene_dict
    d["domain"]["periodic"] = [True, False]
    scene = sphfluid.load_scene(d)
    assert scene.periodic == (True, False)
    assert sphfluid.load_scene(scene.to_dict()) == scene
    sim = sphfluid.Simulation(scene)
    assert tuple(sim._solver.params.periodic) == (True, False)


@pytest.mark.parametrize("value,message", [
    ([True], "expected [x, y] of true/false"),
    ([1, 0], "expected true or false, got the number 1"),
    ("x", "expected [x, y] of true/false"),
])
def test_scene_rejects_bad_periodic_values(scene_dict, value, message):
    d = scene_dict
    d["domain"]["periodic"] = value
    with pytest.raises(sphfluid.SceneError, match=r"domain\.periodic(\[\d\])?: " + message.replace(
            "[", r"\[").replace("]", r"\]")):
        sphfluid.load_scene(d)


def test_scene_rejects_a_periodic_axis_shorter_than_two_smoothing_lengths(scene_dict):
    d = scene_dict
    d["domain"] = {"min": [0.0, 0.0], "max": [0.05, 2.0], "periodic": [True, False]}
    d["fluid_regions"] = []
    with pytest.raises(sphfluid.SceneError, match=r"domain\.periodic: a periodic x axis"):
        sphfluid.load_scene(d)
