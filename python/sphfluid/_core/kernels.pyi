# Types of sphfluid._core.kernels (cpp/bind_kernels.cpp): the 2D SPH kernels,
# vectorised over numpy arrays, for tests and the Python layer.
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

# Radial kernels: values at distances r (any shape, r >= 0) for support h, m.
def w_poly6(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """poly6 W(r) = 4/(pi h^8) (h^2 - r^2)^3."""
def lap_poly6(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """poly6 Laplacian -48/(pi h^8) (h^2 - r^2)(h^2 - 3 r^2)."""
def w_spiky(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """spiky W(r) = 10/(pi h^5) (h - r)^3."""
def lap_visc(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """viscosity Laplacian 40/(pi h^5) (h - r)."""
def wendland_w(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """Wendland C2 W(r) = 7/(pi h^2) (1 - q)^4 (1 + 4q), q = r / h."""
def wendland_lap(r: ArrayLike, h: float) -> NDArray[np.float64]:
    """Wendland C2 Laplacian -140/(pi h^4) (1 - q)^2 (2 - 5q)."""

# Gradients: (n, 2) at the offsets r_ij of shape (n, 2).
def grad_poly6(r_ij: ArrayLike, h: float) -> NDArray[np.float64]:
    """poly6 gradient."""
def grad_spiky(r_ij: ArrayLike, h: float) -> NDArray[np.float64]:
    """spiky gradient."""
def wendland_grad(r_ij: ArrayLike, h: float) -> NDArray[np.float64]:
    """Wendland C2 gradient."""

def wendland_corner(d1: float, d2: float, h: float, dx: float = 0.0,
                    m_over_rho0: float = 0.0) -> tuple[float, float, float]:
    """wcsph's share of the quadrant beyond a right-angled corner at distances d1 and d2
    from its walls: (density / rho0, push along wall 1's normal, push along wall 2's
    normal), per unit 2 p rho0 / rho^2; from the mirrored lattice of spacing dx (particle
    mass m_over_rho0 * rho0) or, with dx = 0, the continuum."""
def lattice_mass(rho0: float, dx: float, h: float,
                 kernel: Literal["poly6", "wendland"] = "poly6") -> float:
    """Particle mass giving density rho0 inside a filled square lattice of spacing dx, for
    the seed's poly6 or wcsph's Wendland kernel."""
