"""wcsph's dam break at several speeds of sound: the densest particle over every
step to t = 1 s (compression only, rho > rho0), where and when, and how many
steps have some particle over 1 %. STABILITY.md, "Density error and the speed of
sound", quotes its output (with the summed density).

    python benchmarks/experiments/density_vs_sound_speed.py 3000 10,20,30,40 [DENSITY]

DENSITY: "summation" (default here) or "continuity" (wcsph's default).
"""
from __future__ import annotations

import sys
import time

import numpy as np

import sphfluid
from sphfluid.bench import dam_break_scene
from sphfluid.simulation import expected_top_speed


def scan(n_target: int, factors: list[float], density: str = "summation") -> None:
    for factor in factors:
        scene = dam_break_scene(n_target, "wcsph")
        scene["solver"]["time_step"] = "auto"
        scene["solver"]["density"] = density
        top = expected_top_speed(sphfluid.load_scene(scene))
        scene["fluid"]["speed_of_sound"] = factor * top
        sim = sphfluid.Simulation(scene)
        worst, t_worst, x_worst, over, steps = 0.0, 0.0, (0.0, 0.0), 0, 0
        start = time.perf_counter()
        while sim.time < 1.0:
            sim.step(1)
            steps += 1
            c = sim.densities / scene["fluid"]["rest_density"] - 1.0
            k = int(np.argmax(c))
            over += c[k] > 0.01
            if c[k] > worst:
                worst, t_worst, x_worst = c[k], sim.time, tuple(sim.positions[k])
        wall = time.perf_counter() - start
        print(f"{sim.n_particles:,} particles, c0 = {factor:g} x {top:.2f} = {factor * top:.0f} m/s: "
              f"{steps:,} steps, {wall:.1f} s; densest {100 * worst:.2f} % at t = {t_worst:.3f} s, "
              f"x = ({x_worst[0]:.3f}, {x_worst[1]:.3f}); steps with a particle over 1 %: "
              f"{over} ({100 * over / steps:.2f} %)", flush=True)


if __name__ == "__main__":
    scan(int(sys.argv[1]) if len(sys.argv) > 1 else 3000,
         [float(f) for f in (sys.argv[2] if len(sys.argv) > 2 else "10,20,30,40").split(",")],
         sys.argv[3] if len(sys.argv) > 3 else "summation")
