"""The neighbour filter built into small programs and checked against brute
force, lists and density sums both, for the seed's and wcsph's kernels: the
full lists, and the half lists of the pair-once loops with their carried sums,
over awkward inputs (one row or one column of cells, points on cell borders, a
single particle or none, blocks of one particle and blocks larger than n), and
the half lists bitwise the same on 1, 2, 3 and 17 threads. Built once
for baseline x86-64, which takes the scalar path every CPU without AVX-512
runs (the installed extension here may use the AVX-512 path), and once with
-march=native, which takes the AVX-512 path where the CPU has it."""
from __future__ import annotations

import os
import platform
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
#include "neighbours/lists.hpp"
#include "terms/kernels.hpp"
#include "terms/wendland.hpp"
using namespace sphfluid;

template <class W>
int check(const std::vector<Vec2>& x, Real h, W w, const char* name, Index block) {
  const Index n = static_cast<Index>(x.size());
  CellGrid grid;
  std::vector<Index> order;
  grid.sort(x.data(), n, h, 1, order);
  std::vector<Vec2> xs(n);
  for (Index k = 0; k < n; ++k) xs[k] = x[order[k]];
  Csr<Index> nbrs;
  std::vector<Real> sum(n, -1), total(n, -1), acc(n, -1);
  std::vector<std::vector<Index>> lists(n);
  lists::full(grid, xs.data(), n, h, 2, nbrs, w, [&](Index i, const Index* nb, Index count, Real s) {
    sum[i] = s;
    lists[i].assign(nb, nb + count);
  });
  // The half lists: row i holds exactly the neighbours j > i and those before
  // i's block, and the sums carried within a block add up to every neighbour's
  // weight.
  Csr<Index> half;
  lists::half(grid, xs.data(), n, h, 1, block, half, acc.data(), w,
                       [&](Index i, Real s) { total[i] = s; });
  int bad = 0, bad_once = 0;
  // The same rows, in the same order, and bitwise the same sums on any number
  // of threads (more threads than blocks included).
  for (const int threads : {2, 3, 17}) {
    Csr<Index> again;
    std::vector<Real> acc2(n, -1), total2(n, -1);
    lists::half(grid, xs.data(), n, h, threads, block, again, acc2.data(), w,
                         [&](Index i, Real s) { total2[i] = s; });
    for (Index i = 0; i < n; ++i) {
      const Row<Index> a = half.row(i), b = again.row(i);
      if (total2[i] != total[i] || !std::equal(a.begin(), a.end(), b.begin(), b.end())) {
        ++bad_once;
        break;
      }
    }
  }
  for (Index i = 0; i < n; ++i) {
    const Index lo = i - i % block;
    std::vector<Index> want, want_half, got;
    Real ws = 0;
    for (Index j = 0; j < n; ++j) {
      const Real r2 = (xs[i] - xs[j]).squaredNorm();
      if (j == i || r2 >= h * h) continue;
      want.push_back(j);
      ws += w(r2);
      if (j > i || j < lo) want_half.push_back(j);
    }
    const Real tol = 1e-12 * (std::abs(ws) + w(Real(0)));
    if (want != lists[i] || std::abs(sum[i] - ws) > tol) ++bad;
    for (const Index j : half.row(i)) got.push_back(j);
    std::sort(got.begin(), got.end());
    if (want_half != got || std::abs(total[i] - ws) > tol) ++bad_once;
  }
  std::printf("%s, block %d: %d particles, %d wrong, %d wrong once\n", name, block, n, bad,
              bad_once);
  return bad + bad_once;
}

int main() {
#if SPHFLUID_AVX512
  std::printf("path: avx512\n");
#else
  std::printf("path: scalar\n");
#endif
  unsigned s = 12345;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  const Real h = 0.06;
  const Kernels poly(h);
  Wendland wend(h);
  std::vector<std::pair<const char*, std::vector<Vec2>>> cases(6);
  cases[0].first = "random";
  for (int k = 0; k < 3000; ++k) cases[0].second.emplace_back(2.0 * rnd() - 0.5, 1.5 * rnd());
  cases[1].first = "one row of cells";
  for (int k = 0; k < 600; ++k) cases[1].second.emplace_back(3.0 * rnd(), 0.5 * h * rnd());
  cases[2].first = "one column of cells";
  for (int k = 0; k < 600; ++k) cases[2].second.emplace_back(0.5 * h * rnd(), 3.0 * rnd());
  cases[3].first = "lattice on the cell borders";  // spacing h / 2: pairs at exactly h
  for (int a = 0; a < 30; ++a)
    for (int b = 0; b < 30; ++b) cases[3].second.emplace_back(0.5 * h * a, 0.5 * h * b);
  cases[4].first = "one particle";
  cases[4].second.emplace_back(0.3, 0.7);
  cases[5].first = "no particles";
  int bad = 0;
  for (const auto& c : cases)
    for (const Index block : {Index(1), Index(7), Index(700), Index(5000)}) {
      std::printf("%s: ", c.first);
      bad += check(c.second, h, Poly6Weight(poly), "poly6", block);
      std::printf("%s: ", c.first);
      bad += check(c.second, h, WendlandWeight(wend), "wendland", block);
    }
  std::printf("wrong in all: %d\n", bad);
  return bad != 0;
}
"""


def eigen_include() -> Path | None:
    for base in sys.path:
        p = Path(base or ".") / "cmeel.prefix" / "include" / "eigen3"
        if (p / "Eigen" / "Core").is_file():
            return p
    p = Path("/usr/include/eigen3")
    return p if (p / "Eigen" / "Core").is_file() else None


def build_and_run(tmp_path, flags):
    cxx = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    eigen = eigen_include()
    if cxx is None or eigen is None:
        pytest.skip("needs a C++ compiler and Eigen's headers (pip install cmeel-eigen)")
    src = tmp_path / "driver.cpp"
    src.write_text(DRIVER)
    exe = tmp_path / "driver"
    cpp = ROOT / "cpp"
    cmd = [cxx, "-std=c++17", *flags, f"-I{cpp}", f"-isystem{eigen}", str(src),
           str(cpp / "neighbours" / "grid.cpp"), "-o", str(exe)]
    try:  # with the threads where the compiler has OpenMP, as the extension
        subprocess.run(cmd + ["-fopenmp"], check=True, capture_output=True, text=True)
    except subprocess.CalledProcessError:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "wrong in all: 0" in out.stdout
    assert out.stdout.count(" 0 wrong, 0 wrong once") == 6 * 4 * 2, out.stdout
    return out.stdout


def test_scalar_filter_matches_brute_force(tmp_path):
    x86 = platform.machine().lower() in ("x86_64", "amd64")
    out = build_and_run(tmp_path, ["-O1"] + (["-mno-avx512f"] if x86 else []))
    assert "path: scalar" in out


def test_native_filter_matches_brute_force(tmp_path):
    """Where the CPU has AVX-512 this is the path the installed extension runs."""
    out = build_and_run(tmp_path, ["-O2", "-march=native"])
    if "path: avx512" not in out:
        pytest.skip("no AVX-512 on this CPU: the native build took the scalar path, tested above")
