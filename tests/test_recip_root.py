"""The seed's double pair forces with 1/r from rsqrt14 and two Newton steps
(the pair term's RecipRoot, which Intel CPUs run: prefers_recip_root) against the
square root and division, in a small program: the same forces to round-off,
including coincident particles (r = 0, no force) and pairs just inside h."""
from __future__ import annotations

from pathlib import Path

import pytest
import sphfluid
from conftest import ROOT
from test_cell_blocks import run_cell_pairs_driver

DRIVER = r"""
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>
#include "methods/seed/pairs.hpp"
#include "neighbours/frames.hpp"
using namespace sphfluid;

struct One {
  template <class L> L operator()(L) const { return simd::splat<L>(1.0); }
};

int main() {
#if SPHFLUID_AVX512
  unsigned s = 5;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  const Real h = 0.02, dx = 0.01;
  std::vector<Vec2> x0;
  for (int j = 0; j < 50; ++j)
    for (int i = 0; i < 40; ++i)
      x0.emplace_back((i + 0.5 + 0.3 * (rnd() - 0.5)) * dx, (j + 0.5 + 0.3 * (rnd() - 0.5)) * dx);
  x0.push_back(x0[100]);                              // coincident with particle 100
  x0.push_back(x0[200] + Vec2(h * (1 - 1e-12), 0));   // just inside h of particle 200
  const Index n = static_cast<Index>(x0.size());
  CellGrid grid;
  std::vector<Index> order;
  grid.sort(x0.data(), n, h, 1, order);
  std::vector<Vec2> x(n), v(n);
  std::vector<Real> p(n), ir(n);
  for (Index k = 0; k < n; ++k) {
    x[k] = x0[order[k]];
    v[k] = Vec2(rnd() - 0.5, rnd() - 0.5);
    p[k] = 1e3 * (rnd() + 0.1);
    ir[k] = 1e-3 * (0.9 + 0.2 * rnd());
  }
  CellPairs cp;
  cp.make_blocks(grid, n, 2);
  std::vector<Real> rho(n);
  cp.density(grid, x.data(), h, 1.0, 1.0, One{}, rho.data(), 1);  // (cuts the pair blocks)
  std::vector<Vec2> a0(n), a1(n);
  using simd::D8;
  const PositionFrame<D8> frame(x.data(), h);
  const InterleavedVelocity vel{v.data()};
  const seed::ForcePairs<D8, true, false, InterleavedVelocity> root{
      p.data(), ir.data(), vel, D8::splat(h), D8::splat(0.7)};
  const seed::ForcePairs<D8, true, true, InterleavedVelocity> newton{
      p.data(), ir.data(), vel, D8::splat(h), D8::splat(0.7)};
  cp.pair_sums(grid, frame, root, a0.data(), 2);
  cp.pair_sums(grid, frame, newton, a1.data(), 2);
  double largest = 0, diff = 0;
  int bad = 0;
  for (Index k = 0; k < n; ++k) {
    largest = std::max(largest, a0[k].norm());
    diff = std::max(diff, (a1[k] - a0[k]).norm());
    bad += !(a1[k].allFinite() && a0[k].allFinite());
  }
  std::printf("largest %.6e, max difference %.3e of it, %d not finite\n", largest,
              diff / largest, bad);
  return bad != 0 || !(diff <= 1e-14 * largest);
#else
  std::printf("no cell clusters in this build\n");
  return 0;
#endif
}
"""


def test_recip_root_gives_the_forces_of_the_root_and_division(tmp_path):
    out = run_cell_pairs_driver(tmp_path, DRIVER)
    assert "0 not finite" in out.stdout, out.stdout


@pytest.mark.skipif(not Path("/proc/cpuinfo").exists(), reason="reads the CPU vendor from /proc")
def test_the_solver_takes_the_newton_steps_on_intel_cpus_only():
    sim = sphfluid.Simulation(str(ROOT / "scenes" / "droplet.json"))
    intel = "GenuineIntel" in Path("/proc/cpuinfo").read_text()
    assert sim._solver.recip_root is intel
