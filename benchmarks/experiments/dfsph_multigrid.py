"""dfsph: would a multigrid preconditioner carry a tall column's pressure in few
iterations? The solves' matrix M = R R^T (D4 of D5, dt = 1) is built with
SciPy for a column of water W x H particles on the lattice in a box (three
layers of wall particles standing in for the walls' share, D2), the top row
left out (the free surface, where k = 0); its right side is the error of one
step's fall under gravity. Preconditioned conjugate gradients solve it to a
residual of `tol` (relative, summed |r|) with (a) M's diagonal, as the solver
does, and (b) a V-cycle of aggregation multigrid: 2 x 2 particles (a cell of
the search) to a coarse unknown, then 2 x 2 coarse ones, Galerkin coarse
matrices P^T A P, damped Jacobi smoothing, a direct solve at the top
(docs/method-dfsph.md, "Not yet"). Prints the iterations of each, then the
solution across a row and M's smallest eigenvalues with their modes.

    pip install scipy
    python benchmarks/experiments/dfsph_multigrid.py [W H [omega sweeps scale]]
"""
from __future__ import annotations

import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy.spatial import cKDTree

DX = 0.01
H_SUPPORT = 2 * DX  # the default support: two spacings
MASS = 1000.0 * DX * DX


def gradient_factor(r: np.ndarray) -> np.ndarray:
    """Wendland C2 in 2D with support H_SUPPORT: W'(r) / r."""
    q = r / H_SUPPORT
    alpha = 7.0 / (np.pi * H_SUPPORT**2)
    return np.where(q < 1, alpha * (-20.0 * q * (1 - q) ** 3) / H_SUPPORT**2, 0.0)


def column(width: int, height: int):
    """The fluid's positions (n, 2) and the rate matrix R (n, 2n) of D4, walls
    as particles at rest (they add to a particle's own column only)."""
    i, j = np.meshgrid(np.arange(width), np.arange(height))
    fluid = np.c_[(i.ravel() + 0.5) * DX, (j.ravel() + 0.5) * DX]
    walls = []
    for layer in range(3):
        walls += [((k + 0.5) * DX, -(layer + 0.5) * DX) for k in range(-3, width + 3)]
        for k in range(height + 5):
            walls += [(-(layer + 0.5) * DX, (k + 0.5) * DX),
                      ((width + layer + 0.5) * DX, (k + 0.5) * DX)]
    points = np.r_[fluid, np.array(walls)]
    n = len(fluid)
    pairs = cKDTree(points).query_pairs(H_SUPPORT * (1 - 1e-9), output_type="ndarray")
    a, b = pairs[:, 0], pairs[:, 1]
    r = points[a] - points[b]
    mg = (MASS * gradient_factor(np.hypot(r[:, 0], r[:, 1])))[:, None] * r
    rows, cols, vals = [], [], []
    for p, q, sign in ((a, b, 1.0), (b, a, -1.0)):  # rate_p = sum (u_p - u_q) . mg_pq
        keep = p < n
        for c in range(2):
            g = sign * mg[keep, c]
            rows += [p[keep], p[keep]]
            cols += [2 * p[keep] + c, 2 * q[keep] + c]
            vals += [g, -g]
    rows, cols, vals = (np.concatenate(x) for x in (rows, cols, vals))
    fluid_cols = cols < 2 * n  # the walls' velocities are 0
    R = sp.csr_matrix((vals[fluid_cols], (rows[fluid_cols], cols[fluid_cols])),
                      shape=(n, 2 * n))
    return fluid, R


def aggregation(cells: np.ndarray):
    """P (n, m): each unknown to the coarse one of its cell; the coarse cells."""
    key = cells[:, 0] * 1_000_000 + cells[:, 1]
    unique, agg = np.unique(key, return_inverse=True)
    P = sp.csr_matrix((np.ones(len(agg)), (np.arange(len(agg)), agg)),
                      shape=(len(agg), len(unique)))
    return P, np.c_[unique // 1_000_000, unique % 1_000_000]


def main() -> None:
    args = sys.argv[1:]
    width, height = (int(args[0]), int(args[1])) if len(args) >= 2 else (40, 200)
    omega = float(args[2]) if len(args) > 2 else 0.8
    sweeps = int(args[3]) if len(args) > 3 else 2
    scale = float(args[4]) if len(args) > 4 else 1.8
    x, R = column(width, height)
    active = x[:, 1] < (height - 1) * DX  # the top row is the free surface
    A = (R @ R.T).tocsr()[active][:, active].tocsr()
    g = np.zeros(R.shape[1])
    g[1::2] = -9.81e-3  # one step's fall, dt = 1 ms
    e = -(R @ g)[active]
    levels, prolong = [A], []
    cells = np.floor(x[active] / H_SUPPORT).astype(np.int64)
    while levels[-1].shape[0] > 50:
        P, cells = aggregation(cells)
        prolong.append(P)
        levels.append((P.T @ levels[-1] @ P).tocsr())
        cells = cells // 2
    inverse_diagonals = [1.0 / L.diagonal() for L in levels]
    coarsest = sla.factorized(levels[-1].tocsc())

    def v_cycle(level: int, b: np.ndarray) -> np.ndarray:
        if level == len(levels) - 1:
            return coarsest(b)
        L, d = levels[level], inverse_diagonals[level]
        z = omega * d * b
        for _ in range(sweeps - 1):
            z += omega * d * (b - L @ z)
        z += scale * (prolong[level] @ v_cycle(level + 1, prolong[level].T @ (b - L @ z)))
        for _ in range(sweeps):
            z += omega * d * (b - L @ z)
        return z

    def pcg(precondition, tol: float, most: int = 5000) -> int:
        z_k = np.zeros_like(e)
        r = e.copy()
        z = precondition(r)
        p, rz = z.copy(), r @ z
        target = tol * np.abs(e).sum()
        for k in range(most):
            Ap = A @ p
            alpha = rz / (p @ Ap)
            z_k += alpha * p
            r -= alpha * Ap
            if np.abs(r).sum() <= target:
                return k + 1
            z = precondition(r)
            rz, previous = r @ z, rz
            p = z + rz / previous * p
        return most

    print(f"{width} x {height} particles, levels {[L.shape[0] for L in levels]}, "
          f"{A.nnz / A.shape[0]:.1f} entries a row")
    for tol in (1e-2, 1e-3):
        t0 = time.perf_counter()
        jacobi = pcg(lambda r: inverse_diagonals[0] * r, tol)
        t1 = time.perf_counter()
        multigrid = pcg(lambda r: v_cycle(0, r), tol)
        t2 = time.perf_counter()
        print(f"tol {tol:g}: diagonal {jacobi} iterations ({t1 - t0:.2f} s), "
              f"multigrid {multigrid} ({t2 - t1:.2f} s)")
    solution = sla.spsolve(A.tocsc(), e)
    xa = x[active]
    row = np.abs(xa[:, 1] - 20.5 * DX) < 1e-9
    print("the solution across row 20 (over its mean):",
          np.round(solution[row] / solution[row].mean(), 2))
    values, modes = sla.eigsh(A, k=4, sigma=0, which="LM")
    print("smallest eigenvalues / mean diagonal:", values / A.diagonal().mean())
    for v in modes.T[:2]:
        print("  its mode across row 20:", np.round(v[row][:8] / np.abs(v).max(), 2))


if __name__ == "__main__":
    main()
