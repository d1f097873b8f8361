"""Brute-force O(N^2) NumPy evaluation of the seed's equations (docs/method-seed.md), for tests.

Written from docs/method-seed.md independently of the C++ core: every pair is evaluated,
no cell grid, no neighbour list.
"""
from __future__ import annotations

import numpy as np


def poly6(r2, h):
    d = np.clip(h * h - r2, 0.0, None)
    return 4.0 / (np.pi * h**8) * d**3


def separations(x, period=None):
    """r_ij = x_i - x_j for every pair; along an axis with a period L (period =
    (Lx or None, Ly or None)) the nearest image is taken."""
    r = x[:, None, :] - x[None, :, :]
    for axis, length in enumerate(period or (None, None)):
        if length is not None:
            r[..., axis] -= length * np.round(r[..., axis] / length)
    return r


def seed_forces(x, v, *, h, m, rho0, k, eta=0.0, sigma=0.0, threshold=None,
                gravity=(0.0, -9.81), ghosts=None, ghost_mass=None, ghost_density=None,
                period=None):
    """Density, pressure and acceleration of every particle (docs/method-seed.md).

    ghosts: optional list (per particle) of (g, 2) arrays of wall ghost positions.
    period: optional periodic box lengths (see separations).
    """
    n = len(x)
    r = separations(x, period)                 # r_ij = x_i - x_j
    r2 = (r**2).sum(-1)
    rl = np.sqrt(r2)
    inside = r2 < h * h
    rho = (m * poly6(r2, h) * inside).sum(1)    # eq. 10, j = i included
    gm = m if ghost_mass is None else ghost_mass
    gd = rho0 if ghost_density is None else ghost_density
    if ghosts is not None:
        for i in range(n):
            for g in ghosts[i]:
                rho[i] += gm * poly6(((x[i] - g) ** 2).sum(), h)
    p = k * (rho - rho0)                        # eq. 15

    with np.errstate(divide="ignore", invalid="ignore"):
        unit = np.where(rl[..., None] > 0, r / rl[..., None], 0.0)
    dspiky = -30.0 / (np.pi * h**5) * np.clip(h - rl, 0.0, None) ** 2
    grad_spiky = dspiky[..., None] * unit
    lap_visc = 40.0 / (np.pi * h**5) * np.clip(h - rl, 0.0, None)

    coef = m * (p[:, None] + p[None, :]) / (2.0 * rho[None, :])
    f = -(coef[..., None] * grad_spiky).sum(1)                              # eq. 14
    if eta > 0:
        dv = v[None, :, :] - v[:, None, :]                                  # v_j - v_i
        f += eta * ((m / rho[None, :] * lap_visc)[..., None] * dv).sum(1)   # eq. 17
    if ghosts is not None:
        for i in range(n):
            for g in ghosts[i]:
                rg = x[i] - g
                d = np.sqrt((rg**2).sum())
                if d >= h:
                    continue
                pw = max(p[i], 0.0)  # walls push, never pull
                if d > 0:
                    gs = -30.0 / (np.pi * h**5) * (h - d) ** 2 * rg / d
                    f[i] -= gm * (pw + pw) / (2.0 * gd) * gs
                if eta > 0:
                    f[i] -= eta * gm / gd * 40.0 / (np.pi * h**5) * (h - d) * v[i]
    if sigma > 0:
        d = np.clip(h * h - r2, 0.0, None)
        grad_c = -24.0 / (np.pi * h**8) * d[..., None] ** 2 * r
        lap_c = -48.0 / (np.pi * h**8) * d * (h * h - 3.0 * r2)
        vol = m / rho[None, :]
        nrm = (vol[..., None] * grad_c).sum(1)                              # eq. 18, grad
        lap = (vol * lap_c).sum(1)
        size = np.linalg.norm(nrm, axis=1)
        thr = 0.323 / h if threshold is None else threshold
        on = size > thr
        f[on] -= sigma * (lap[on] / size[on])[:, None] * nrm[on]            # eq. 20
    a = f / rho[:, None] + np.asarray(gravity)
    return rho, p, a


def wendland_grad(r, h):
    """grad W of the Wendland C2 kernel with support h, for offsets r (..., 2)."""
    rl = np.sqrt((r**2).sum(-1))
    q = np.clip(1.0 - rl / h, 0.0, None)
    return (-140.0 / (np.pi * h**4) * q**3)[..., None] * r


QUINTIC_SUPPORT = 2.8  # W31's support, spacings


def quintic_grad(r, h):
    """grad W of the quintic spline with support h (3 smoothing lengths; W31),
    for offsets r (..., 2): W = 7 / (478 pi (h/3)^2) [(3-s)^5 - 6 (2-s)^5 + 15 (1-s)^5]
    with s = 3 |r| / h, each power where its base is positive."""
    rl = np.sqrt((r**2).sum(-1))
    s = 3.0 * rl / h
    a, b, c = (np.clip(k - s, 0.0, None) for k in (3.0, 2.0, 1.0))
    dw = 7.0 / (478.0 * np.pi) * (3.0 / h) ** 3 * (-5 * a**4 + 30 * b**4 - 75 * c**4)  # W'(r)
    return (dw / np.where(rl > 0, rl, 1.0))[..., None] * r


def wendland(r, h):
    q = np.clip(1.0 - r / h, 0.0, None)
    return 7.0 / (np.pi * h**2) * q**4 * (1.0 + 4.0 * (r / h)) * (r < h)


def wcsph_forces(x, v, *, h, m, rho0, c0, alpha, eta=0.0, gravity=(0.0, -9.81), period=None,
                 background_pressure=0.0):
    """Density, pressure and acceleration under the wcsph method with no walls:
    summation density (Wendland C2, support h), Tait EOS clamped at rho0,
    symmetric pressure gradient, Monaghan's artificial viscosity and Morris'
    viscosity (docs/method-wcsph.md)."""
    r = separations(x, period)
    r2 = (r**2).sum(-1)
    rho = (m * wendland(np.sqrt(r2), h)).sum(1)
    B = rho0 * c0**2 / 7.0
    p = np.maximum(B * ((rho / rho0) ** 7 - 1.0) + background_pressure, 0.0)
    gw = wendland_grad(r, h)
    vij = v[:, None, :] - v[None, :, :]
    hs, eps2 = 0.5 * h, 0.01 * (0.5 * h) ** 2
    vr = (vij * r).sum(-1)
    rho_bar = 0.5 * (rho[:, None] + rho[None, :])
    pi_ij = np.where(vr < 0, -alpha * c0 * hs * vr / (r2 + eps2) / rho_bar, 0.0)
    coef = p[:, None] / rho[:, None] ** 2 + p[None, :] / rho[None, :] ** 2 + pi_ij
    a = -(m * coef[..., None] * gw).sum(1)
    if eta > 0:
        rg = (r * gw).sum(-1)
        visc = (m * 2 * eta / (rho[:, None] * rho[None, :]) * rg / (r2 + eps2))[..., None] * vij
        a += visc.sum(1)
    return rho, p, a + np.asarray(gravity)


def delta_rate(x, v, rho, *, h, m, rho0, c0, delta, gravity=(0.0, -9.81), period=None):
    """d rho / dt of wcsph with the continuity density and no walls
    (docs/method-wcsph.md, W17-W18): rho_i sum_j V_j v_ij . grad W_ij plus the
    diffusion delta hs c0 sum_j psi_ij (r_ji . grad W_ij)/r^2 V_j with
    psi_ij = 2 [(rho_j - rho_i) + rho0 g . r_ij / c0^2]."""
    r = separations(x, period)
    r2 = (r**2).sum(-1)
    gw = wendland_grad(r, h)
    vij = v[:, None, :] - v[None, :, :]
    vol = m / rho
    rate = rho * ((vij * gw).sum(-1) * vol[None, :]).sum(1)
    psi = 2.0 * ((rho[None, :] - rho[:, None]) + rho0 * (r @ np.asarray(gravity)) / c0**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        rg = np.where(r2 > 0, (-r * gw).sum(-1) / r2, 0.0)
    rate += delta * 0.5 * h * c0 * (psi * rg * vol[None, :]).sum(1)
    return rate


def kernel_sums(x, *, h, m, rho0, period=None):
    """(m / rho0) sum_j W_ij, j = i included: W26's free-surface test."""
    r = separations(x, period)
    return m / rho0 * wendland(np.sqrt((r**2).sum(-1)), h).sum(1)


def surface_floor(x, rho, *, h, m, rho0, period=None):
    """W26: where the kernel sum is below 0.95, the density is at least rho0."""
    sums = kernel_sums(x, h=h, m=m, rho0=rho0, period=period)
    return np.where((sums < 0.95) & (rho < rho0), rho0, rho)


def pressure_held(x, rho, *, h, m, rho0, period=None):
    """W26b: where the pressure is floored at 0: a kernel sum S below 0.95,
    or a density below rho0 (S - 0.05) (stretched spray that gathered)."""
    sums = kernel_sums(x, h=h, m=m, rho0=rho0, period=period)
    return (sums < 0.95) | (rho < rho0 * (sums - 0.05))


def shift(x, v, rho, *, h, m, rho0, k, dt, period=None):
    """W21 without walls: dr_i = -k U dt hs sum_j [1 + 0.2 (W_ij / W(dx))^4] grad W_ij V_j,
    U the largest speed, dx = sqrt(m / rho0); where the kernel sum (m / rho0)
    sum_j W_ij (j = i included) is below 0.95 only the part across the colour
    gradient sum_j V_j grad W_ij; at most 0.2 dx and U dt."""
    r = separations(x, period)
    rl = np.sqrt((r**2).sum(-1))
    gw = wendland_grad(r, h)
    vol = m / rho
    dx = np.sqrt(m / rho0)
    w = wendland(rl, h) / wendland(np.array(dx), h)
    np.fill_diagonal(w, 0.0)
    s = (((1.0 + 0.2 * w**4) * vol[None, :])[..., None] * gw).sum(1)
    colour = (vol[None, :, None] * gw).sum(1)
    speed = np.sqrt((v**2).sum(1)).max()
    d = -k * speed * dt * 0.5 * h * s
    surface = m / rho0 * wendland(rl, h).sum(1) < 0.95
    n = colour / np.maximum(np.hypot(*colour.T), 1e-300)[:, None]
    d[surface] -= (d[surface] * n[surface]).sum(1)[:, None] * n[surface]
    size = np.hypot(*d.T)
    cap = min(0.2 * dx, speed * dt)
    return d * np.minimum(1.0, cap / np.maximum(size, 1e-300))[:, None]


def shift_rate(x, rho, du, *, h, m, period=None):
    """W27: the shift's share of d rho / dt for particles moved at du on top of
    the flow, sum_j V_j [2 rho_i du_i + (rho_j - rho_i) du_j] . grad W_ij."""
    r = separations(x, period)
    gw = wendland_grad(r, h)
    vol = m / rho
    a = 2.0 * rho[:, None, None] * du[:, None, :] + (rho[None, :] - rho[:, None])[..., None] * du[None, :, :]
    return ((a * gw).sum(-1) * vol[None, :]).sum(1)


def laplacian_sums(x, rho, *, h, m, period=None):
    """sum_j V_j F_ij r_ij^2 of each particle (W24; grad W = F r)."""
    r = separations(x, period)
    r2 = (r**2).sum(-1)
    rl = np.sqrt(r2)
    F = np.where(rl < h, -140.0 / (np.pi * h**4) * np.clip(1.0 - rl / h, 0.0, None) ** 3, 0.0)
    np.fill_diagonal(F, 0.0)
    return (F * r2 * (m / rho)[None, :]).sum(1)


def continuity_alpha(alpha, eta, rho0, hs, c0):
    """W28: the scene's alpha less the physical viscosity's equivalent
    8 nu / (hs c0), not below 0."""
    return max(0.0, alpha - 8.0 * eta / (rho0 * hs * c0))


def gradient_normalisation(h, dx, vol, grad=wendland_grad):
    """W29's S: sum over the square lattice's points y of -V F(|y|) y_2^2, with
    grad W = F(r) r (the continuum's value is 1); grad: the kernel's gradient."""
    k = np.arange(-int(np.ceil(h / dx)), int(np.ceil(h / dx)) + 1) * dx
    y = np.stack(np.meshgrid(k, k), -1).reshape(-1, 2)
    return float(-(vol * grad(y, h)[:, 1] * y[:, 1]).sum())


def reconstruction_strain(x, v, rho, *, h, m, period=None):
    """W30: each particle's strain (e_xx, e_yy, e_xy) for the artificial
    viscosity's reconstruction: G = sum_j V_j (v_j - v_i) (x) grad W_ij / t with
    t = -1/2 sum_j V_j F_ij r_ij^2 (none where t <= 1/2), its symmetric part E
    times max(0, (|E|^2 - |Omega|^2) / (|E|^2 + |Omega|^2)), Omega the
    antisymmetric part."""
    r = separations(x, period)
    r2 = (r**2).sum(-1)
    gw = wendland_grad(r, h)
    vol = m / rho
    dv = v[None, :, :] - v[:, None, :]  # v_j - v_i
    g = np.einsum("ij,ija,ijb->iab", np.broadcast_to(vol[None, :], r2.shape), dv, gw)
    t = -0.5 * laplacian_sums(x, rho, h=h, m=m, period=period)
    ok = t > 0.5
    G = g / np.where(ok, t, 1.0)[:, None, None]
    E = 0.5 * (G + G.transpose(0, 2, 1))
    Om = 0.5 * (G - G.transpose(0, 2, 1))
    e2, w2 = (E**2).sum((1, 2)), (Om**2).sum((1, 2))
    share = np.where(e2 > w2, (e2 - w2) / np.where(e2 + w2 > 0, e2 + w2, 1.0), 0.0)
    E = E * (share * ok)[:, None, None]
    return E[:, 0, 0], E[:, 1, 1], E[:, 0, 1]


def delta_forces(x, v, rho, *, h, m, rho0, c0, alpha, eta=0.0, gravity=(0.0, -9.81),
                 period=None, background_pressure=0.0, lap_sums=None, spacing=None,
                 held=None, strain=None, quintic=False):
    """Pressure and acceleration of wcsph with the continuity density and no
    walls (W19 with W4-W5, W24, W29): Tait without the clamp, the sum form
    (p_i + p_j)/(rho_i rho_j) of the pressure term divided by the lattice's
    gradient normalisation S (spacing sqrt(m / rho0) by default), the viscous term
    2 m eta/(rho_i rho_j) F_ij v_ij (c_i + c_j)/2 with c = -2 / lap_sums
    (laplacian_sums of these positions and densities by default). `held`:
    where the pressure is not below 0 (W26b; pressure_held). `strain`: W30's
    (reconstruction_strain's; None: no reconstruction), whose linear part of v_ij . r_ij,
    the one of a_i = r_ij . E_i r_ij and a_j nearer zero where both are negative,
    times q^2 (3 - 2q) with q = (r^2/dx^2 - 1/4) / (3/4) in [0, 1], the
    artificial viscosity leaves out. `quintic`: the pressure's part on the
    quintic spline of support 2.8 dx with its own S (W31: the core's with
    quintic_pressure, where nothing shifts)."""
    r = separations(x, period)
    r2 = (r**2).sum(-1)
    B = rho0 * c0**2 / 7.0
    p = B * ((rho / rho0) ** 7 - 1.0) + background_pressure
    if held is not None:
        p = np.where(held & (p < 0.0), 0.0, p)
    gw = wendland_grad(r, h)
    vij = v[:, None, :] - v[None, :, :]
    hs = 0.5 * h
    eps2 = 0.01 * hs**2
    vr = (vij * r).sum(-1)
    rho_bar = 0.5 * (rho[:, None] + rho[None, :])
    alpha = continuity_alpha(alpha, eta, rho0, hs, c0)
    dx = np.sqrt(m / rho0) if spacing is None else spacing
    if alpha > 0 and strain is not None:
        exx, eyy, exy = strain
        def linear(xx, yy, xy):
            return xx[:, None] * r[..., 0] ** 2 + yy[:, None] * r[..., 1] ** 2 + \
                2 * xy[:, None] * r[..., 0] * r[..., 1]
        ai, aj = linear(exx, eyy, exy), linear(exx, eyy, exy).T
        lin = np.where((ai < 0) & (aj < 0), np.maximum(ai, aj), 0.0)  # minmod, approaching
        q = np.clip((r2 / dx**2 - 0.25) / 0.75, 0.0, 1.0)  # closer than dx: in part
        vr = vr - lin * q**2 * (3 - 2 * q)
    pi_ij = np.where(vr < 0, -alpha * c0 * hs * vr / (r2 + eps2) / rho_bar, 0.0)
    pressure = (p[:, None] + p[None, :]) / (rho[:, None] * rho[None, :])
    if quintic:  # W31
        hp = QUINTIC_SUPPORT * dx
        S = gradient_normalisation(hp, dx, m / rho0, quintic_grad)
        a = -(m * (pressure / S)[..., None] * quintic_grad(r, hp)).sum(1) - \
            (m * pi_ij[..., None] * gw).sum(1)
    else:
        S = gradient_normalisation(h, dx, m / rho0)
        coef = pressure / S + pi_ij
        a = -(m * coef[..., None] * gw).sum(1)
    if eta > 0:
        if lap_sums is None:
            lap_sums = laplacian_sums(x, rho, h=h, m=m, period=period)
        c = np.where(lap_sums < 0, -2.0 / np.where(lap_sums < 0, lap_sums, -1.0), 1.0)
        rl = np.sqrt(r2)
        F = np.where(rl < h, -140.0 / (np.pi * h**4) * np.clip(1.0 - rl / h, 0.0, None) ** 3,
                     0.0)
        k = m * 2 * eta / (rho[:, None] * rho[None, :]) * F * 0.5 * (c[:, None] + c[None, :])
        a += (k[..., None] * vij).sum(1)
    return p, a + np.asarray(gravity)
