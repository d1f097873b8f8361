"""The dam break of the benchmarks and the validation, defined once: a column
a x 2a against the left wall of a tank, after Martin & Moyce (1952, n^2 = 2).
Reads nothing; builds the geometric part of a scene dict (sphfluid-scene/1) that
`sphfluid bench`, the validation's dam-break case and the peers' drivers share.
scenes/dam_break.json repeats it (tests/test_dam_break.py checks that it agrees).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GEOMETRY", "DamBreakGeometry"]


@dataclass(frozen=True)
class DamBreakGeometry:
    """The column, the tank, the domain around them, gravity and the water.

    The fluid fills the column [0, a] x [0, 2a]; the tank's walls are x = 0,
    x = tank and the floor y = 0, up to tank_height; the domain leaves room
    around the tank (particles that leave it are removed).
    """

    a: float = 1.0  # m, the column's width (its height is 2a)
    tank: float = 4.0  # m, the tank's length (its right wall at x = tank)
    tank_height: float = 3.0  # m, the walls' height
    domain_min: tuple[float, float] = (-0.1, -0.1)  # m
    domain_max: tuple[float, float] = (4.1, 3.6)  # m
    g: float = 9.81  # m/s^2, downwards
    rho0: float = 1000.0  # kg/m^3

    def column(self) -> dict:
        """The fluid region: a rectangle a wide and 2a high at the origin."""
        return {"shape": "rectangle", "min": [0.0, 0.0], "max": [self.a, 2.0 * self.a]}

    def walls(self) -> list[dict]:
        """The tank as one polyline: left wall, floor, right wall."""
        L, H = self.tank, self.tank_height
        return [{"polyline": [[0.0, H], [0.0, 0.0], [L, 0.0], [L, H]]}]

    def scene(self, spacing: float, *, name: str, fluid: dict, solver: dict,
              duration: float | None = None) -> dict:
        """A scene dict of this dam break at particle spacing dx = `spacing` [m],
        the method's default support, with the given name, fluid (rest_density is this geometry's rho0,
        the rest is the caller's), solver block and, if given, duration [s]."""
        scene = {
            "format": "sphfluid-scene/1",
            "name": name,
            "gravity": [0.0, -self.g],
            "domain": {"min": list(self.domain_min), "max": list(self.domain_max)},
            "fluid": {"rest_density": self.rho0, **fluid},
            "resolution": {"spacing": spacing},
            "fluid_regions": [self.column()],
            "walls": self.walls(),
            "solver": solver,
        }
        if duration is not None:
            scene["duration"] = duration
        return scene


GEOMETRY = DamBreakGeometry()
