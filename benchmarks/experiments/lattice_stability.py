"""Is the square lattice under a uniform pressure stable with wcsph's pressure
force, at a support of h = k dx? (docs/method-wcsph.md, "The kernel's support".)

Under a uniform pressure p the pair force (W19) on a particle of the lattice is
-C sum_j grad W(r_ij) with C = 2 p m / rho^2 / S: the force of a pair potential
C W. Displacing the particles by u e^{i k.x} gives m u'' = -C D(k) u with the
lattice sum D(k) = sum_j (1 - cos k.r_j) Hess W(r_j). The lattice is stable
where both eigenvalues of D(k) are >= 0 for every k of the Brillouin zone. A
carried (continuity) density does not see a displacement that keeps the
volume (a shear), so nothing else restores it. `squeeze` compresses the rows
along y by that fraction (a hydrostatic column's, W23b).

    python benchmarks/experiments/lattice_stability.py analysis [2,2.5,2.75,3] [SQUEEZE] [--quintic]
    python benchmarks/experiments/lattice_stability.py elastic [2.75,3,4] [--quintic]
    python benchmarks/experiments/lattice_stability.py run 2.75,3 [N] [PRESSURE]

--quintic analyses the quintic spline of support h (W31's pressure kernel,
`solver.pressure_kernel`) in place of the Wendland kernel; `run` runs wcsph's
default, the pressure on the Wendland kernel.

`elastic` takes D(k) at long waves, sum_j (k.r_j)^2 / 2 Hess W(r_j) / |k|^2:
its transverse part, over its longitudinal one, is a shear modulus the
pressure lends the lattice (a fluid has none), for waves along x and along a
diagonal.

`run` puts a periodic box of N x N particles (default 40) at the given
background pressure (default 20 kPa; c0 = 46.5 m/s, no gravity), displaced by
1e-4 spacings at random, and prints its largest speed every 0.25 s for 1 s: a
stable lattice's falls, an unstable one's grows by orders of magnitude.
"""
from __future__ import annotations

import sys

import numpy as np


def wendland_hessian(x: np.ndarray, y: np.ndarray, h: float):
    """The Hessian of the 2D Wendland C2 kernel of support h at (x, y) != 0."""
    r = np.hypot(x, y)
    q = r / h
    a = np.clip(1 - q, 0, None)
    w = 7 / (np.pi * h * h)
    d1 = -20 * w * q * a**3 / h  # W'(r)
    d2 = 20 * w * a**2 * (4 * q - 1) / h**2  # W''(r)
    ex, ey, f = x / r, y / r, d1 / r
    return (d2 * ex * ex + f * (1 - ex * ex), (d2 - f) * ex * ey, d2 * ey * ey + f * (1 - ey * ey))


def quintic_hessian(x: np.ndarray, y: np.ndarray, h: float):
    """The Hessian of the 2D quintic spline of support h (s = 3r/h) at (x, y) != 0,
    up to its normalisation."""
    r = np.hypot(x, y)
    s = 3 * r / h
    a, b, c = (np.clip(k - s, 0, None) for k in (3.0, 2.0, 1.0))
    d1 = (3 / h) * (-5 * a**4 + 30 * b**4 - 75 * c**4)  # W'(r)
    d2 = (3 / h) ** 2 * (20 * a**3 - 120 * b**3 + 300 * c**3)  # W''(r)
    ex, ey, f = x / r, y / r, d1 / r
    return (d2 * ex * ex + f * (1 - ex * ex), (d2 - f) * ex * ey, d2 * ey * ey + f * (1 - ey * ey))


HESSIAN = wendland_hessian  # --quintic: quintic_hessian


def smallest_eigenvalue(k: float, squeeze: float = 0.0, samples: int = 121):
    """min over the Brillouin zone of D(k)'s smaller eigenvalue (dx = 1, W(0)'s
    scale), and where."""
    reach = int(np.ceil(k)) + 1
    i, j = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1))
    keep = (i != 0) | (j != 0)
    x, y = i[keep].astype(float), j[keep] * (1 - squeeze)
    hxx, hxy, hyy = HESSIAN(x, y, k)
    waves = np.linspace(0, np.pi, samples)
    kx, ky = (a.ravel() for a in np.meshgrid(waves, waves))
    c = 1 - np.cos(np.outer(kx, i[keep]) + np.outer(ky, j[keep]))
    a, b, d = c @ hxx, c @ hxy, c @ hyy
    lowest = 0.5 * (a + d) - np.sqrt(0.25 * (a - d) ** 2 + b * b)
    at = int(lowest.argmin())
    return float(lowest[at]), (float(kx[at]), float(ky[at]))


def analysis(ratios: list[float], squeeze: float) -> None:
    print("| h / dx | smallest eigenvalue of D | at k dx |")
    print("|---:|---:|---|")
    for k in ratios:
        value, (kx, ky) = smallest_eigenvalue(k, squeeze)
        print(f"| {k:g} | {value:+.5f} | ({kx:.2f}, {ky:.2f}) |")


def elastic(ratios: list[float]) -> None:
    print("| h / dx | transverse / longitudinal, along x | along a diagonal |")
    print("|---:|---:|---:|")
    for k in ratios:
        reach = int(np.ceil(k)) + 1
        i, j = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1))
        keep = (i != 0) | (j != 0)
        x, y = i[keep].astype(float), j[keep].astype(float)
        hxx, hxy, hyy = HESSIAN(x, y, k)
        ratios_k = []
        for e in (np.array([1.0, 0.0]), np.array([1.0, 1.0]) / np.sqrt(2)):
            c = 0.5 * (e[0] * x + e[1] * y) ** 2
            m = np.array([[c @ hxx, c @ hxy], [c @ hxy, c @ hyy]])
            t = np.array([-e[1], e[0]])
            ratios_k.append(float(t @ m @ t) / float(e @ m @ e))
        print(f"| {k:g} | {ratios_k[0]:+.4f} | {ratios_k[1]:+.4f} |")


def run(ratios: list[float], n: int, pressure: float) -> None:
    from sphfluid import Simulation

    for k in ratios:
        scene = {"format": "sphfluid-scene/1", "name": "lattice under pressure",
                 "gravity": [0.0, 0.0],
                 "domain": {"min": [0.0, 0.0], "max": [1.0, 1.0], "periodic": [True, True]},
                 "fluid": {"rest_density": 1000.0, "speed_of_sound": 46.5,
                           "background_pressure": pressure},
                 "resolution": {"spacing": 1.0 / n, "smoothing_length": k / n},
                 "fluid_regions": [{"shape": "rectangle", "min": [0.0, 0.0],
                                    "max": [1.0, 1.0]}],
                 "walls": [], "solver": {"method": "wcsph", "time_step": "auto", "shifting": 0}}
        sim = Simulation(scene, threads=2)
        rng = np.random.default_rng(1)
        x = sim.positions + 1e-4 / n * rng.standard_normal(sim.positions.shape)
        sim.set_state(x % 1.0, np.zeros_like(x))
        speeds = []
        for t in (0.25, 0.5, 0.75, 1.0):
            sim.advance_to(t)
            speeds.append(float(np.sqrt((sim.velocities**2).sum(1)).max()))
        print(f"h = {k:g} dx: largest speed at t = 0.25 / 0.5 / 0.75 / 1 s: "
              + " / ".join(f"{s:.2g}" for s in speeds) + " m/s", flush=True)


if __name__ == "__main__":
    if "--quintic" in sys.argv:
        sys.argv.remove("--quintic")
        HESSIAN = quintic_hessian
    mode = sys.argv[1] if len(sys.argv) > 1 else "analysis"
    ks = [float(v) for v in (sys.argv[2] if len(sys.argv) > 2 else "2,2.5,2.75,3").split(",")]
    if mode == "analysis":
        analysis(ks, float(sys.argv[3]) if len(sys.argv) > 3 else 0.0)
    elif mode == "elastic":
        elastic(ks)
    elif mode == "run":
        run(ks, int(sys.argv[3]) if len(sys.argv) > 3 else 40,
            float(sys.argv[4]) if len(sys.argv) > 4 else 20_000.0)
    else:
        sys.exit(f"unknown mode {mode!r}: analysis, elastic or run")
