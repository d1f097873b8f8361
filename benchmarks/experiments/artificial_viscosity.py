"""What wcsph's artificial viscosity alpha (`fluid.artificial_viscosity`, 0.1 by
default) takes and gives, n cells across the depth, for each alpha given:

- the piston wave maker's waves (validation case wave_maker): the height of
  the first harmonic (period T, fitted over 3-12 s) over linear theory's at
  gauges 0.3 to 1.8 m from the piston (the validation's gauge is at 1.0 m);
- the tank at rest filled on the lattice (validation case hydrostatic): its
  largest speed over sqrt(gH) at t = 0.5 to 5 s (the square lattice's
  instability under pressure, which alpha alone damps; docs/method-wcsph.md,
  "The square lattice under pressure").

VALIDATION.md, "Piston wave maker"; docs/method-wcsph.md, "Choices".

    python benchmarks/experiments/artificial_viscosity.py N ALPHA [ALPHA ...] [--reconstruct]

--reconstruct runs both with `solver.viscosity_reconstruction` (W30).
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np

import sphfluid
from sphfluid.probes import Probes, SurfaceProbe, sample
from sphfluid.validation import reference as ref
from sphfluid.validation.cases import Hydrostatic, WaveMaker

GAUGES = (0.3, 0.6, 1.0, 1.4, 1.8)  # m from the piston's mean position
RECONSTRUCT = False  # W30
TANK_TIMES = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0)  # s


def heights(n: int, alpha: float) -> tuple[list[float], float]:
    case = WaveMaker()
    scene = case.scene(n, "wcsph")
    scene["fluid"]["artificial_viscosity"] = alpha
    scene["solver"]["viscosity_reconstruction"] = RECONSTRUCT
    sim = sphfluid.Simulation(scene)
    probes = Probes(surface=tuple(SurfaceProbe(f"g{k}", x) for k, x in enumerate(GAUGES)))
    t, eta, begin = [], [], time.perf_counter()
    for when in case.sample_times():
        sim.advance_to(float(when))
        h = sample(sim, probes)
        t.append(sim.time)
        eta.append([h[f"g{k}.height"] - case.length for k in range(len(GAUGES))])
    t, eta = np.array(t), np.array(eta)
    w = (t >= case.window[0] - 1e-9) & (t <= case.window[1] + 1e-9)
    omega = 2 * math.pi / case.period
    basis = np.c_[np.cos(omega * t[w]), np.sin(omega * t[w]), np.ones(w.sum())]
    theory = case.stroke * ref.piston_height_ratio(ref.wave_number(case.period, case.length)
                                                   * case.length)
    out = []
    for k in range(len(GAUGES)):
        (a, b, _), *_ = np.linalg.lstsq(basis, eta[w, k], rcond=None)
        out.append(2 * math.hypot(a, b) / theory)
    return out, time.perf_counter() - begin


def tank_speeds(n: int, alpha: float) -> list[float]:
    case = Hydrostatic()
    scene = case.scene(n, "wcsph")
    scene["fluid"]["artificial_viscosity"] = alpha
    scene["solver"]["viscosity_reconstruction"] = RECONSTRUCT
    sim = sphfluid.Simulation(scene)
    out = []
    for t in TANK_TIMES:
        sim.advance_to(t)
        out.append(float(np.sqrt((sim.velocities**2).sum(1)).max() / math.sqrt(9.81 * case.length)))
    return out


def main() -> None:
    global RECONSTRUCT
    args = sys.argv[1:]
    RECONSTRUCT = "--reconstruct" in args
    args = [a for a in args if a != "--reconstruct"]
    n = int(args[0])
    alphas = [float(a) for a in args[1:]]
    print(f"n = {n}, the waves: H / H_theory at " + ", ".join(f"{x:g}" for x in GAUGES) + " m")
    for alpha in alphas:
        ratios, wall = heights(n, alpha)
        print(f"alpha {alpha:<5g} " + " ".join(f"{r:.3f}" for r in ratios) + f"  ({wall:.0f} s)",
              flush=True)
    print(f"n = {n}, the tank: largest speed / sqrt(gH) at t = "
          + ", ".join(f"{t:g}" for t in TANK_TIMES) + " s")
    for alpha in alphas:
        print(f"alpha {alpha:<5g} " + " ".join(f"{v:.2e}" for v in tank_speeds(n, alpha)),
              flush=True)


if __name__ == "__main__":
    main()
