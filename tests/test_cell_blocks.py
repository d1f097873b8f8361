"""The blocks of cell rows in which the cell-cluster loops evaluate each pair
once (CellPairs::make_blocks), checked in a small program: they start at row
boundaries, in order, and each cut falls at the first row boundary at or past
its share k n / count, so the first of two threads' halves holds at most one
row more than n / 2.
The cuts depend on the sorted particles alone (the thread-identity tests check
the sums)."""
from __future__ import annotations

from test_walls_native import build_and_run

DRIVER = r"""
#include <algorithm>
#include <cstdio>
#include <vector>
#include "cell_pairs.hpp"
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
    out = build_and_run(tmp_path, DRIVER, units=("grid.cpp",))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "wrong in all: 0" in out.stdout
    assert "column, 10 blocks asked: 10 made" in out.stdout, out.stdout
