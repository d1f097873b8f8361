"""dfsph: one simulated second (or the given seconds) of the benchmark's dam
break (about 10,000 particles, water's viscosity), step by step: wall time of
the stepping, steps, iterations a step, and over every step the largest
compression (when and where), the steps with a particle more than 1 % and 2 %
compressed, the largest 99.9th percentile of the compression, the mean
compression; particles lost, and the time per phase (docs/method-dfsph.md,
Measured).

    python benchmarks/experiments/dfsph_dam_break.py [particles [seconds]]
"""
from __future__ import annotations

import sys
import time

import numpy as np

import sphfluid
from sphfluid.bench import dam_break_scene


def main() -> None:
    n_target = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    end = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    d = dam_break_scene(n_target, "dfsph")  # water, the adaptive step
    sim = sphfluid.Simulation(sphfluid.load_scene(d), threads=2)
    n0, wall = sim.n_particles, 0.0
    worst, when, where = 0.0, 0.0, (0.0, 0.0)
    over1 = over2 = 0
    p999, means = 0.0, []
    while sim.time < end - 1e-9:
        start = time.perf_counter()
        sim.step()
        wall += time.perf_counter() - start
        excess = sim.densities / 1000.0 - 1.0
        i = int(excess.argmax())
        if excess[i] > worst:
            worst, when, where = float(excess[i]), sim.time, tuple(sim.positions[i])
        over1 += excess[i] > 0.01
        over2 += excess[i] > 0.02
        p999 = max(p999, float(np.percentile(excess, 99.9)))
        means.append(float(np.maximum(excess, 0).mean()))
    st = sim.stats()
    phases = {k: round(v, 2) for k, v in sim._solver.phase_seconds().items()}
    steps = sim.step_count
    print(f"{n0:,} particles: {sim.time:.3g} s in {steps:,} steps, {wall:.2f} s of stepping; "
          f"{st['solve_iterations'] / steps:.1f} iterations a step, "
          f"{st['solve_unconverged']} unconverged; over every step: largest compression "
          f"{worst:.4f} (t = {when:.3f} s at ({where[0]:.3f}, {where[1]:.3f}) m), steps with "
          f"a particle over 1 % {over1}, over 2 % {over2}, largest 99.9th percentile "
          f"{p999:.4f}, mean compression {np.mean(means):.2e}; {n0 - sim.n_particles} particles "
          f"lost; phases {phases}")


if __name__ == "__main__":
    main()
