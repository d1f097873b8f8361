"""wcsph with the continuity density (docs/method-wcsph.md, W17-W22): the
rate, the diffusion and the forces against a brute-force NumPy evaluation
(tests/reference.py), the same state on one thread and on two, and the scene
options."""
import numpy as np
import pytest

import sphfluid
from sphfluid import _core
from sphfluid.scene import SceneError
from reference import delta_forces, delta_rate

H, M, RHO0, C0 = 0.1, 0.6, 1000.0, 20.0


def solver(x, v, *, alpha, eta, delta, gravity, side, threads=1, shifting=0.0):
    p = _core.SimParams()
    p.method, p.h, p.mass, p.rho0, p.c0 = _core.Method.wcsph, H, M, RHO0, C0
    p.alpha, p.eta, p.gravity = alpha, eta, gravity
    p.continuity, p.delta, p.shifting = True, delta, shifting
    p.domain_min, p.domain_max = (0.0, 0.0), (side, side)
    p.periodic = (True, True)
    p.threads = threads
    return _core.Solver(p, x, v, np.zeros((0, 2, 2)))


@pytest.mark.parametrize("alpha,eta,delta", [(0.0, 0.0, 0.0), (0.3, 0.5, 0.1), (0.0, 0.5, 0.4)])
def test_one_step_equals_brute_force(alpha, eta, delta):
    """A random periodic cloud: the starting evaluation (rho = rho0), then one
    step of dt: v_h = v + dt/2 a0, x1 = x + dt v_h, rho1 = rho0 + dt D(x1, v_h,
    rho0), a1 = a(x1, v_h, rho1) (W22), each against the brute force."""
    rng = np.random.default_rng(4)
    side, n = 0.6, 400
    x = rng.uniform(0.0, side, (n, 2))
    v = rng.normal(0.0, 0.5, (n, 2))
    g = (0.3, -9.81)
    s = solver(x, v, alpha=alpha, eta=eta, delta=delta, gravity=g, side=side)
    rho = np.full(n, RHO0)
    period = (side, side)
    kw = dict(h=H, m=M, rho0=RHO0, c0=C0, alpha=alpha, eta=eta, gravity=g, period=period)
    _, a0 = delta_forces(x, v, rho, **kw)
    o = np.argsort(s.ids)
    np.testing.assert_allclose(s.accelerations[o], a0, rtol=1e-9, atol=1e-9 * np.abs(a0).max())
    dt = 2e-4
    s.step(dt)
    vh = v + 0.5 * dt * a0
    x1 = np.mod(x + dt * vh, side)
    d = delta_rate(x1, vh, rho, h=H, m=M, rho0=RHO0, c0=C0, delta=delta, gravity=g,
                   period=period)
    assert np.abs(d).max() > 100  # the rate matters at this dt
    rho1 = rho + dt * d
    p1, a1 = delta_forces(x1, vh, rho1, **kw)
    o = np.argsort(s.ids)
    np.testing.assert_allclose(s.positions[o], x1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s.densities[o], rho1, rtol=1e-12)
    np.testing.assert_allclose(s.pressures[o], p1, rtol=1e-9, atol=1e-9 * np.abs(p1).max())
    np.testing.assert_allclose(s.accelerations[o], a1, rtol=1e-8, atol=1e-8 * np.abs(a1).max())
    assert (p1 < 0).sum() > 50 and (p1 > 0).sum() > 50  # no clamp: both signs occur


def test_diffusion_leaves_a_hydrostatic_profile_alone():
    """The diffusion of W18 takes out the hydrostatic density difference
    (Fourtakas et al. 2019): a linear profile rho0 (1 + g (H - y) / c0^2) at
    rest has no rate, whatever delta; the plain difference would have one."""
    dx = 0.025
    g = np.arange(0.5, 24) * dx
    x = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    rho = RHO0 * (1 + 9.81 * (0.6 - x[:, 1]) / C0**2)
    v = np.zeros_like(x)
    rate = delta_rate(x, v, rho, h=H, m=M, rho0=RHO0, c0=C0, delta=0.1,
                      period=(0.6, 0.6))
    interior = (x[:, 1] > H) & (x[:, 1] < 0.6 - H)  # away from the vertical seam's jump
    assert np.abs(rate[interior]).max() < 1e-9 * RHO0
    plain = delta_rate(x, v, rho, h=H, m=M, rho0=RHO0, c0=C0, delta=0.1, gravity=(0.0, 0.0),
                       period=(0.6, 0.6))
    assert np.abs(plain[interior]).max() > 1e-3


def test_one_thread_and_two_give_the_same_state():
    rng = np.random.default_rng(5)
    side, n = 1.5, 2500
    x = rng.uniform(0.0, side, (n, 2))
    v = rng.normal(0.0, 0.3, (n, 2))
    runs = []
    for threads in (1, 2):
        s = solver(x, v, alpha=0.1, eta=0.5, delta=0.1, gravity=(0.0, -9.81), side=side,
                   threads=threads, shifting=16.0)
        s.step(1e-4, 5)
        o = np.argsort(s.ids)
        runs.append((s.positions[o], s.velocities[o], s.densities[o]))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


def test_scene_options():
    d = {"format": "sphfluid-scene/1", "domain": {"min": [0, 0], "max": [1, 1],
                                                   "periodic": [True, True]},
         "fluid": {"rest_density": 1000.0, "viscosity": 10.0, "speed_of_sound": 10.0},
         "resolution": {"spacing": 0.05},
         "fluid_regions": [{"shape": "rectangle", "min": [0, 0], "max": [1, 1]}],
         "gravity": [0, 0],
         "solver": {"method": "wcsph", "time_step": "auto", "density": "continuity",
                    "density_diffusion": 0.2, "shifting": 8}}
    scene = sphfluid.load_scene(d)
    assert (scene.density, scene.density_diffusion, scene.shifting) == ("continuity", 0.2, 8)
    assert sphfluid.load_scene(scene.to_dict()) == scene
    sim = sphfluid.Simulation(scene, threads=1)
    sim.advance_to(0.01)
    assert np.isfinite(sim.densities).all()
    bad = dict(d, solver={"method": "seed", "time_step": 1e-4, "density": "continuity"})
    with pytest.raises(SceneError, match=r"solver\.density"):
        sphfluid.load_scene(bad)
    bad = dict(d, solver={"method": "wcsph", "time_step": "auto", "shifting": 2})
    with pytest.raises(SceneError, match=r"solver\.shifting"):
        sphfluid.load_scene(bad)
    bad = dict(d, solver=dict(d["solver"], density="sum"))
    with pytest.raises(SceneError, match=r"solver\.density"):
        sphfluid.load_scene(bad)
