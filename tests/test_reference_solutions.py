"""Unit tests of the validation reference solutions (sphfluid.validation.reference)."""
from __future__ import annotations

import numpy as np
import pytest
from sphfluid.validation import reference as ref

# Morris, Fox & Zhu (1997) Poiseuille parameters.
GAP, NU, FORCE = 1e-3, 1e-6, 2e-4
V0 = FORCE * GAP**2 / (8 * NU)


def poiseuille(y, t, **kwargs):
    return ref.poiseuille_velocity(y, t, gap=GAP, nu=NU, force=FORCE, **kwargs)


# ---------------------------------------------------------------- Poiseuille


def test_poiseuille_centre_max():
    assert ref.poiseuille_centre_max(GAP, NU, FORCE) == pytest.approx(2.5e-5, rel=1e-12)


def test_poiseuille_zero_at_start_and_small_early():
    y = np.linspace(0.0, GAP, 41)
    assert np.array_equal(poiseuille(y, 0.0), np.zeros_like(y))
    # Early on the fluid accelerates freely away from the walls (v = F t) and the
    # maximum principle bounds it everywhere: 0 <= v <= F t.
    t = 1e-3
    v = poiseuille(y, t)
    assert np.all(v >= -1e-12 * V0)
    assert np.all(v <= FORCE * t * (1 + 1e-9))
    assert poiseuille(GAP / 2, t) == pytest.approx(FORCE * t, rel=1e-8)
    assert poiseuille(GAP / 2, 1e-7) == pytest.approx(FORCE * 1e-7, rel=1e-6)


def test_poiseuille_positive_for_positive_force():
    y = np.linspace(0.0, GAP, 21)[1:-1]
    assert np.all(poiseuille(y, 0.05) > 0.0)


@pytest.mark.parametrize("t", [1e-4, 0.01, 0.2, np.inf])
def test_poiseuille_no_slip(t):
    v = poiseuille(np.array([0.0, GAP]), t)
    assert np.all(np.abs(v) <= 1e-12 * V0)


@pytest.mark.parametrize("t", [0.01, 0.05, 0.3])
def test_poiseuille_satisfies_pde(t):
    # dv/dt = F + nu d2v/dy2, central differences: O(dt^2, dy^2) error.
    dt, dy = 1e-5, GAP / 400
    y = np.linspace(0.0, GAP, 401)
    dvdt = (poiseuille(y, t + dt) - poiseuille(y, t - dt)) / (2 * dt)
    v = poiseuille(y, t)
    d2v = (v[2:] - 2 * v[1:-1] + v[:-2]) / dy**2
    residual = dvdt[1:-1] - FORCE - NU * d2v
    assert np.max(np.abs(residual)) < 1e-4 * FORCE


def test_poiseuille_tends_to_parabola():
    y = np.linspace(0.0, GAP, 51)
    parabola = FORCE * y * (GAP - y) / (2 * NU)
    np.testing.assert_allclose(poiseuille(y, np.inf), parabola, rtol=0, atol=1e-15 * V0)
    np.testing.assert_allclose(poiseuille(y, 5.0), parabola, rtol=0, atol=1e-12 * V0)
    assert np.max(parabola) == pytest.approx(V0)


def test_poiseuille_adaptive_terms_converged():
    y = np.linspace(0.0, GAP, 33)
    for t in (1e-5, 0.0225, 0.5):
        exact = poiseuille(y, t, terms=100_000)
        np.testing.assert_allclose(poiseuille(y, t), exact, rtol=0, atol=1e-10 * V0)


@pytest.mark.parametrize(
    ("t", "centre_ratio", "quarter"),
    [
        (0.0225, "0.1786", 4.048e-06),
        (0.045, "0.3388", 7.036e-06),
        (0.1125, "0.6600", 1.274e-05),
        (0.225, "0.8880", 1.677e-05),
        (0.5, "0.9926", 1.862e-05),
        (1.0, "0.99995", 1.875e-05),
    ],
)
def test_poiseuille_matches_table(t, centre_ratio, quarter):
    """analytic.md section 2 table, to the tabulated digits."""
    centre, quarter_sim = poiseuille(np.array([GAP / 2, GAP / 4]), t)
    digits = len(centre_ratio.split(".")[1])
    assert f"{centre / V0:.{digits}f}" == centre_ratio
    assert float(f"{quarter_sim:.4g}") == pytest.approx(quarter, rel=1e-12)


# ---------------------------------------------------------------- Taylor-Green

TG = {"length": 2.0, "speed": 0.5, "nu": 0.03}  # deliberately not the unit box
RHO = 3.0


def test_taylor_green_divergence_free():
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, TG["length"], (2, 20))
    h = 1e-6
    du_dx = (ref.taylor_green_velocity(x + h, y, 0.7, **TG)[0]
             - ref.taylor_green_velocity(x - h, y, 0.7, **TG)[0]) / (2 * h)
    dv_dy = (ref.taylor_green_velocity(x, y + h, 0.7, **TG)[1]
             - ref.taylor_green_velocity(x, y - h, 0.7, **TG)[1]) / (2 * h)
    assert np.max(np.abs(du_dx + dv_dy)) < 1e-8


def test_taylor_green_momentum():
    """du/dt + (u.grad) u = -grad p / rho + nu lap u, by central differences."""
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, TG["length"], (2, 12))
    t, h, dt = 0.4, 1e-4, 1e-5

    def vel(xx, yy, tt):
        return np.array(ref.taylor_green_velocity(xx, yy, tt, **TG))

    def pres(xx, yy):
        return ref.taylor_green_pressure(xx, yy, t, rho=RHO, **TG)

    w = vel(x, y, t)
    dw_dt = (vel(x, y, t + dt) - vel(x, y, t - dt)) / (2 * dt)
    dw_dx = (vel(x + h, y, t) - vel(x - h, y, t)) / (2 * h)
    dw_dy = (vel(x, y + h, t) - vel(x, y - h, t)) / (2 * h)
    lap = (vel(x + h, y, t) + vel(x - h, y, t) + vel(x, y + h, t) + vel(x, y - h, t)
           - 4 * w) / h**2
    grad_p = np.array([(pres(x + h, y) - pres(x - h, y)) / (2 * h),
                       (pres(x, y + h) - pres(x, y - h)) / (2 * h)])
    residual = dw_dt + w[0] * dw_dx + w[1] * dw_dy + grad_p / RHO - TG["nu"] * lap
    scale = np.pi / TG["length"] * TG["speed"] ** 2  # size of the nonlinear term
    assert np.max(np.abs(residual)) < 1e-5 * scale
    assert np.max(np.abs(grad_p / RHO)) > 0.1 * scale  # the pressure term matters


@pytest.mark.parametrize(("t", "expected"), [(1.0, 0.45404), (2.0, 0.20615), (5.0, 0.019296)])
def test_taylor_green_max_speed(t, expected):
    """|v|max/U at Re = 100 (analytic.md section 4), on a grid holding the maximum."""
    x, y = np.meshgrid(np.linspace(0, 1, 41), np.linspace(0, 1, 41))
    u, v = ref.taylor_green_velocity(x, y, t, nu=0.01)
    assert np.max(np.hypot(u, v)) == pytest.approx(expected, rel=2e-5)
    assert ref.taylor_green_decay(t, nu=0.01) == pytest.approx(expected, rel=2e-5)


def test_taylor_green_pressure_zero_mean():
    x, y = np.meshgrid(np.linspace(0, 2, 64, endpoint=False), np.linspace(0, 2, 64, endpoint=False))
    p = ref.taylor_green_pressure(x, y, 0.0, rho=RHO, **TG)
    assert abs(p.mean()) < 1e-12
    assert p.max() == pytest.approx(RHO * TG["speed"] ** 2 / 2)


# ---------------------------------------------------------------- droplet, hydrostatic


def test_droplet_frequency():
    assert ref.droplet_frequency(1.0, 1.0, 0.2, rho_outer=1.0) == pytest.approx(19.365, abs=5e-4)
    assert ref.droplet_frequency(1.0, 1.0, 0.2) == pytest.approx(27.386, abs=5e-4)
    # omega^2 ~ n (n^2 - 1): mode 3 is 2 sqrt(2) times faster than mode 2.
    ratio = ref.droplet_frequency(1.0, 1.0, 0.2, mode=3) / ref.droplet_frequency(1.0, 1.0, 0.2)
    assert ratio == pytest.approx(np.sqrt(24 / 6))
    with pytest.raises(ValueError, match="mode"):
        ref.droplet_frequency(1.0, 1.0, 0.2, mode=1)


def test_droplet_damping_and_laplace():
    assert ref.droplet_damping_rate(0.05, 0.2) == pytest.approx(5.0)
    assert ref.droplet_damping_rate(0.05, 0.2, mode=3) == pytest.approx(15.0)
    assert ref.laplace_pressure_jump(1.0, 0.3 / np.sqrt(np.pi)) == pytest.approx(5.908, abs=5e-4)


def test_hydrostatic_pressure():
    p = ref.hydrostatic_pressure([0.0, 0.25, 1.0, 1.5], depth=1.0, rho0=1000.0)
    np.testing.assert_allclose(p, [9810.0, 7357.5, 0.0, 0.0])


# ---------------------------------------------------------------- Martin & Moyce


def test_martin_moyce_loader():
    front = ref.martin_moyce("front")
    assert len(front.x) == len(front.y) == 15
    assert (front.x[0], front.y[0]) == (0.41, 1.11)
    assert front.x_name.startswith("T=") and front.y_name.startswith("Z=")
    assert front.width == pytest.approx(0.05715)
    height = ref.martin_moyce("height")
    assert len(height.x) == 17 and height.x_name.startswith("tau=")
    assert np.all(np.diff(height.y) < 0)
    assert len(ref.martin_moyce("front_fig3").x) == 15
    small = ref.martin_moyce("front_fig3_small")
    assert len(small.x) == 10 and small.width == pytest.approx(0.028575)
    assert all(np.all(np.diff(s.x) > 0) for s in (front, height, small))
    with pytest.raises(ValueError, match="unknown series"):
        ref.martin_moyce("Table 2")


def test_time_scales():
    a = 0.05715
    assert ref.front_time_scale(a) == pytest.approx(np.sqrt(2) * ref.height_time_scale(a))
    assert ref.height_time_scale(a, g=1.0) == pytest.approx(1 / np.sqrt(a))


A = 0.05715


def front_history(lead=0.0):
    """A front history (t [s], z [m]) through the Table 2 points, reached ``lead`` earlier in T."""
    table = ref.martin_moyce("front")
    t = np.concatenate([[0.0], (table.x - lead) / ref.front_time_scale(A)])
    return t, np.concatenate([[1.0], table.y]) * A


def test_mean_front_error_of_table_is_zero():
    assert ref.mean_front_error(*front_history(), A) < 1e-12


def test_front_running_ahead_is_corrected_by_positive_shift():
    t, z = front_history(lead=0.15)
    unshifted = ref.mean_front_error(t, z, A)
    assert unshifted > 0.05
    shift, error = ref.best_shift_front_error(t, z, A)
    assert shift == pytest.approx(0.15, abs=1e-9)
    assert error < 1e-9 < unshifted
    assert ref.mean_front_error(t, z, A, shift=-0.1) > unshifted


def test_mean_front_error_needs_three_points():
    t, z = front_history()
    with pytest.raises(ValueError, match="covers 2 points"):
        ref.mean_front_error(t[:3], z[:3], A)
    with pytest.raises(ValueError, match="increasing"):
        ref.mean_front_error(t[::-1], z[::-1], A)


def test_mean_height_error():
    table = ref.martin_moyce("height")
    t = np.concatenate([[0.0], table.x / ref.height_time_scale(A)])
    eta = np.concatenate([[1.0], table.y]) * 2 * A
    assert ref.mean_height_error(t, eta, A) < 1e-12
    # Using the front's time scale by mistake gives a clearly wrong history.
    assert ref.mean_height_error(t * np.sqrt(2), eta, A) > 0.02


def test_front_error_skips_points_beyond_the_tank():
    data = ref.martin_moyce("front")
    scale = ref.front_time_scale(1.0)
    t = np.union1d(np.linspace(0.0, 3.5, 50), data.x) / scale  # the table's knots included
    z = np.minimum(np.interp(t * scale, data.x, data.y, left=1.0), 4.0)  # a 4 a tank stops it
    assert ref.mean_front_error(t, z, 1.0) > 0.005  # the last point (Z = 4.11) counts
    assert ref.mean_front_error(t, z, 1.0, max_z=4.0) < 1e-12


def test_ghia_cavity_centrelines_load_in_order():
    from sphfluid.validation.reference import ghia_cavity

    y, u = ghia_cavity("u_vertical")
    x, v = ghia_cavity("v_horizontal")
    assert len(y) == 17 and len(x) == 17
    assert (np.diff(y) > 0).all() and (np.diff(x) > 0).all()
    assert u[-1] == 1.0 and u[0] == 0.0  # the lid moves at U; the floor rests
    assert u.min() == pytest.approx(-0.21090) and v.min() == pytest.approx(-0.24533)
    with pytest.raises(ValueError, match="unknown series"):
        ghia_cavity("w")


def test_buchner_wall_pressure_loader_and_error():
    t, p = ref.buchner_pressure()
    assert len(t) == 98 and np.all(np.diff(t) >= 0)
    assert 2.0 < t[0] < 2.1 and 7.2 < t[-1] < 7.4
    # the measured curve: quiet before the surge, the first peak near t* 2.75
    assert np.abs(p[t < 2.4]).max() < 0.05
    assert 0.6 < p[(t > 2.6) & (t < 3.0)].max() < 0.8
    assert ref.mean_pressure_error(t, p) == 0.0
    window = (t >= 2.0) & (t <= 7.0)
    zero = ref.mean_pressure_error(np.array([0.0, 10.0]), np.zeros(2))
    assert zero == pytest.approx(np.abs(p[window]).mean())
    # the published delta-SPH against the same points: 0.12 - 0.15
    for series in ("marrone_h40", "marrone_h80", "marrone_h320"):
        ts, ps = ref.buchner_pressure(series)
        assert len(ts) == 525
        assert 0.1 < ref.mean_pressure_error(ts, ps) < 0.15
    with pytest.raises(ValueError, match="unknown series"):
        ref.buchner_pressure("P2")
    with pytest.raises(ValueError, match="fewer than 3"):
        ref.mean_pressure_error(np.array([0.0, 2.05]), np.zeros(2))


def test_wave_number_solves_the_dispersion_relation():
    for period, depth in ((1.0, 0.3), (0.5, 2.0), (10.0, 0.1)):
        k = ref.wave_number(period, depth)
        omega = 2 * np.pi / period
        assert 9.81 * k * np.tanh(k * depth) == pytest.approx(omega**2, rel=1e-12)
    # shallow water: omega = k sqrt(g h); deep: omega^2 = g k
    assert ref.wave_number(100.0, 0.1) == pytest.approx(2 * np.pi / 100 / np.sqrt(9.81 * 0.1),
                                                        rel=1e-3)
    assert ref.wave_number(0.5, 10.0) == pytest.approx((4 * np.pi) ** 2 / 9.81, rel=1e-12)
    with pytest.raises(ValueError):
        ref.wave_number(0.0, 1.0)


def test_piston_height_ratio_has_its_limits():
    """H/S -> kh in shallow water (the piston's volume per stroke spreads over one
    wavelength), -> 2 in deep water; 0.982 at kh = 1 (by hand: 5.524 / 5.627)."""
    assert ref.piston_height_ratio(1e-3) == pytest.approx(1e-3, rel=1e-3)
    assert ref.piston_height_ratio(20.0) == pytest.approx(2.0, rel=1e-12)
    assert ref.piston_height_ratio(1.0) == pytest.approx(
        2 * (np.cosh(2) - 1) / (np.sinh(2) + 2), rel=1e-15)
    assert 0.981 < ref.piston_height_ratio(1.0) < 0.983
    with pytest.raises(ValueError):
        ref.piston_height_ratio(0.0)


def test_channel_velocity_carries_its_mean_and_sticks_to_the_walls():
    """Plane Poiseuille flow with mean U: 0 at both walls, 1.5 U in the middle,
    and its average over the gap U (Simpson's rule is exact for a parabola)."""
    y = np.linspace(0.0, 0.2, 3)
    u = ref.channel_velocity(y, 0.2, 0.3)
    assert u[0] == u[-1] == 0.0 and u[1] == pytest.approx(0.45, rel=1e-15)
    assert (u[0] + 4 * u[1] + u[2]) / 6 == pytest.approx(0.3, rel=1e-15)
