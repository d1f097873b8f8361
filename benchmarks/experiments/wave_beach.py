"""The piston wave maker's tank (validation case wave_maker, 3.5 m long) with
and without its damping zone: the wave height 1 m from the piston over
H_theory and the reflection coefficient from two gauges (1.0 and 1.3 m), each
over 3-8 s and 8-13 s (the waves reflected by the far wall reach the gauges
after about 6 s). wcsph, n cells across the depth (VALIDATION.md, "Piston wave
maker").

    python benchmarks/experiments/wave_beach.py [n]
"""
from __future__ import annotations

import sys
import time

import sphfluid
from sphfluid.validation.cases import Result, WaveMaker


def measure(case: WaveMaker, n: int, beach: bool) -> None:
    scene = case.scene(n, "wcsph")
    if not beach:
        del scene["damping_zones"]
    sim = sphfluid.Simulation(scene)
    samples, t0 = [], time.perf_counter()
    for t in case.sample_times():
        sim.advance_to(float(t))
        samples.append(case.sample(sim))
    line = []
    for window in ((3.0, 8.0), (8.0, 13.0)):
        result = Result(case=case.name, method="wcsph", n=n, spacing=case.spacing(n))
        case.window = window
        case.score(samples, None, result)
        line.append(f"{window[0]:g}-{window[1]:g} s: H/H_theory "
                    f"{result.metrics['H, m'] / result.metrics['H_theory, m']:.3f}, reflection "
                    f"{result.metrics['reflection coefficient']:.3f}")
    print(f"{'with' if beach else 'without'} the damping zone ({sim.n_particles:,} particles, "
          f"{time.perf_counter() - t0:.0f} s): " + "; ".join(line))


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    case = WaveMaker()
    case.duration = 13.0
    for beach in (True, False):
        measure(case, n, beach)


if __name__ == "__main__":
    main()
