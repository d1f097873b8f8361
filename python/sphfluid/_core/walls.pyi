# Types of sphfluid._core.walls (cpp/bind_kernels.cpp): the wall geometry, for tests.
# Walls are (s, 2, 2) arrays of segments [[x1, y1], [x2, y2]], m.
import numpy as np
from numpy.typing import ArrayLike, NDArray

def ghosts(walls: ArrayLike, point: ArrayLike, h: float,
           nearest_only: bool = False) -> NDArray[np.float64]:
    """Positions (g, 2) of the wall ghosts of a particle at point [x, y] (seed 4.1); with
    nearest_only, only those at the walls' nearest point (wcsph's and dfsph's: none at a
    joint that another segment comes nearer than, nor where three segments meet)."""
def collide(walls: ArrayLike, x_old: ArrayLike, x_new: ArrayLike, v: ArrayLike,
            restitution: float = 1.0,
            h: float = 1.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """Move from x_old towards x_new with velocity v, reflecting off the walls (seed 4.2);
    returns (x, v). A bounce leaves the particle 1e-6 h in front of the wall."""
