"""The blocks of cell rows in which the cell-cluster loops evaluate each pair
once (CellPairs::make_blocks), checked in a small program: they start at row
boundaries, in order, and each cut falls at the first row boundary at or past
its share k n / count, so the first of two threads' halves holds at most one
row more than n / 2.
The cuts depend on the sorted particles alone (the thread-identity tests check
the sums).
The pair passes' blocks (CellPairs::cut_pair_blocks) are cut by cost instead:
each row's pairs, as the density pass counts them, and one for each of its
particles; a second program counts the pairs by brute force and checks the
density pass's counts and those cuts."""
from __future__ import annotations

import pytest
from test_walls_native import build_and_run

DRIVER = r"""
#include <algorithm>
#include <cstdio>
#include <vector>
#include "neighbours/cell_pairs.hpp"
using namespace sphfluid;

int check(const std::vector<Vec2>& x0, Real h, Index count, const char* name) {
  const Index n = static_cast<Index>(x0.size());
  CellGrid grid;
  std::vector<Index> order;
  grid.sort(x0.data(), n, h, 1, order);
  CellPairs cp;
  cp.make_blocks(grid, n, count);
  const Index nx = grid.nx(), ny = grid.ny();
  const Index* start = grid.cell_starts();
  auto row_start = [&](Index y) { return start[y * nx]; };
  Index widest = 0;
  for (Index y = 0; y < ny; ++y) widest = std::max(widest, row_start(y + 1) - row_start(y));
  int bad = 0;
  const Index nb = cp.blocks();
  if (nb < 1 || nb > std::max<Index>(count, 1) || cp.block_row(0) != 0 || cp.block_row(nb) != ny)
    ++bad;
  for (Index b = 1; b < nb; ++b) {
    const Index y = cp.block_row(b), s = row_start(y);
    if (y <= cp.block_row(b - 1) || s >= n) ++bad;
    // the cut is the first row boundary at or past some share k n / count
    bool first = false;
    for (Index k = 1; k < count; ++k)
      if (std::int64_t(s) * count >= std::int64_t(k) * n &&
          std::int64_t(row_start(y - 1)) * count < std::int64_t(k) * n)
        first = true;
    if (!first) ++bad;
  }
  Index half = -1;  // particles in the first half of the blocks (two threads)
  if (count % 2 == 0 && nb == count) {
    half = row_start(cp.block_row(nb / 2));
    if (2 * half < n || 2 * half - n > 2 * widest) ++bad;
  }
  std::printf("%s, %d blocks asked: %d made, widest row %d, first half %d of %d, %d wrong\n",
              name, count, nb, widest, half, n, bad);
  return bad;
}

int main() {
  unsigned s = 7;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  const Real h = 0.0283;
  std::vector<Vec2> column, thin, empty;
  for (int k = 0; k < 10011; ++k) column.emplace_back(rnd(), 2.0 * rnd());   // the dam's column
  for (int k = 0; k < 3000; ++k) thin.emplace_back(4.0 * rnd(), 0.1 * rnd());  // few, wide rows
  int bad = 0;
  for (const Index count : {1, 2, 8, 10, 16}) {
    bad += check(column, h, count, "column");
    bad += check(thin, h, count, "thin layer");
  }
  bad += check(empty, h, 4, "no particles");
  std::printf("wrong in all: %d\n", bad);
  return bad != 0;
}
"""


def test_blocks_split_the_particles_evenly_at_row_boundaries(tmp_path):
    out = build_and_run(tmp_path, DRIVER, units=("neighbours/grid.cpp",))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "wrong in all: 0" in out.stdout
    assert "column, 10 blocks asked: 10 made" in out.stdout, out.stdout


PAIR_DRIVER = r"""
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>
#include "neighbours/cell_pairs.hpp"
using namespace sphfluid;

#if SPHFLUID_AVX512
struct One {  // every neighbour weighs 1: rho_i = 1 + (neighbours of i)
  template <class L> L operator()(L) const { return simd::splat<L>(1.0); }
};

int check(const std::vector<Vec2>& x0, Real h, Index count, const char* name) {
  const Index n = static_cast<Index>(x0.size());
  CellGrid grid;
  std::vector<Index> order;
  grid.sort(x0.data(), n, h, 1, order);
  std::vector<Vec2> x(n);
  for (Index k = 0; k < n; ++k) x[k] = x0[order[k]];
  CellPairs cp;
  cp.make_blocks(grid, n, count);
  std::vector<Real> rho(n);
  const std::int64_t pairs = cp.density(grid, x.data(), h, 1.0, 1.0, One{}, rho.data(), 2);
  const Index nx = grid.nx(), ny = grid.ny();
  const Index* start = grid.cell_starts();
  std::vector<Index> row(n);
  for (Index y = 0; y < ny; ++y)
    for (Index k = start[y * nx]; k < start[(y + 1) * nx]; ++k) row[k] = y;
  // Each pair by brute force, in the lower of its two rows; cost of a row:
  // its pairs and one for each of its particles.
  std::vector<std::int64_t> cost(ny, 0);
  std::vector<Index> nbrs(n, 0);
  std::int64_t brute = 0;
  for (Index i = 0; i < n; ++i) {
    ++cost[row[i]];
    for (Index j = i + 1; j < n; ++j)
      if ((x[i] - x[j]).squaredNorm() < h * h) {
        ++brute;
        ++cost[std::min(row[i], row[j])];
        ++nbrs[i];
        ++nbrs[j];
      }
  }
  int bad = pairs != brute;
  for (Index i = 0; i < n; ++i) bad += rho[i] != 1.0 + nbrs[i];
  std::vector<std::int64_t> below(ny + 1, 0);
  for (Index y = 0; y < ny; ++y) below[y + 1] = below[y] + cost[y];
  const std::int64_t total = below[ny];
  std::int64_t widest = 0;
  for (Index y = 0; y < ny; ++y) widest = std::max(widest, cost[y]);
  const Index nb = cp.pair_blocks();
  if (nb < 1 || nb > count || cp.pair_block_row(0) != 0 || cp.pair_block_row(nb) != ny) ++bad;
  for (Index b = 1; b < nb; ++b) {
    const Index y = cp.pair_block_row(b);
    if (y <= cp.pair_block_row(b - 1) || below[y] >= total) ++bad;
    // the first row boundary whose cost below reaches some share k total / count
    bool first = false;
    for (Index k = 1; k < count; ++k)
      if (below[y] * count >= k * total && below[y - 1] * count < k * total) first = true;
    if (!first) ++bad;
  }
  std::int64_t half = -1;  // cost of the first half of the blocks (two threads)
  if (count % 2 == 0 && nb == count) {
    half = below[cp.pair_block_row(nb / 2)];
    if (2 * half < total || 2 * half - total > 2 * widest) ++bad;
  }
  std::printf("%s, %d blocks asked: %d made, %lld pairs (brute force %lld), cost %lld, "
              "first half %lld, widest row %lld, %d wrong\n",
              name, count, nb, static_cast<long long>(pairs), static_cast<long long>(brute),
              static_cast<long long>(total), static_cast<long long>(half),
              static_cast<long long>(widest), bad);
  return bad;
}
#endif

int main() {
#if SPHFLUID_AVX512
  unsigned s = 11;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  const Real h = 0.0283;
  // A column denser at its foot, as a compressed fluid is: the pairs crowd
  // into the lower rows, so that cuts by particles and by cost differ.
  std::vector<Vec2> column, sparse;
  for (int k = 0; k < 6000; ++k)  // density falling linearly from the foot to 0 at the top
    column.emplace_back(0.6 * rnd(), 1.2 * (1.0 - std::sqrt(rnd())));
  for (int k = 0; k < 200; ++k) sparse.emplace_back(4.0 * rnd(), 3.0 * rnd());  // few pairs
  int bad = 0;
  for (const Index count : {1, 2, 8}) {
    bad += check(column, h, count, "column");
    bad += check(sparse, h, count, "sparse");
  }
  std::printf("wrong in all: %d\n", bad);
  return bad != 0;
#else
  std::printf("no cell clusters in this build\n");
  return 0;
#endif
}
"""


def run_cell_pairs_driver(tmp_path, source):
    """Build and run a driver of the cell clusters for this CPU (-march=native,
    OpenMP); it prints "no cell clusters" where they do not compile (no AVX-512F
    and VL), and the test is skipped there."""
    out = build_and_run(tmp_path, source, "-march=native", "-fopenmp", units=("neighbours/grid.cpp",))
    assert out.returncode == 0, out.stdout + out.stderr
    if "no cell clusters" in out.stdout:
        pytest.skip("the cell clusters need AVX-512F and VL")
    return out


def test_pair_blocks_split_the_pairs_evenly(tmp_path):
    out = run_cell_pairs_driver(tmp_path, PAIR_DRIVER)
    assert "wrong in all: 0" in out.stdout, out.stdout
    assert "column, 2 blocks asked: 2 made" in out.stdout, out.stdout
