"""solver.pair_precision "float": the seed's pressure and viscosity pair forces
summed in single precision by the cell clusters (CellFloatFrame, SeedFloats),
the density in double as without it. The forces agree with the double sums to
float round-off at any resolution and wherever the fluid sits in the domain, 1
and 2 threads give identical states, and double stays the default."""
from __future__ import annotations

import json

import numpy as np
import pytest
import sphfluid
from conftest import ROOT
from sphfluid import _core

GRAVITY = np.array([0.0, -9.81])


def params(h, float_pairs, origin=0.0, side=1.0, eta=0.3):
    """The seed's settings at smoothing length h (spacing h / 2), for a box of
    the given side whose lower left corner is at (origin, origin)."""
    p = _core.SimParams()
    dx = h / 2
    p.h, p.rho0, p.k, p.eta = h, 1000.0, 30.0, eta
    p.mass = 1000.0 * dx * dx
    p.domain_min = (origin - 0.2 * side, origin - 0.2 * side)
    p.domain_max = (origin + 1.2 * side, origin + 1.2 * side)
    p.float_pairs = float_pairs
    return p


def jittered(n_side, dx, origin, seed=3):
    """A lattice with jitter of 0.2 dx: no two particles closer than 0.6 dx."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side))
    x = np.column_stack([i.ravel(), j.ravel()]) * dx + 0.5 * dx
    x += rng.uniform(-0.2 * dx, 0.2 * dx, x.shape)
    return origin + x, rng.normal(0.0, 0.5, x.shape)


def evaluated(h, float_pairs, origin=0.0, n_side=40):
    dx = h / 2
    side = n_side * dx
    x, v = jittered(n_side, dx, origin)
    # a floor and a left wall, so the walls' share is in the sums too
    walls = origin + np.array([[[0.0, 0.0], [side, 0.0]], [[0.0, side], [0.0, 0.0]]])
    v *= h / 0.02  # velocities that scale with the resolution (a fixed CFL number)
    s = _core.Solver(params(h, float_pairs, origin, side), x, v, walls, np.arange(len(x)))
    assert s.float_pairs == float_pairs
    s.compute_forces()
    o = np.argsort(s.ids)
    return s, s.accelerations[o] - GRAVITY, s.densities[o], s.pressures[o]


def needs_float_pairs():
    s = _core.Solver(params(0.02, True), np.array([[0.5, 0.5]]), np.zeros((1, 2)),
                     np.zeros((0, 2, 2)), np.arange(1))
    if not s.float_pairs:
        pytest.skip("this build has no cell clusters (AVX-512F and VL): float pairs fall "
                    "back to double")


@pytest.mark.parametrize("h,origin", [(0.02, 0.0), (0.02, 1000.0), (1e-5, 3.0), (200.0, -5e4)])
def test_float_sums_match_double_to_float_round_off(h, origin):
    """Densities and pressures exactly (the density stays in double), forces to
    2e-6 of the largest (measured: 4e-7 in all four cases). The pressure forces
    are sums of terms tens of times larger than their result, so float's 6e-8
    grows in them. Positions far from the origin (x = 1000 m at h = 0.02 m: a
    float of 1000 resolves 6e-5 m, a third of a percent of h) and extreme h
    (powers of h up to h^-5 in the kernels) keep that precision: the float sums
    take positions relative to their cell, in cells, and quantities scaled to
    order one."""
    needs_float_pairs()
    _, ad, rd, pd = evaluated(h, False, origin)
    s, af, rf, pf = evaluated(h, True, origin)
    assert s.float_pairs
    np.testing.assert_array_equal(rf, rd)
    np.testing.assert_array_equal(pf, pd)
    fscale = np.abs(ad).max()
    assert np.abs(af - ad).max() < 2e-6 * fscale
    assert np.abs(af - ad).max() > 0  # and float really ran


def test_double_is_the_default_and_float_is_seed_only():
    p = _core.SimParams()
    assert p.float_pairs is False
    x, v = jittered(10, 0.01, 0.0)
    walls = np.zeros((0, 2, 2))
    assert not _core.Solver(params(0.02, False), x, v, walls, np.arange(len(x))).float_pairs
    w = params(0.02, True)
    w.method, w.c0 = _core.Method.wcsph, 20.0
    assert not _core.Solver(w, x, v, walls, np.arange(len(x))).float_pairs
    t = params(0.02, True)
    t.sigma = 0.5  # the seed with tension keeps its lists, in double
    assert not _core.Solver(t, x, v, walls, np.arange(len(x))).float_pairs


def scene(name, precision=None):
    d = json.loads((ROOT / "scenes" / name).read_text())
    if precision is not None:
        d["solver"]["pair_precision"] = precision
    return d


def test_scene_key_is_checked_with_its_path():
    with pytest.raises(sphfluid.SceneError, match=r"solver\.pair_precision.*\"double\" or "
                       r"\"float\""):
        sphfluid.load_scene(scene("dam_break.json", "single"))
    d = scene("dam_break.json", "float")
    d["solver"]["method"] = "wcsph"
    with pytest.raises(sphfluid.SceneError, match=r"solver\.pair_precision.*seed method only"):
        sphfluid.load_scene(d)
    loaded = sphfluid.load_scene(scene("dam_break.json", "float"))
    assert loaded.pair_precision == "float"
    assert sphfluid.load_scene(loaded.to_dict()) == loaded
    assert sphfluid.load_scene(scene("dam_break.json")).pair_precision == "double"
    assert sphfluid.Simulation(scene("dam_break.json")).stats()["pair_precision"] == "double"


@pytest.mark.skipif(not sphfluid.has_openmp, reason="built without OpenMP")
def test_one_and_two_threads_give_identical_states():
    needs_float_pairs()
    out = []
    for threads in (1, 2):
        sim = sphfluid.Simulation(scene("dam_break.json", "float"), threads=threads)
        assert sim.threads_in_use == threads and sim.stats()["pair_precision"] == "float"
        sim.step(200)
        out.append({k: getattr(sim, k).copy() for k in ("ids", "positions", "velocities",
                                                        "accelerations", "densities")})
    for key in out[0]:
        np.testing.assert_array_equal(out[0][key], out[1][key], err_msg=key)


def test_shuffled_input_gives_the_same_forces_to_float_round_off():
    """Storage order changes the order of the float sums within a cell: the
    result moves by float round-off, not more."""
    needs_float_pairs()
    x, v = jittered(40, 0.01, 0.0, seed=8)
    walls = np.array([[[0.0, 0.0], [0.4, 0.0]]])
    perm = np.random.default_rng(2).permutation(len(x))
    ids = np.arange(len(x))
    a = _core.Solver(params(0.02, True, side=0.4), x, v, walls, ids)
    b = _core.Solver(params(0.02, True, side=0.4), x[perm], v[perm], walls, ids[perm])
    a.compute_forces()
    b.compute_forces()
    oa, ob = np.argsort(a.ids), np.argsort(b.ids)
    fa, fb = a.accelerations[oa] - GRAVITY, b.accelerations[ob] - GRAVITY
    assert np.abs(fb - fa).max() < 1e-6 * np.abs(fa).max()  # measured: 1e-7
    np.testing.assert_allclose(b.densities[ob], a.densities[oa], rtol=1e-14, atol=0)
    assert np.abs(fb - fa).max() > 0  # the order did change the float sums


def test_dam_break_front_agrees_with_double():
    """0.4 s of the bundled dam break: the surge front of the float run within
    half a particle spacing of the double run's."""
    needs_float_pairs()
    from sphfluid.validation.cases import surge_front
    dx = scene("dam_break.json")["resolution"]["spacing"]
    fronts = []
    for precision in ("double", "float"):
        sim = sphfluid.Simulation(scene("dam_break.json", precision), threads=1)
        sim.advance_to(0.4)
        fronts.append(surge_front(sim.positions, dx))
    assert fronts[0] > 1.5  # the surge has run well out from the column's 1 m
    assert abs(fronts[1] - fronts[0]) < 0.5 * dx


@pytest.mark.parametrize("k", [250.0, 1e5])
def test_float_force_error_scales_with_the_pressure(k):
    """The float error of a pair term is relative to the term, and the pressure
    terms grow with p / rho while their sum (the net force) need not: under a
    high background pressure (a stiff EOS) a particle's acceleration differs
    from double's by up to about 3e-7 max(p / rho) / h, whatever the net force.
    Measured on this lattice compressed by 1.7 %: 2.4e-7 to 2.6e-7 at k = 250,
    1e4 and 1e5 (at k = 1e5, p / rho0 = 3.5e3 m^2/s^2 in the bulk and h =
    0.04 m: 0.35 m/s^2 at most, 0.04 in the median)."""
    needs_float_pairs()
    h, n_side = 0.04, 40
    x, v = jittered(n_side, h / 2, 0.0)
    side = n_side * h / 2
    walls = np.array([[[0.0, 0.0], [side, 0.0]], [[0.0, side], [0.0, 0.0]]])
    out = []
    for float_pairs in (False, True):
        p = params(h, float_pairs, 0.0, side)
        p.k, p.rho0 = k, 983.0  # the lattice's density is 1.7 % above rho0
        s = _core.Solver(p, x, v, walls, np.arange(len(x)))
        s.compute_forces()
        o = np.argsort(s.ids)
        out.append((s.accelerations[o], s.pressures[o], s.densities[o]))
    (ad, pd, rd), (af, _, _) = out
    scale = np.abs(pd / rd).max() / h
    err = np.abs(af - ad).max()
    assert 1e-7 * scale < err < 1e-6 * scale
