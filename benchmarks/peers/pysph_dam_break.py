"""PySPH on our dam break: its dam_break_2d example (scheme wcsph) with our geometry,
particle mass and h. Reads the configuration JSON file that peers.py writes (the
geometry, the spacing, the end time); reports on stdout as child.py describes.

    python benchmarks/peers/pysph_dam_break.py CONFIG.json
"""
from __future__ import annotations

from importlib.metadata import version

import numpy as np
from child import Reporter, load_config
from pysph.base.utils import get_particle_array
from pysph.examples.dam_break_2d import DamBreak2D

LAYERS = 4  # boundary particle layers, as the example's non-staggered tank


def fluid_lattice(cfg: dict) -> tuple[np.ndarray, np.ndarray]:
    """Our column's particles: ((i + 1/2) dx, (j + 1/2) dx) inside a x 2a."""
    dx = cfg["spacing"]
    x, y = np.meshgrid((np.arange(cfg["columns"]) + 0.5) * dx,
                       (np.arange(cfg["rows"]) + 0.5) * dx)
    return x.ravel(), y.ravel()


def tank_particles(cfg: dict) -> tuple[np.ndarray, np.ndarray]:
    """Dummy wall particles on our lattice, LAYERS deep outside x = 0, x = L, y = 0."""
    dx, length, height = cfg["spacing"], cfg["tank"], cfg["tank_height"]
    out = -(np.arange(LAYERS) + 0.5) * dx
    inside_x = (np.arange(int(length / dx + 0.5)) + 0.5) * dx
    inside_y = (np.arange(int(height / dx + 0.5)) + 0.5) * dx
    cols = np.concatenate([out, inside_x[inside_x < length], length - out])
    rows = np.concatenate([out, inside_y[inside_y < height]])
    x, y = np.meshgrid(cols, rows)
    wall = (x < 0) | (x > length) | (y < 0)
    return x[wall], y[wall]


class Peer(DamBreak2D):
    """The example with our geometry, and mass and h taken from --dx."""

    def __init__(self, cfg: dict, reporter: Reporter, **kwargs):
        self.cfg = cfg
        self.reporter = reporter
        super().__init__(**kwargs)

    def create_particles(self):
        rho0, dx = self.cfg["rho0"], self.cfg["spacing"]
        mass = rho0 * dx * dx
        xf, yf = fluid_lattice(self.cfg)
        xb, yb = tank_particles(self.cfg)
        fluid = get_particle_array(name="fluid", x=xf, y=yf, h=self.h, m=mass, rho=rho0)
        boundary = get_particle_array(name="boundary", x=xb, y=yb, h=self.h, m=mass, rho=rho0)
        self.scheme.setup_properties([fluid, boundary])
        self.fluid = fluid
        return [fluid, boundary]

    def post_step(self, solver):
        # called before the solver advances t by dt
        self.reporter.step(solver.t + solver.dt,
                           lambda: np.column_stack((self.fluid.x, self.fluid.y)))


def main() -> None:
    cfg = load_config()
    reporter = Reporter(cfg)
    app = Peer(cfg, reporter, fname="dam_break_peer", output_dir=cfg["workdir"])
    app.setup(["--scheme", "wcsph", "--dx", repr(cfg["spacing"]), "--tf", repr(cfg["end_time"]),
               "--openmp", "--disable-output", "--quiet", "--directory", cfg["workdir"]])
    reporter.start("WCSPH", version("pysph"), app.fluid.get_number_of_particles())
    reporter.begin()
    app.solver.solve(False)
    reporter.finish(app.solver.t)


if __name__ == "__main__":
    main()
