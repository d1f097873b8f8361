"""Reference solutions for the validation cases: analytic formulas and experimental data.

Pure NumPy; nothing here runs the simulator. The formulas follow the validation notes
(Poiseuille start-up, Taylor-Green vortex, 2D droplet, hydrostatic tank) and the
dam-break data are the published measurements of Martin & Moyce (1952).
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from importlib import resources

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "ExperimentalSeries",
    "best_shift_front_error",
    "droplet_damping_rate",
    "droplet_frequency",
    "front_time_scale",
    "ghia_cavity",
    "height_time_scale",
    "hydrostatic_pressure",
    "laplace_pressure_jump",
    "martin_moyce",
    "mean_front_error",
    "mean_height_error",
    "piston_height_ratio",
    "poiseuille_centre_max",
    "poiseuille_velocity",
    "taylor_green_decay",
    "taylor_green_pressure",
    "taylor_green_velocity",
    "wave_number",
]

FloatArray = NDArray[np.float64]

_SERIES_RTOL = 1e-10  # truncation error of the Poiseuille series, relative to F L^2/(8 nu)
_SERIES_CHUNK = 1024  # modes summed per vectorised block (bounds memory for long series)


# --------------------------------------------------------------------------------------
# Poiseuille start-up flow
# --------------------------------------------------------------------------------------


def poiseuille_centre_max(gap: float, nu: float, force: float) -> float:
    """Steady centreline velocity of body-force-driven Poiseuille flow.

    Parameters
    ----------
    gap : float
        Plate spacing L [m].
    nu : float
        Kinematic viscosity [m^2/s].
    force : float
        Body force per unit mass F along the plates [m/s^2].

    Returns
    -------
    float
        ``F L^2 / (8 nu)`` [m/s].
    """
    return force * gap**2 / (8.0 * nu)


def _poiseuille_terms(t: float, gap: float, nu: float) -> int:
    """Number of series terms whose truncation error is below ``_SERIES_RTOL * v0``.

    With first omitted odd mode M and s = pi^2 nu t / L^2, the tail relative to v0 is
    at most (32/pi^3) e^{-M^2 s} (1/M^3 + 1/(4 M^2)) <= (40/pi^3) e^{-M^2 s} min(1, 1/M^2),
    so either bound on M below is sufficient.
    """
    c = 40.0 / (np.pi**3 * _SERIES_RTOL)
    s = np.pi**2 * nu * t / gap**2
    first_omitted = min(np.sqrt(np.log(c) / s), np.sqrt(c))
    return max(0, int(np.ceil((first_omitted - 1.0) / 2.0)))


def poiseuille_velocity(
    y: ArrayLike,
    t: float,
    *,
    gap: float,
    nu: float,
    force: float,
    terms: int | None = None,
) -> FloatArray:
    """Start-up Poiseuille flow driven by a body force (Morris, Fox & Zhu 1997).

    Plates at ``y = 0`` and ``y = gap`` with no slip, fluid at rest at ``t = 0`` and a
    constant body force per unit mass ``force`` along +x for ``t > 0``::

        v_x = F y (L - y) / (2 nu)
              - sum_n 4 F L^2 / (nu pi^3 m^3) sin(m pi y / L) exp(-m^2 pi^2 nu t / L^2),

    with ``m = 2n + 1``. This is the sign-corrected form (positive velocity for a
    positive force); see analytic.md, section 2.

    Parameters
    ----------
    y : array_like
        Wall-normal positions, ``0 <= y <= gap`` [m].
    t : float
        Time since the force was switched on [s]; ``inf`` gives the steady parabola.
    gap : float
        Plate spacing L [m].
    nu : float
        Kinematic viscosity [m^2/s].
    force : float
        Body force per unit mass F [m/s^2].
    terms : int, optional
        Number of series terms. By default it is chosen so that the truncation error is
        below 1e-10 of ``poiseuille_centre_max`` (up to ~6e4 terms as ``t -> 0``).

    Returns
    -------
    ndarray
        Velocity v_x at ``y`` [m/s], same shape as ``y``; exactly zero for ``t <= 0``.
    """
    y = np.asarray(y, dtype=float)
    if t <= 0.0:
        return np.zeros_like(y)
    n_terms = _poiseuille_terms(t, gap, nu) if terms is None else terms
    s = np.pi**2 * nu * t / gap**2
    eta = y / gap
    series = np.zeros_like(y)
    for start in range(0, n_terms, _SERIES_CHUNK):
        m = 2.0 * np.arange(start, min(start + _SERIES_CHUNK, n_terms)) + 1.0
        series += np.sin(np.pi * np.multiply.outer(eta, m)) @ (np.exp(-(m**2) * s) / m**3)
    steady = force / (2.0 * nu) * y * (gap - y)
    return steady - 4.0 * force * gap**2 / (nu * np.pi**3) * series


# --------------------------------------------------------------------------------------
# Taylor-Green vortex
# --------------------------------------------------------------------------------------


def taylor_green_decay(t: ArrayLike, *, length: float = 1.0, nu: float) -> FloatArray:
    """Velocity decay factor of the Taylor-Green vortex, ``exp(-8 pi^2 nu t / L^2)``.

    The maximum speed is ``speed`` times this factor; the kinetic energy decays as its
    square.

    Parameters
    ----------
    t : array_like
        Time [s].
    length : float
        Side L of the periodic box [m].
    nu : float
        Kinematic viscosity [m^2/s].

    Returns
    -------
    ndarray
        The decay factor, same shape as ``t``.
    """
    return np.exp(-8.0 * np.pi**2 * nu * np.asarray(t, dtype=float) / length**2)


def taylor_green_velocity(
    x: ArrayLike, y: ArrayLike, t: float, *, length: float = 1.0, speed: float = 1.0, nu: float
) -> tuple[FloatArray, FloatArray]:
    """Velocity of the 2D Taylor-Green vortex in the periodic box ``[0, L]^2``.

    Exact Navier-Stokes solution (Taylor & Green 1937; setup of Adami, Hu & Adams 2013)::

        u = -U e^{bt} cos(2 pi x / L) sin(2 pi y / L)
        v =  U e^{bt} sin(2 pi x / L) cos(2 pi y / L),   b = -8 pi^2 nu / L^2

    Parameters
    ----------
    x, y : array_like
        Positions [m] (broadcast together).
    t : float
        Time [s].
    length : float
        Side L of the box [m].
    speed : float
        Initial velocity amplitude U [m/s].
    nu : float
        Kinematic viscosity [m^2/s].

    Returns
    -------
    u, v : ndarray
        Velocity components [m/s].
    """
    k = 2.0 * np.pi / length
    kx = k * np.asarray(x, dtype=float)
    ky = k * np.asarray(y, dtype=float)
    amplitude = speed * taylor_green_decay(t, length=length, nu=nu)
    return -amplitude * np.cos(kx) * np.sin(ky), amplitude * np.sin(kx) * np.cos(ky)


def taylor_green_pressure(
    x: ArrayLike,
    y: ArrayLike,
    t: float,
    *,
    length: float = 1.0,
    speed: float = 1.0,
    nu: float,
    rho: float,
) -> FloatArray:
    """Pressure of the 2D Taylor-Green vortex (zero mean; add any constant).

    ``p = -(rho U^2 / 4) e^{2bt} [cos(4 pi x / L) + cos(4 pi y / L)]``, which balances
    the nonlinear term of :func:`taylor_green_velocity`.

    Parameters
    ----------
    x, y : array_like
        Positions [m] (broadcast together).
    t : float
        Time [s].
    length : float
        Side L of the box [m].
    speed : float
        Initial velocity amplitude U [m/s].
    nu : float
        Kinematic viscosity [m^2/s].
    rho : float
        Density [kg/m^3].

    Returns
    -------
    ndarray
        Pressure [Pa].
    """
    k2 = 4.0 * np.pi / length
    amplitude = 0.25 * rho * (speed * taylor_green_decay(t, length=length, nu=nu)) ** 2
    return -amplitude * (np.cos(k2 * np.asarray(x, float)) + np.cos(k2 * np.asarray(y, float)))


# --------------------------------------------------------------------------------------
# 2D droplet
# --------------------------------------------------------------------------------------


def laplace_pressure_jump(sigma: float, radius: float) -> float:
    """Laplace pressure jump ``p_in - p_out = sigma / R`` of a 2D (cylindrical) drop.

    In 2D only one principal curvature is non-zero; the 3D sphere value 2 sigma / R
    does not apply.

    Parameters
    ----------
    sigma : float
        Surface tension coefficient [N/m].
    radius : float
        Drop radius R [m].

    Returns
    -------
    float
        Pressure jump [Pa].
    """
    return sigma / radius


def droplet_frequency(
    sigma: float, rho_inner: float, radius: float, *, mode: int = 2, rho_outer: float = 0.0
) -> float:
    """Angular frequency of small inviscid capillary oscillations of a 2D drop.

    ``omega^2 = n (n^2 - 1) sigma / ((rho_i + rho_o) R^3)``: the planar (cylindrical)
    result, the k -> 0 limit of Rayleigh's (1879) jet dispersion relation. The 3D
    formula n (n - 1) (n + 2) must not be used in 2D.

    Parameters
    ----------
    sigma : float
        Surface tension coefficient [N/m].
    rho_inner : float
        Density of the drop [kg/m^3].
    radius : float
        Drop radius R [m].
    mode : int
        Mode number n >= 2 (n = 2 is the elliptic mode).
    rho_outer : float
        Density of the surrounding fluid [kg/m^3]; 0 for a drop in vacuum.

    Returns
    -------
    float
        omega [rad/s]; the period is ``2 pi / omega``.
    """
    _check_mode(mode)
    return float(np.sqrt(mode * (mode**2 - 1) * sigma / ((rho_inner + rho_outer) * radius**3)))


def wave_number(period: float, depth: float, g: float = 9.81) -> float:
    """k of linear water waves of this period on water this deep: the root of the
    dispersion relation omega^2 = g k tanh(k h), by Newton's method from the
    deep-water value (it converges for every period and depth)."""
    if not (period > 0 and depth > 0 and g > 0):
        raise ValueError("period, depth and g must be > 0")
    omega2 = (2 * np.pi / period) ** 2
    k = max(omega2 / g, np.sqrt(omega2 / (g * depth)))
    for _ in range(100):
        t = np.tanh(k * depth)
        f = g * k * t - omega2
        k_next = k - f / (g * t + g * k * depth * (1 - t * t))
        if abs(k_next - k) <= 1e-14 * k:
            return float(k_next)
        k = k_next
    return float(k)


def piston_height_ratio(kh: float) -> float:
    """H / S of the waves a piston wave maker makes, linear theory (Biesel & Suquet
    1951): 2 (cosh 2kh - 1) / (sinh 2kh + 2kh), H the wave height (crest to
    trough) far from the piston, S its stroke (peak to peak), kh the wave number
    times the depth. It tends to kh in shallow water and to 2 in deep water."""
    if not kh > 0:
        raise ValueError("kh must be > 0")
    two = 2 * kh
    return float(2 * (np.cosh(two) - 1) / (np.sinh(two) + two))


def droplet_damping_rate(nu: float, radius: float, mode: int = 2) -> float:
    """Estimated viscous amplitude decay rate ``1/tau = 2 n (n - 1) nu / R^2`` (2D).

    An estimate only: derived from the dissipation of the potential-flow mode of a drop
    in vacuum at weak viscosity (the same method reproduces Lamb's 3D rate). A viscous
    outer fluid damps faster.

    Parameters
    ----------
    nu : float
        Kinematic viscosity of the drop [m^2/s].
    radius : float
        Drop radius R [m].
    mode : int
        Mode number n >= 2.

    Returns
    -------
    float
        Decay rate 1/tau [1/s] of the amplitude, ``eps(t) ~ exp(-t/tau)``.
    """
    _check_mode(mode)
    return 2.0 * mode * (mode - 1) * nu / radius**2


def _check_mode(mode: int) -> None:
    if mode < 2:
        raise ValueError(f"oscillation mode must be >= 2 (got {mode}); n = 1 is a translation")


# --------------------------------------------------------------------------------------
# Hydrostatic tank
# --------------------------------------------------------------------------------------


def hydrostatic_pressure(
    y: ArrayLike, *, depth: float, rho0: float, g: float = 9.81
) -> FloatArray:
    """Hydrostatic gauge pressure ``rho0 g (H - y)`` below a free surface at ``y = H``.

    Parameters
    ----------
    y : array_like
        Heights above the bottom [m].
    depth : float
        Water depth H [m].
    rho0 : float
        Reference density [kg/m^3].
    g : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    ndarray
        Pressure [Pa], zero at and above the surface.
    """
    return rho0 * g * np.clip(depth - np.asarray(y, dtype=float), 0.0, None)


# --------------------------------------------------------------------------------------
# Dam break: Martin & Moyce (1952)
# --------------------------------------------------------------------------------------

_MM_FILE = "martin_moyce_1952.csv"
_MM_SERIES = {
    "front": "MM_table2_front",
    "height": "MM_table6_height",
    "front_fig3": "MM_fig3_front_a2.25in",
    "front_fig3_small": "MM_fig3_front_a1.125in",
}


@dataclass(frozen=True)
class ExperimentalSeries:
    """One measured curve ``y(x)`` with its axis names.

    Attributes
    ----------
    name : str
        Series name in the data file.
    x_name, y_name : str
        Definitions of the non-dimensional axes.
    width : float
        Column width a of the experiment [m].
    x, y : ndarray
        The data points, in increasing ``x``.
    """

    name: str
    x_name: str
    y_name: str
    width: float
    x: FloatArray
    y: FloatArray


def martin_moyce(series: str = "front") -> ExperimentalSeries:
    """Dam-break measurements of Martin & Moyce (1952), column height 2a.

    Martin, J. C. & Moyce, W. J. (1952), Phil. Trans. R. Soc. Lond. A 244:312-324.

    Parameters
    ----------
    series : {"front", "height", "front_fig3", "front_fig3_small"}
        ``"front"``: Table 2, surge front Z = z/a against T = t sqrt(2g/a) (a = 2.25 in).
        ``"height"``: Table 6, residual height H = eta/(2a) against tau = t sqrt(g/a).
        ``"front_fig3"`` / ``"front_fig3_small"``: front digitised from Figure 3 for
        a = 2.25 in / 1.125 in, reaching later times than the table (error ~0.05 in T).

    Returns
    -------
    ExperimentalSeries
    """
    if series not in _MM_SERIES:
        raise ValueError(f"unknown series {series!r}; expected one of {sorted(_MM_SERIES)}")
    name = _MM_SERIES[series]
    text = (resources.files("sphfluid.validation") / "data" / _MM_FILE).read_text("utf-8")
    data_lines = (line for line in io.StringIO(text) if not line.startswith("#"))
    rows = [row for row in csv.DictReader(data_lines) if row["series"] == name]
    return ExperimentalSeries(
        name=name,
        x_name=rows[0]["x_name"],
        y_name=rows[0]["y_name"],
        width=float(rows[0]["a_m"]),
        x=np.array([float(row["x"]) for row in rows]),
        y=np.array([float(row["y"]) for row in rows]),
    )


def front_time_scale(a: float, g: float = 9.81) -> float:
    """Factor ``sqrt(2 g / a)`` turning time t [s] into the front's T = t sqrt(2g/a).

    Martin & Moyce scale the front time with n sqrt(g/a), n^2 = 2 being the column's
    height-to-width ratio; the height time :func:`height_time_scale` has no factor n.
    """
    return float(np.sqrt(2.0 * g / a))


def height_time_scale(a: float, g: float = 9.81) -> float:
    """Factor ``sqrt(g / a)`` turning time t [s] into the height's tau = t sqrt(g/a).

    Unlike :func:`front_time_scale` there is no factor n = sqrt(2).
    """
    return float(np.sqrt(g / a))


def mean_front_error(
    t: ArrayLike, z: ArrayLike, a: float, *, shift: float = 0.0, g: float = 9.81,
    max_z: float = np.inf,
) -> float:
    """Mean |Z_sim - Z_MM| of a simulated surge front against Martin & Moyce Table 2.

    The simulated history becomes the points ``(t sqrt(2g/a) + shift, z/a)``: a positive
    ``shift`` delays the simulation, as if its clock started later, which compensates for
    the lag of a real dam release (authors use +0.1 to 0.2; Lethe +0.175). Z_sim is
    interpolated linearly at the table's T values. Only table points inside the shifted
    simulated time range are used, so a run is judged only up to its last time.

    Parameters
    ----------
    t : array_like
        Increasing simulation times [s].
    z : array_like
        Front position measured from the back wall [m], one per time.
    a : float
        Initial column width [m].
    shift : float
        Shift added to the simulated T (non-dimensional).
    g : float
        Gravitational acceleration [m/s^2].
    max_z : float
        Only table points with Z below this are used: a tank of length L stops the
        front at Z = L/a, so points beyond it (Martin & Moyce's tank was longer)
        cannot be compared.

    Returns
    -------
    float
        Mean absolute error in Z = z/a.

    Raises
    ------
    ValueError
        If the inputs are malformed or fewer than 3 table points are covered.
    """
    x_sim = np.asarray(t, dtype=float) * front_time_scale(a, g) + shift
    ref = martin_moyce("front")
    return _mean_abs_error(x_sim, np.asarray(z, dtype=float) / a, ref, ref.y < max_z)


def best_shift_front_error(
    t: ArrayLike, z: ArrayLike, a: float, shifts: ArrayLike | None = None, *, g: float = 9.81,
    max_z: float = np.inf,
) -> tuple[float, float]:
    """The shift (from ``shifts``) minimising :func:`mean_front_error`, and that error.

    Parameters
    ----------
    t, z, a, g, max_z
        As for :func:`mean_front_error`.
    shifts : array_like, optional
        Candidate shifts of the simulated T; default ``np.linspace(0, 0.3, 31)``.
        Every candidate must cover at least 3 table points. On a tie the smallest
        listed first wins.

    Returns
    -------
    best_shift, error : float
    """
    candidates = np.linspace(0.0, 0.3, 31) if shifts is None else np.asarray(shifts, float)
    errors = [mean_front_error(t, z, a, shift=float(s), g=g, max_z=max_z) for s in candidates]
    best = int(np.argmin(errors))
    return float(candidates[best]), errors[best]


def mean_height_error(
    t: ArrayLike, eta: ArrayLike, a: float, *, shift: float = 0.0, g: float = 9.81
) -> float:
    """Mean |H_sim - H_MM| of a simulated residual column height against Table 6.

    Like :func:`mean_front_error`, with H = eta / (2a) sampled at
    ``tau = t sqrt(g/a) + shift`` (``shift`` is in units of tau, not T).

    Parameters
    ----------
    t : array_like
        Increasing simulation times [s].
    eta : array_like
        Height of the fluid at the back wall [m], one per time.
    a : float
        Initial column width [m] (the initial height is 2a).
    shift : float
        Shift added to the simulated tau.
    g : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    float
        Mean absolute error in H.

    Raises
    ------
    ValueError
        If the inputs are malformed or fewer than 3 table points are covered.
    """
    x_sim = np.asarray(t, dtype=float) * height_time_scale(a, g) + shift
    return _mean_abs_error(x_sim, np.asarray(eta, dtype=float) / (2.0 * a), martin_moyce("height"))


def _mean_abs_error(x_sim: FloatArray, y_sim: FloatArray, ref: ExperimentalSeries,
                    use: NDArray[np.bool_] | None = None) -> float:
    """Mean |y_sim(x) - y_ref| over the reference points inside ``[x_sim[0], x_sim[-1]]``
    (and in ``use``, when given)."""
    if x_sim.ndim != 1 or x_sim.shape != y_sim.shape or x_sim.size < 2:
        raise ValueError("times and values must be 1D arrays of the same length (>= 2)")
    if np.any(np.diff(x_sim) <= 0.0):
        raise ValueError("times must be strictly increasing")
    covered = (ref.x >= x_sim[0]) & (ref.x <= x_sim[-1])
    if use is not None:
        covered &= use
    if np.count_nonzero(covered) < 3:
        raise ValueError(
            f"the simulated history covers {np.count_nonzero(covered)} points of "
            f"{ref.name} (at least 3 needed; the data span {ref.x[0]}..{ref.x[-1]})"
        )
    y_at_ref = np.interp(ref.x[covered], x_sim, y_sim)
    return float(np.mean(np.abs(y_at_ref - ref.y[covered])))


# --------------------------------------------------------------------------------------
# Lid-driven cavity
# --------------------------------------------------------------------------------------

# --------------------------------------------------------------------------------------
# Dam break against a wall: pressure at the far wall (Buchner 2002)
# --------------------------------------------------------------------------------------

_BUCHNER_FILE = "buchner_2002_p1.csv"
BUCHNER_SERIES = ("buchner_P1", "marrone_h40", "marrone_h80", "marrone_h320")


def buchner_pressure(series: str = "buchner_P1") -> tuple[FloatArray, FloatArray]:
    """Pressure at sensor P1 on the far wall of the dam break of Buchner (2002),
    ``(t_star, p_star)`` in increasing t_star = t sqrt(g/H), p_star = p / (rho g H).

    ``"buchner_P1"`` is the experiment (Buchner, PhD thesis, TU Delft, 2002; the
    set-up of Zhou, De Kat & Buchner 1999); ``"marrone_h40"`` etc. the delta-SPH
    results of Marrone et al. (2011, CMAME 200:1526) at H/dx = 40, 80, 320. Both
    digitised from the published plots (the data file's header says by whom).
    """
    return _series_xy(_BUCHNER_FILE, series, BUCHNER_SERIES, "t_star", "p_star")


def _series_xy(filename: str, series: str, known, x: str, y: str
               ) -> tuple[FloatArray, FloatArray]:
    """Columns x and y of a packaged data file's rows of one series, in
    increasing x (a stable sort: digitised points keep their order on ties)."""
    if series not in known:
        raise ValueError(f"unknown series {series!r}; expected one of {list(known)}")
    text = (resources.files("sphfluid.validation") / "data" / filename).read_text("utf-8")
    rows = [row for row in csv.DictReader(line for line in io.StringIO(text)
                                          if not line.startswith("#"))
            if row["series"] == series]
    xs = np.array([float(r[x]) for r in rows])
    ys = np.array([float(r[y]) for r in rows])
    order = np.argsort(xs, kind="stable")
    return xs[order], ys[order]


def mean_pressure_error(t_star: ArrayLike, p_star: ArrayLike,
                        window: tuple[float, float] = (2.0, 7.0)) -> float:
    """Mean |p_sim - p_exp| / (rho g H) over Buchner's P1 points with t_star in
    window (and within the simulated times), p_sim interpolated linearly."""
    t = np.asarray(t_star, dtype=float)
    p = np.asarray(p_star, dtype=float)
    te, pe = buchner_pressure("buchner_P1")
    use = (te >= window[0]) & (te <= window[1]) & (te >= t[0]) & (te <= t[-1])
    if use.sum() < 3:
        raise ValueError("the simulated times cover fewer than 3 of the measured points")
    return float(np.mean(np.abs(np.interp(te[use], t, p) - pe[use])))


_GHIA_FILE = "ghia_1982_re100.csv"
_GHIA_SERIES = ("u_vertical", "v_horizontal")


def ghia_cavity(series: str) -> tuple[FloatArray, FloatArray]:
    """Centreline velocities of the lid-driven cavity at Re = 100 (Ghia, Ghia & Shin 1982).

    Ghia, U., Ghia, K. N. & Shin, C. T. (1982), J. Comput. Phys. 48:387-411, Tables I and II.

    Parameters
    ----------
    series : {"u_vertical", "v_horizontal"}
        ``"u_vertical"``: u / U on the vertical centreline against y / L (the lid at 1).
        ``"v_horizontal"``: v / U on the horizontal centreline against x / L.

    Returns
    -------
    (coordinate, velocity) : tuple of arrays, in increasing coordinate
    """
    return _series_xy(_GHIA_FILE, series, _GHIA_SERIES, "coordinate", "velocity")


def channel_velocity(y, gap: float, mean: float):
    """Plane Poiseuille flow between walls at y = 0 and y = gap carrying the mean
    velocity `mean`: u = 1.5 mean (1 - (2y/gap - 1)^2)."""
    eta = 2 * np.asarray(y, float) / gap - 1
    return 1.5 * mean * (1 - eta**2)
