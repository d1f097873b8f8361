"""The seed's 2D kernels (docs/method-seed.md): normalisation, support, gradients, Laplacians."""
from __future__ import annotations

import numpy as np
import pytest
from sphfluid._core import kernels

H = 0.37


def radial_integral(f, h, n=20001):
    """Integral of a radial function over the plane: 2 pi int_0^h f(r) r dr (Simpson)."""
    r = np.linspace(0.0, h, n)
    y = f(r) * r
    w = np.ones(n)
    w[1:-1:2], w[2:-1:2] = 4, 2
    return 2 * np.pi * (h / (n - 1)) / 3 * (w * y).sum()


@pytest.mark.parametrize("name", ["w_poly6", "w_spiky"])
def test_kernels_integrate_to_one(name):
    f = getattr(kernels, name)
    assert radial_integral(lambda r: f(r, H), H) == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("name", ["w_poly6", "w_spiky", "lap_visc", "lap_poly6"])
def test_kernels_vanish_outside_support(name):
    f = getattr(kernels, name)
    r = np.array([H, H * (1 + 1e-12), 1.5 * H, 10 * H])
    assert np.all(f(r, H) == 0.0)


def test_viscosity_laplacian_second_moment():
    # sum_j V_j (v_j - v_i) lap W approximates lap v in 2D only if
    # int r^2 lap W dA = 2 d = 4 (docs/method-seed.md: this fixes the constant 40/(pi h^5)).
    assert radial_integral(lambda r: r**2 * kernels.lap_visc(r, H), H) == pytest.approx(4.0, rel=1e-9)


def test_viscosity_laplacian_reproduces_laplacian_of_a_quadratic():
    # v(x, y) = x^2 + 3 y^2 has lap v = 8; check the discrete sum on a fine lattice.
    dx = H / 60
    g = np.arange(-61, 62) * dx
    X, Y = np.meshgrid(g, g)
    r = np.hypot(X, Y).ravel()
    v = (X**2 + 3 * Y**2).ravel()
    approx = (dx * dx * v * kernels.lap_visc(r, H)).sum()
    assert approx == pytest.approx(8.0, rel=2e-2)


@pytest.mark.parametrize("name,grad", [("w_poly6", "grad_poly6"), ("w_spiky", "grad_spiky")])
def test_gradients_match_finite_differences(name, grad):
    w, g = getattr(kernels, name), getattr(kernels, grad)
    rng = np.random.default_rng(7)
    pts = rng.uniform(-H, H, (200, 2))
    pts = pts[(np.hypot(*pts.T) < 0.97 * H) & (np.hypot(*pts.T) > 0.02 * H)]
    eps = 1e-6 * H
    num = np.empty_like(pts)
    for axis in range(2):
        e = np.zeros(2)
        e[axis] = eps
        num[:, axis] = (w(np.hypot(*(pts + e).T), H) - w(np.hypot(*(pts - e).T), H)) / (2 * eps)
    ana = g(pts, H)
    scale = np.abs(ana).max()
    assert np.abs(num - ana).max() < 1e-6 * scale


def test_poly6_laplacian_matches_finite_differences():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-H, H, (100, 2))
    pts = pts[np.hypot(*pts.T) < 0.95 * H]
    eps = 1e-4 * H
    w = lambda p: kernels.w_poly6(np.hypot(*p.T), H)
    lap = sum(w(pts + e) + w(pts - e) - 2 * w(pts) for e in (np.array([eps, 0]), np.array([0, eps])))
    lap /= eps**2
    ana = kernels.lap_poly6(np.hypot(*pts.T), H)
    assert np.abs(lap - ana).max() < 1e-5 * np.abs(ana).max()


def test_spiky_gradient_is_zero_at_the_origin():
    assert np.all(kernels.grad_spiky(np.zeros((1, 2)), H) == 0.0)


def test_constants_match_spec():
    # docs/method-seed.md: poly6 4/(pi h^8) (h^2 - r^2)^3; spiky grad -30/(pi h^5) (h - r)^2;
    # viscosity Laplacian 40/(pi h^5) (h - r).
    r = 0.3 * H
    assert kernels.w_poly6(np.array([r]), H)[0] == pytest.approx(4 / (np.pi * H**8) * (H**2 - r**2) ** 3)
    g = kernels.grad_spiky(np.array([[r, 0.0]]), H)[0]
    assert g[0] == pytest.approx(-30 / (np.pi * H**5) * (H - r) ** 2)
    assert kernels.lap_visc(np.array([r]), H)[0] == pytest.approx(40 / (np.pi * H**5) * (H - r))


def test_lattice_mass_gives_rest_density():
    dx, h, rho0 = 0.02, 0.04, 1000.0
    m = kernels.lattice_mass(rho0, dx, h)
    g = np.arange(-3, 4) * dx
    X, Y = np.meshgrid(g, g)
    rho = m * kernels.w_poly6(np.hypot(X, Y).ravel(), h).sum()
    assert rho == pytest.approx(rho0, rel=1e-12)


@pytest.mark.parametrize("h", [0.0, -1.0, float("nan")])
def test_bad_smoothing_length_is_rejected(h):
    with pytest.raises(ValueError, match="h must be > 0"):
        kernels.w_poly6(np.array([0.1]), h)
