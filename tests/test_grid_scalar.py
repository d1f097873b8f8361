"""The neighbour filter's scalar path, which every CPU without AVX-512 runs:
grid.hpp built without AVX-512 into a small program (the installed extension
here may use the AVX-512 path) and checked against brute force, lists and
density sums both, for the seed's and wcsph's kernels, and the half lists of
the pair-once loops with their carried sums."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

DRIVER = r"""
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>
#include "grid.hpp"
#include "kernels.hpp"
#include "wendland.hpp"
using namespace sphfluid;

template <class W>
int check(const std::vector<Vec2>& x, Real h, W w, const char* name) {
  const Index n = static_cast<Index>(x.size());
  CellGrid grid;
  std::vector<Index> order;
  grid.sort(x.data(), n, h, 1, order);
  std::vector<Vec2> xs(n);
  for (Index k = 0; k < n; ++k) xs[k] = x[order[k]];
  Csr<Index> nbrs;
  std::vector<Real> sum(n, -1);
  std::vector<std::vector<Index>> lists(n);
  grid.neighbours(xs.data(), n, h, 1, nbrs, w, [&](Index i, const Index* nb, Index count, Real s) {
    sum[i] = s;
    lists[i].assign(nb, nb + count);
  });
  int bad = 0;
  for (Index i = 0; i < n; ++i) {
    std::vector<Index> want;
    Real ws = 0;
    for (Index j = 0; j < n; ++j) {
      const Real r2 = (xs[i] - xs[j]).squaredNorm();
      if (j != i && r2 < h * h) {
        want.push_back(j);
        ws += w(r2);
      }
    }
    if (want != lists[i] || std::abs(sum[i] - ws) > 1e-12 * (std::abs(ws) + w(Real(0)))) ++bad;
  }
  std::printf("%s: %d particles, %d wrong\n", name, n, bad);
  // The half lists of the pair-once loops, over blocks of 700 particles: row i
  // holds exactly the neighbours j > i and those before i's block, and the
  // sums carried within a block add up to every neighbour's weight.
  const Index block = 700;
  Csr<Index> half;
  std::vector<Real> acc(n, -1), total(n, -1);
  std::vector<std::vector<Index>> rows(n);
  grid.neighbours_once(xs.data(), n, h, 2, block, half, acc.data(), w, [&](Index i, Real s) {
    total[i] = s;
  });
  int bad_once = 0;
  for (Index i = 0; i < n; ++i) {
    const Index lo = i - i % block;
    std::vector<Index> want, got;
    Real ws = 0;
    for (Index j = 0; j < n; ++j) {
      const Real r2 = (xs[i] - xs[j]).squaredNorm();
      if (j == i || r2 >= h * h) continue;
      ws += w(r2);
      if (j > i || j < lo) want.push_back(j);
    }
    for (const Index j : half.row(i)) got.push_back(j);
    std::sort(got.begin(), got.end());
    if (want != got || std::abs(total[i] - ws) > 1e-12 * (std::abs(ws) + w(Real(0)))) ++bad_once;
  }
  std::printf("%s once: %d particles, %d wrong\n", name, n, bad_once);
  return bad + bad_once;
}

int main() {
#if defined(__AVX512F__)
  std::printf("built with AVX-512: the scalar path is not tested\n");
  return 2;
#endif
  std::vector<Vec2> x;
  unsigned s = 12345;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  for (int k = 0; k < 3000; ++k) x.emplace_back(2.0 * rnd() - 0.5, 1.5 * rnd());
  const Real h = 0.06;
  const Kernels poly(h);
  Wendland wend(h);
  return check(x, h, Kernels::Poly6OfR2{&poly}, "poly6") +
         check(x, h, Wendland::OfR2{&wend}, "wendland") != 0;
}
"""


def eigen_include() -> Path | None:
    for base in sys.path:
        p = Path(base or ".") / "cmeel.prefix" / "include" / "eigen3"
        if (p / "Eigen" / "Core").is_file():
            return p
    p = Path("/usr/include/eigen3")
    return p if (p / "Eigen" / "Core").is_file() else None


def test_scalar_filter_matches_brute_force(tmp_path):
    cxx = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    eigen = eigen_include()
    if cxx is None or eigen is None:
        pytest.skip("needs a C++ compiler and Eigen's headers (pip install cmeel-eigen)")
    src = tmp_path / "driver.cpp"
    src.write_text(DRIVER)
    exe = tmp_path / "driver"
    cpp = ROOT / "cpp"
    subprocess.run([cxx, "-std=c++17", "-O1", f"-I{cpp}", f"-isystem{eigen}",
                    str(src), str(cpp / "grid.cpp"), "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "poly6: 3000 particles, 0 wrong" in out.stdout
    assert "wendland: 3000 particles, 0 wrong" in out.stdout
    assert "poly6 once: 3000 particles, 0 wrong" in out.stdout
    assert "wendland once: 3000 particles, 0 wrong" in out.stdout
