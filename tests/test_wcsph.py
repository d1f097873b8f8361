"""The wcsph method: its kernel, its equations against a brute-force evaluation,
the hydrostatic tank, energy in a closed tank, and every scene running with it."""
from __future__ import annotations

import json

import numpy as np
import pytest
import sphfluid
from conftest import ROOT, SCENE_IDS, SCENES
from reference import wcsph_forces
from sphfluid import _core
from sphfluid.simulation import expected_top_speed, speed_of_sound
from test_kernels import radial_integral

H = 0.3


def test_wendland_integrates_to_one_and_vanishes_outside():
    k = _core.kernels
    assert radial_integral(lambda r: k.wendland_w(r, H), H) == pytest.approx(1.0, rel=1e-9)
    assert np.all(k.wendland_w(np.array([H, 1.5 * H]), H) == 0.0)


def test_wendland_gradient_and_laplacian_match_finite_differences():
    k = _core.kernels
    rng = np.random.default_rng(4)
    pts = rng.uniform(-H, H, (200, 2))
    pts = pts[(np.hypot(*pts.T) < 0.95 * H) & (np.hypot(*pts.T) > 0.05 * H)]
    def w(p):
        return k.wendland_w(np.hypot(*p.T), H)

    eps = 1e-6 * H
    num = np.stack([(w(pts + e) - w(pts - e)) / (2 * eps)
                    for e in (np.array([eps, 0.0]), np.array([0.0, eps]))], axis=1)
    ana = k.wendland_grad(pts, H)
    assert np.abs(num - ana).max() < 1e-6 * np.abs(ana).max()
    eps = 1e-4 * H
    lap = sum(w(pts + e) + w(pts - e) - 2 * w(pts)
              for e in (np.array([eps, 0.0]), np.array([0.0, eps]))) / eps**2
    ana = k.wendland_lap(np.hypot(*pts.T), H)
    assert np.abs(lap - ana).max() < 1e-4 * np.abs(ana).max()


def check_against_brute_force(*, n, side, seed, alpha, eta, p_b=0.0, threads=0, clumps=0):
    """Random particles in a square of the given side (and `clumps` of 60 in
    squares of h/2, a coincident pair among them): the native densities,
    pressures and accelerations against tests/reference.py's; returns the
    reference pressures."""
    rng = np.random.default_rng(seed)
    h = 0.1
    x = rng.uniform(0.0, side, (n, 2))
    if clumps:
        corners = rng.uniform(0.0, side - h / 2, (clumps, 2))
        x = np.vstack([x, *(c + rng.uniform(0.0, h / 2, (60, 2)) for c in corners)])
        x[-1] = x[-2]
        n = len(x)
    v = rng.normal(0.0, 1.0, (n, 2))
    p = _core.SimParams()
    p.method, p.h, p.mass, p.rho0, p.c0 = _core.Method.wcsph, h, 0.6, 1000.0, 20.0
    p.alpha, p.eta, p.background_pressure = alpha, eta, p_b
    p.domain_min, p.domain_max = (-1.0, -1.0), (side + 1.5, side + 1.5)
    p.threads = threads
    s = _core.Solver(p, x, v, np.zeros((0, 2, 2)))
    rho, pr, a = wcsph_forces(x, v, h=h, m=0.6, rho0=1000.0, c0=20.0, alpha=alpha, eta=eta,
                              background_pressure=p_b)
    o = np.argsort(s.ids)
    np.testing.assert_allclose(s.densities[o], rho, rtol=1e-12)
    np.testing.assert_allclose(s.pressures[o], pr, rtol=1e-10, atol=1e-9 * pr.max())
    np.testing.assert_allclose(s.accelerations[o], a, rtol=1e-9, atol=1e-9 * np.abs(a).max())
    return pr


@pytest.mark.parametrize("alpha,eta,p_b", [(0.0, 0.0, 0.0), (0.3, 0.0, 0.0), (0.3, 0.5, 0.0),
                                           (0.3, 0.5, 2.0e4)])
def test_native_wcsph_equals_brute_force(alpha, eta, p_b):
    pr = check_against_brute_force(n=300, side=0.5, seed=8, alpha=alpha, eta=eta, p_b=p_b)
    assert (pr > 0).sum() > 50 and (pr == 0).sum() > 10  # compressed and clamped both occur
    if p_b > 0:  # and pressures between 0 and p_b (below the reference) too
        assert ((pr > 0) & (pr < p_b)).sum() > 10


@pytest.mark.parametrize("threads", [1, 2])
def test_native_wcsph_equals_brute_force_across_pair_blocks(threads):
    """Enough particles for several of the blocks in which the pairs are
    evaluated once (an even number from 1,025 particles on: two here), so
    pairs within a block and across blocks both occur, on one thread and on
    two."""
    check_against_brute_force(n=2600, side=1.3, seed=9, alpha=0.3, eta=0.5, threads=threads)


@pytest.mark.parametrize("threads", [1, 2])
def test_native_wcsph_equals_brute_force_with_crowded_cells(threads):
    """Cells of many more particles than the cell-cluster loops take at once
    (neighbours/cell_pairs.hpp) and coincident particles, across several blocks."""
    check_against_brute_force(n=2400, side=1.3, seed=10, alpha=0.3, eta=0.5, threads=threads,
                              clumps=3)


def wcsph_scene(name, density="continuity", **fluid):
    d = json.loads((ROOT / "scenes" / name).read_text())
    d["solver"] = {"method": "wcsph", "time_step": "auto", "density": density}
    d["fluid"].update(fluid)
    return sphfluid.load_scene(d)


def test_speed_of_sound_is_ten_times_the_expected_top_speed():
    scene = wcsph_scene("dam_break.json")
    # Free fall from the top of the column (2 m) to the floor of the domain (-0.1 m).
    assert expected_top_speed(scene) == pytest.approx(np.sqrt(2 * 9.81 * 2.1))
    assert speed_of_sound(scene) == pytest.approx(10 * np.sqrt(2 * 9.81 * 2.1))


@pytest.mark.slow
def test_hydrostatic_tank_with_wcsph():
    """The summed density (W2): density within 1 % of rho0 (the Mach 0.1 of
    c0 = 10 U gives ~0.5 %), and the pressure gradient of a real liquid, rho0 g
    (unlike the seed's), within 20 %. (The continuity density's tank:
    tests/test_wcsph_continuity.py.)"""
    scene = wcsph_scene("hydrostatic.json", "summation", viscosity=0.0)
    sim = sphfluid.Simulation(scene)
    sim.run(2.0)
    slopes, compress, speeds = [], [], []
    for _ in range(5):
        sim.run(0.2)
        x, p, rho = sim.positions, sim.pressures, sim.densities
        top = x[:, 1].max()
        inner = (x[:, 1] > 0.1) & (x[:, 1] < top - 0.1) & (x[:, 0] > 0.1) & (x[:, 0] < 0.9)
        slopes.append(-np.polyfit(x[inner, 1], p[inner], 1)[0] / (1000.0 * 9.81))
        compress.append(rho.max() / 1000.0 - 1.0)
        speeds.append(np.sqrt((sim.velocities**2).sum(axis=1).mean()))
    assert max(compress) < 0.01
    assert np.mean(slopes) == pytest.approx(1.0, rel=0.2)
    assert max(speeds) < 0.05 * np.sqrt(9.81 * 1.0)  # settled (measured: ~1.5 %)
    assert sim.removed_particles == 0


def test_lattice_at_rest_in_a_tank_has_rest_density_in_the_corners_too():
    """At t = 0 the tank's particles sit on the lattice the wall tables mirror, so
    no particle is compressed, the two corner particles included: each wall's
    share covers the quadrant beyond the corner, and it is counted once. (Counted
    twice, the corner particles started 1.5 % dense.)"""
    sim = sphfluid.Simulation(wcsph_scene("hydrostatic.json", "summation", viscosity=0.0))
    x, rho = sim.positions, sim.densities
    corners = [np.argmin(np.hypot(*(x - c).T)) for c in [(0.0, 0.0), (1.0, 0.0)]]
    assert all(np.hypot(*(x[k] - c)) < 0.02 for k, c in zip(corners, [(0, 0), (1, 0)]))
    np.testing.assert_allclose(rho[corners], 1000.0, rtol=1e-9)
    assert rho.max() / 1000.0 - 1.0 < 1e-9


def test_uniformly_compressed_lattice_feels_no_force_along_the_walls_and_in_the_corners():
    """A tank's lattice 1 % heavier than rest, without gravity: every particle has
    the same density and pressure, so the fluid's pushes and the walls' balance
    and nothing accelerates, the two corner particles included (whose push from
    the quadrant beyond the corner is counted once; counted twice, it would be
    the size checked at the end)."""
    d = json.loads((ROOT / "scenes" / "hydrostatic.json").read_text())
    d["solver"] = {"method": "wcsph", "time_step": "auto", "density": "summation"}
    d["fluid"]["viscosity"] = 0.0
    d["gravity"] = [0.0, 0.0]
    dx, h = d["resolution"]["spacing"], d["resolution"]["smoothing_length"]
    m0 = _core.kernels.lattice_mass(1000.0, dx, h, "wendland")
    d["resolution"]["particle_mass"] = 1.01 * m0
    sim = sphfluid.Simulation(d)
    x, rho, p, a = sim.positions, sim.densities, sim.pressures, sim.accelerations
    deep = x[:, 1] < 1.0 - 2 * h  # away from the free surface
    np.testing.assert_allclose(rho[deep], 1010.0, rtol=1e-9)
    np.testing.assert_allclose(p[deep], p[deep][0], rtol=1e-9)
    corners = [np.argmin(np.hypot(*(x - c).T)) for c in [(0.0, 0.0), (1.0, 0.0)]]
    half = _core.kernels.wendland_corner(dx / 2, dx / 2, h, dx, 1.01 * m0 / 1000.0)
    doubled = 2 * p[corners[0]] / 1010.0**2 * 1000.0 * np.hypot(half[1], half[2])
    assert doubled > 0.05  # m/s^2: what a double-counted corner would feel
    assert np.abs(a[deep]).max() < 1e-6 * doubled
    assert np.abs(a[corners]).max() < 1e-6 * doubled


def test_corner_share_matches_the_mirrored_lattice_and_the_continuum():
    """The tabulated quadrant beyond a corner, off the table's nodes: against the
    direct sum over the lattice mirrored through the corner (density and both
    pushes, within 0.5 % of their size at the corner's rest point), and, with
    dx = 0, against a fine quadrature of the continuum."""
    h, dx, mr = 0.05, 0.025, 0.025**2
    g = -140 / (np.pi * h**4)
    scale = 5e-3 * np.array(_core.kernels.wendland_corner(dx / 2, dx / 2, h, dx, mr))
    assert scale[0] > 1e-2 * 5e-3  # the share at rest is 1.5 % of rho0
    for d1, d2 in [(0.0125, 0.0125), (0.0071, 0.0193), (0.0202, 0.004), (0.0411, 0.0411)]:
        u, v = np.meshgrid(2 * d1 + dx * np.arange(8), 2 * d2 + dx * np.arange(8))
        r = np.hypot(u, v).ravel()
        a = np.clip(1 - r / h, 0, None)
        want = (mr * _core.kernels.wendland_w(r, h).sum(), mr * (-g * a**3 * u.ravel()).sum(),
                mr * (-g * a**3 * v.ravel()).sum())
        got = _core.kernels.wendland_corner(d1, d2, h, dx, mr)
        assert np.all(np.abs(np.subtract(got, want)) <= scale), (d1, d2, got, want)
        # continuum: W over [d1, inf) x [d2, inf)
        s = (np.arange(2000) + 0.5) * h / 2000
        uu, vv = np.meshgrid(d1 + s, d2 + s)
        cont = _core.kernels.wendland_w(np.hypot(uu, vv).ravel(), h).sum() * (h / 2000) ** 2
        assert _core.kernels.wendland_corner(d1, d2, h)[0] == pytest.approx(cont, rel=2e-2, abs=1e-5)
    assert _core.kernels.wendland_corner(0.03, 0.03, h, dx, mr) == (0.0, 0.0, 0.0)


@pytest.mark.slow
def test_energy_in_a_closed_tank_stays_constant_after_settling():
    """The summed density (W2, whose clamp the energy below follows). Closed
    tank, no physical viscosity, the default artificial viscosity 0.1: the start (at rho0, not yet compressed by gravity) dissipates about 1.4 % of
    M g H while it settles; after that the total energy (kinetic + gravitational
    + Tait elastic) drifts by under 1e-3 M g H (measured: 6e-5 over 2.5 s). With
    alpha = 0.02 the same tank gains energy (0.11 M g H in 3 s): wcsph needs it."""
    d = json.loads((ROOT / "scenes" / "hydrostatic.json").read_text())
    d["solver"] = {"method": "wcsph", "time_step": "auto", "density": "summation"}
    d["fluid"]["viscosity"] = 0.0
    d["walls"] = [{"polyline": [[0.0, 1.2], [0.0, 0.0], [1.0, 0.0], [1.0, 1.2]],
                   "closed": True}]
    d["domain"] = {"min": [-0.1, -0.1], "max": [1.1, 1.3]}
    sim = sphfluid.Simulation(d)
    c0, m = speed_of_sound(sim.scene), sim.particle_mass
    B = 1000.0 * c0**2 / 7

    def energy():
        r = np.maximum(sim.densities / 1000.0, 1.0)
        elastic = m * (B / (6 * 1000.0) * (r**6 - 1) + B * (1 / (r * 1000.0) - 1 / 1000.0))
        return (0.5 * m * (sim.velocities**2).sum() + m * 9.81 * sim.positions[:, 1].sum()
                + elastic.sum())

    scale = sim.n_particles * m * 9.81 * 1.0
    e_start = energy()
    sim.run(0.5)
    e_settled = energy()
    assert (e_settled - e_start) / scale < 0  # settling only dissipates
    drift = []
    for _ in range(4):
        sim.run(0.5)
        drift.append((energy() - e_settled) / scale)
    assert max(abs(x) for x in drift) < 1e-3


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_every_scene_runs_with_wcsph_by_changing_the_method_alone(path):
    d = json.loads(path.read_text())
    d["solver"]["method"] = "wcsph"
    sim = sphfluid.Simulation(d)
    sim.step(50)
    assert np.all(np.isfinite(sim.positions))
    assert sim.stats()["max_density_error"] < 1.0


def test_dam_break_compression_within_one_percent_for_99_percent_of_particles():
    """The issue's 1 % on the dam break, counting compression only (rho > rho0:
    the free surface's deficit is kernel truncation, not compression), sampled
    every 0.01 s to t = 1 s at ~3,000 particles. Measured: mean <= 0.2 %, 99th
    percentile <= 0.6 %. Single particles at the impact on the far wall reach
    4-6 % at this c0; the next test bounds every particle at a higher c0."""
    from sphfluid.bench import dam_break_scene

    scene = dam_break_scene(3000, "wcsph")
    scene["solver"]["time_step"] = "auto"
    sim = sphfluid.Simulation(scene)
    worst_mean = worst_p99 = 0.0
    for t in np.arange(0.01, 1.0001, 0.01):
        sim.advance_to(t)
        c = np.maximum(sim.densities / 1000.0 - 1.0, 0.0)
        worst_mean = max(worst_mean, c.mean())
        worst_p99 = max(worst_p99, np.quantile(c, 0.99))
    assert sim.removed_particles == 0
    assert worst_mean < 0.005
    assert worst_p99 < 0.01


def test_dam_break_every_particle_within_one_percent_at_40_times_the_top_speed():
    """With c0 = 40 x the expected top speed no particle is compressed by 1 % at
    any step to t = 1 s, the impact on the far wall included (measured with the
    summation density at ~3,000 particles: 0.69 %; 30 x: 1.3 %; the default 10 x:
    5.2 %, with 7 % of the steps
    having some particle over 1 %: STABILITY.md, "Density error and the speed of
    sound")."""
    from sphfluid.bench import dam_break_scene

    scene = dam_break_scene(3000, "wcsph")
    scene["solver"]["time_step"] = "auto"
    scene["fluid"]["speed_of_sound"] = 40 * expected_top_speed(sphfluid.load_scene(scene))
    sim = sphfluid.Simulation(scene)
    worst, steps = 0.0, 0
    while sim.time < 1.0:
        sim.step(1)
        steps += 1
        worst = max(worst, sim.densities.max() / 1000.0 - 1.0)
    assert steps == sim.step_count > 15_000  # every step of the run was checked
    assert sim.removed_particles == 0
    assert worst < 0.01


def test_tension_keeps_the_pair_loops_of_the_scene_without_it():
    """wcsph's surface energy reads no neighbour lists, so surface tension
    leaves the pairs where they are summed without it: by cell clusters, with
    no lists kept, where those run (the seed's colour field needs the lists)."""
    rng = np.random.default_rng(4)
    x = rng.uniform(0.0, 0.8, (1500, 2))
    held = []
    for sigma in (0.0, 2.0):
        p = _core.SimParams()
        p.method, p.h, p.mass, p.rho0, p.c0 = _core.Method.wcsph, 0.1, 0.6, 1000.0, 20.0
        p.sigma, p.spacing = sigma, 0.025
        p.domain_min, p.domain_max = (-1.0, -1.0), (2.0, 2.0)
        s = _core.Solver(p, x, np.zeros_like(x), np.zeros((0, 2, 2)))
        held.append((s.memory_bytes["neighbours"], s.neighbour_pairs))
    if held[0][0] > 4 * len(x):
        pytest.skip("no cell clusters in this build (no AVX-512): both keep the lists")
    assert held[1] == held[0]
