"""dfsph: one simulated second (or the given seconds) of the benchmark's dam
break (about 10,000 particles, water's viscosity): wall time, steps,
iterations a step, the largest and mean compression of the states every
0.05 s, particles lost, and the time per phase (docs/method-dfsph.md,
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
    n0, worst, means = sim.n_particles, 0.0, []
    start = time.perf_counter()
    while sim.time < end - 1e-9:
        sim.advance_to(min(end, sim.time + 0.05))
        excess = sim.densities / 1000.0 - 1.0
        worst = max(worst, float(excess.max()))
        means.append(float(np.maximum(excess, 0).mean()))
    wall = time.perf_counter() - start
    st = sim.stats()
    phases = {k: round(v, 2) for k, v in sim._solver.phase_seconds().items()}
    print(f"{n0:,} particles: {end:g} s in {sim.step_count:,} steps, {wall:.2f} s wall; "
          f"{st['solve_iterations'] / sim.step_count:.1f} iterations a step, "
          f"{st['solve_unconverged']} unconverged; largest compression {worst:.4f}, mean "
          f"{np.mean(means):.2e}; {n0 - sim.n_particles} particles lost; phases {phases}")


if __name__ == "__main__":
    main()
