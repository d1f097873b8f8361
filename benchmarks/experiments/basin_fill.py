"""A tap filling an empty basin: an emitter 0.1 m wide at 1 m/s, 0.2 m above
the rim of a basin 0.6 m wide, for 1.5 s, then 1.5 s to settle. The emitted
particles' area (count x spacing^2) over the basin's width is the level the
inflow predicts; the level reached is the top of the fluid in the middle of
the basin (its 98th percentile of y plus half a spacing). Each density of
wcsph, or its continuity density with either free surface (W26b, the
default, or W26; docs/method-wcsph.md quotes the output).

    python benchmarks/experiments/basin_fill.py [pressure_floor,density_floor,summation] [spacing]
"""
from __future__ import annotations

import sys

import numpy as np

from sphfluid.simulation import Simulation

WIDTH = 0.6  # the basin's inside, m (x from 0.2 to 0.8)


def scene(density: str, dx: float) -> dict:
    solver = ({"free_surface": density} if density in ("pressure_floor", "density_floor")
              else {"density": density})
    return {
        "format": "sphfluid-scene/1",
        "name": "A tap filling a basin",
        "domain": {"min": [0, 0], "max": [1, 1.2]},
        "fluid": {"rest_density": 1000, "viscosity": 0.001},
        "resolution": {"spacing": dx},
        "fluid_regions": [],
        "walls": [{"polyline": [[0.2, 0.8], [0.2, 0.0], [0.8, 0.0], [0.8, 0.8]]}],
        "emitters": [{"name": "tap", "at": [0.5, 1.0], "width": 0.1, "speed": 1.0,
                      "stop": 1.5}],
        "solver": {"method": "wcsph", "time_step": "auto", **solver},
    }


def level(sim: Simulation, dx: float) -> tuple[int, float, float]:
    """(particles in the basin, the level they predict, the level reached)."""
    x = sim.positions
    inside = (x[:, 0] > 0.2) & (x[:, 0] < 0.8) & (x[:, 1] < 0.8)
    middle = inside & (np.abs(x[:, 0] - 0.5) < 0.2)
    top = float(np.percentile(x[middle, 1], 98)) + 0.5 * dx if middle.any() else 0.0
    n = int(inside.sum())
    return n, n * dx * dx / WIDTH, top


def main() -> None:
    densities = (sys.argv[1] if len(sys.argv) > 1 else "continuity,summation").split(",")
    dx = float(sys.argv[2]) if len(sys.argv) > 2 else 0.02
    print("| density | t, s | emitted | lost | in the basin | level predicted, m | level, m |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for density in densities:
        sim = Simulation(scene(density, dx), threads=2)
        for t in (2.0, 3.0):  # the tap stops at 1.5 s
            sim.advance_to(t)
            n, predicted, top = level(sim, dx)
            b = sim.balance
            print(f"| {density} | {t:g} | {b['in']} | {b['lost']} | {n} | {predicted:.3f} | "
                  f"{top:.3f} |")


if __name__ == "__main__":
    main()
