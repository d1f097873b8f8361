"""An outlet under gravity: water 0.1 m deep over a 1.6 m flat floor, fed at
0.3 m/s by an inlet across its depth and let out by an outlet 0.3 m wide (the
free surface crosses it), the method's defaults (water, dx = 0.01 m), the fluid
at rest on the lattice at the start. Every 0.5 s: the particles, the surface
height in 0.2 m bins along the flume (the highest particle plus half a
spacing), and the mean pressure of the bottom rows just before the outlet
(docs/scene-format.md, "Inlets and outlets").

    python benchmarks/experiments/outlet_flume.py [DURATION] [LEVEL] [METHOD]

LEVEL sets the outlet's "level" (m; "-" or nothing: the fluid's); METHOD is
wcsph (the default), the seed or dfsph.
"""
from __future__ import annotations

import sys

import numpy as np

import sphfluid

DX, DEPTH, SPEED, LENGTH = 0.01, 0.1, 0.3, 1.6


def scene(buffer: float, level: float | None, method: str) -> dict:
    end = LENGTH + 2 * buffer + 0.05
    outlet = {"at": [buffer + LENGTH, 0.15], "direction": [1, 0], "width": 0.3}
    if level is not None:
        outlet["level"] = level
    d = {"format": "sphfluid-scene/1", "name": "outlet flume",
         "domain": {"min": [0.0, -0.05], "max": [end, 0.4]},
         "fluid": {"rest_density": 1000.0, "viscosity": 1e-3},
         "resolution": {"spacing": DX},
         "fluid_regions": [{"shape": "rectangle", "min": [buffer, 0.0],
                            "max": [buffer + LENGTH, DEPTH]}],
         "walls": [{"polyline": [[0.0, 0.4], [0.0, 0.0], [end, 0.0]]}],
         "solver": {"method": method, "time_step": "auto"}}
    if method == "seed":  # the bundled scenes' viscous fluid
        d["fluid"] = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0}
    if buffer:
        d["inlets"] = [{"at": [buffer, DEPTH / 2], "direction": [1, 0], "width": DEPTH,
                        "speed": SPEED}]
        d["outlets"] = [outlet]
    return d


def main() -> None:
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 4.0
    level = float(sys.argv[2]) if len(sys.argv) > 2 and sys.argv[2] != "-" else None
    method = sys.argv[3] if len(sys.argv) > 3 else "wcsph"
    buffer = sphfluid.load_scene(scene(0.0, None, method)).buffer_depth()
    sim = sphfluid.Simulation(scene(buffer, level, method))
    edges = np.arange(buffer, buffer + LENGTH + 1e-9, 0.2)
    print(f"surface height (m) in 0.2 m bins from the inlet; outlet level: "
          f"{'the fluid' + chr(39) + 's' if level is None else level}")
    for t in np.arange(0.5, duration + 1e-9, 0.5):
        try:
            sim.advance_to(float(t))
        except sphfluid.InstabilityError as e:
            print(f"stopped: {e}")
            return
        x, y = sim.positions.T
        top = []
        for a in edges[:-1]:
            inside = (x >= a) & (x < a + 0.2)
            top.append(y[inside].max() + DX / 2 if inside.any() else float("nan"))
        near = (x > buffer + LENGTH - 0.1) & (x < buffer + LENGTH) & (y < 0.03)
        p = sim.pressures[near].mean() if near.any() else float("nan")
        print(f"t = {sim.time:4.1f} s  {sim.n_particles:5d} particles  "
              + " ".join(f"{v:.3f}" for v in top) + f"  bottom p before the outlet {p:4.0f} Pa",
              flush=True)


if __name__ == "__main__":
    main()
