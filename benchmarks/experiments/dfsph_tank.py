"""dfsph: a tank 1 m deep at rest, filled on the lattice at zero pressure, as a
user sets it up: the pressure's RMS error against rho0 g (H - y) (over the
fluid away from the walls and the surface, as a fraction of rho0 g H) and the
fastest particle over sqrt(gH), every 0.25 s (docs/method-dfsph.md, Measured).

    python benchmarks/experiments/dfsph_tank.py ['{"density_tolerance": 1e-5}'] [dx]
"""
from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

import sphfluid

DEPTH = 1.0


def tank(dx: float, solver: dict) -> dict:
    return {"format": "sphfluid-scene/1", "name": "tank at rest", "gravity": [0, -9.81],
            "domain": {"min": [-0.1, -0.1], "max": [1.1, 1.6]},
            "fluid": {"rest_density": 1000.0, "viscosity": 1e-3},
            "resolution": {"spacing": dx},
            "fluid_regions": [{"shape": "rectangle", "min": [0, 0], "max": [1.0, DEPTH]}],
            "walls": [{"polyline": [[0, 1.5], [0, 0], [1, 0], [1, 1.5]]}],
            "solver": {"method": "dfsph", "time_step": "auto", **solver}}


def main() -> None:
    solver = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    dx = float(sys.argv[2]) if len(sys.argv) > 2 else 0.025
    sim = sphfluid.Simulation(sphfluid.load_scene(tank(dx, solver)), threads=2)
    start = time.perf_counter()
    for t in np.arange(0.25, 2.0 + 1e-9, 0.25):
        sim.advance_to(t)
        x, p, v = sim.positions, sim.pressures, sim.velocities
        inner = (x[:, 1] < 0.8 * DEPTH) & (x[:, 0] > 0.1) & (x[:, 0] < 0.9)
        scale = 1000 * 9.81 * DEPTH
        rms = math.sqrt(np.mean((p[inner] - 1000 * 9.81 * (DEPTH - x[inner, 1])) ** 2)) / scale
        st = sim.stats()
        print(f"t = {t:.2f} s  pressure RMS {rms:.4f} rho0 g H  fastest "
              f"{np.linalg.norm(v, axis=1).max() / math.sqrt(9.81 * DEPTH):.3f} sqrt(gH)  "
              f"steps {sim.step_count}  iterations {st['solve_iterations']}  "
              f"unconverged {st['solve_unconverged']}")
    print(f"wall time {time.perf_counter() - start:.2f} s")


if __name__ == "__main__":
    main()
