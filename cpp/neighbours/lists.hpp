// Neighbour lists (CSR rows) from a sorted cell grid: full (every j != i with
// |r_ij| < h), half (each pair within a block of particles once) and across
// periodic seams (minimum images). Each builder also sums a weight of r^2
// over the particle's neighbours while the candidates are in cache (the
// method's density weight); no physics here beyond calling it.
#pragma once

#include <algorithm>

#include "core/periodic.hpp"
#include "core/csr.hpp"
#include "core/types.hpp"
#include "neighbours/grid.hpp"
#include "simd/ints.hpp"
#include "simd/points.hpp"

namespace sphfluid::lists {

// Whether the candidates are filtered eight at a time (and the weights summed
// there); else a scalar filter that leaves the weights to the caller.
constexpr bool kVectorFilter = kVector8;
constexpr Index kSlack = 8;  // a filter may write 8 lanes past its hits

// The weight sum of one particle: eight lanes where the vector filter runs,
// and a scalar for the scalar loop.
struct Sum {
#if SPHFLUID_AVX512
  simd::D8 lanes = simd::zero<simd::D8>();
#endif
  Real scalar = 0;
  Real total() const {
#if SPHFLUID_AVX512
    return reduce_add(lanes) + scalar;
#else
    return scalar;
#endif
  }
};

// Appends to found[count..] the j in [j0, j1), j != i, with |x_i - x_j|^2 < h2,
// and (kVectorFilter) adds w(|x_i - x_j|^2) of each to sum; returns the new
// count. found has room for j1 - j0 + kSlack more entries. With Carry (a run
// after i), the weight of each hit j < carry_end is also added to acc[j]
// (kVectorFilter; the scalar filter leaves the weights to its caller).
template <bool Carry = false, class WeightOfR2>
Index filter_run(const Vec2* x, const Vec2& xi, Index i, Index j0, Index j1, Real h2,
                 const WeightOfR2& w, Index* found, Index count, Sum& sum, Index carry_end = 0,
                 Real* acc = nullptr) {
  Index j = j0;
#if SPHFLUID_AVX512
  if constexpr (kVectorFilter) {
    using simd::D8;
    // Eight candidates at a time: de-interleave their x and y, compare, and
    // compress the indices of the hits into found (same order as the scalar
    // loop); the last, partial group through masked loads (its unused lanes
    // are never hits).
    const D8 cx = D8::splat(xi.x()), cy = D8::splat(xi.y()), limit = D8::splat(h2);
    const simd::I8 lanes = simd::I8::iota();
    for (; j < j1; j += 8) {
      const std::int64_t left = j1 - j;
      const double* p = x[j].data();
      D8 px, py;
      if (left >= 8) {
        simd::load_xy8(p, px, py);
      } else {
        simd::load_xy(p, simd::Span8(left), px, py);
      }
      const D8 dx = px - cx, dy = py - cy;
      const D8 d2 = simd::fmadd(dx, dx, dy * dy);
      simd::Mask8 hit = simd::lt(simd::first_lanes(left), d2, limit);
      if (static_cast<unsigned>(i - j) < 8u) hit &= static_cast<simd::Mask8>(~(1u << (i - j)));
      const D8 wv = w(d2);
      sum.lanes = mask_add(sum.lanes, hit, sum.lanes, wv);
      if constexpr (Carry) {
        // Candidates are consecutive particles: their acc is one vector.
        const simd::Mask8 carry = hit & simd::first_lanes(carry_end - j);
        (D8::load(acc + j, carry) + wv).store(acc + j, carry);
      }
      // Compress in a register, then store all eight lanes (found has 8
      // entries of slack beyond the candidates): a compress straight to
      // memory is microcoded on some CPUs (measured 2x slower here).
      compress(hit, simd::I8::splat(j) + lanes).store(found + count);
      count += static_cast<Index>(simd::count(hit));
    }
  }
#endif
  (void)w;
  (void)sum;
  (void)carry_end;
  (void)acc;
  for (; j < j1; ++j) {  // branch-free: write every candidate, keep the hits
    found[count] = j;
    count += static_cast<Index>(((xi - x[j]).squaredNorm() < h2) & (j != i));
  }
  return count;
}

// After the particles were sorted on `grid`: the full neighbour lists for
// radius h. visit(i, nbrs, count, sum) runs right after particle i's list is
// built, with sum = the sum of w(|r_ij|^2) over its neighbours, taken in the
// same pass over the candidates. w(r2) is called with a Real, and, where the
// vector filter runs, with a D8 of eight r2.
template <class WeightOfR2, class Visit>
void full(const CellGrid& grid, const Vec2* x, Index n, Real h, int threads, Csr<Index>& out,
          WeightOfR2 w, Visit visit) {
  const Real h2 = h * h;
  const Index nx = grid.nx(), ny = grid.ny();
  const Index* cell_of = grid.sorted_cells();
  const Index* start = grid.cell_starts();
  out.build(n, threads, [&](Index i, Chunk<Index>& list) {
    const Index c = cell_of[i];
    const Index cy = c / nx, cx = c - cy * nx;
    const Index x0 = std::max<Index>(cx - 1, 0), x1 = std::min<Index>(cx + 1, nx - 1);
    const Index y0 = std::max<Index>(cy - 1, 0), y1 = std::min<Index>(cy + 1, ny - 1);
    const Vec2 xi = x[i];
    // Branch-free: write every candidate, advance only for real neighbours.
    Index candidates = 0;
    for (Index yy = y0; yy <= y1; ++yy)
      candidates += start[yy * nx + x1 + 1] - start[yy * nx + x0];
    const std::size_t base = list.size();
    Index* found = list.extend(candidates + kSlack);
    Index count = 0;
    Sum sum;
    for (Index yy = y0; yy <= y1; ++yy) {
      // Cells x0..x1 of one row are contiguous in the sorted storage.
      const Index j0 = start[yy * nx + x0], j1 = start[yy * nx + x1 + 1];
      count = filter_run(x, xi, i, j0, j1, h2, w, found, count, sum);
    }
    list.resize(base + count);
    if constexpr (!kVectorFilter) {
      // The scalar filter keeps only the hits: their weights are summed
      // here, over the ~10 neighbours instead of the ~36 candidates.
      for (Index q = 0; q < count; ++q) sum.scalar += w((xi - x[found[q]]).squaredNorm());
    }
    visit(i, found, count, sum.total());
  });
}

// Half lists, for evaluating each pair once over blocks of `block` particles
// in storage order (block b holds [b block, (b + 1) block)): row i holds its
// neighbours j > i and those in earlier blocks (j < lo, the first particle of
// i's block). A pair within a block is stored once, in its first particle's
// row; a pair across blocks in both rows. Candidates come from half the
// cells: the row below only for earlier blocks, i's own row of cells from
// i + 1 on (and before lo), the row above in full. Each thread builds whole
// blocks, in order. The weight sums cover every neighbour: acc (n entries,
// overwritten) carries the weights of the pairs within a block to their
// second particle, and visit(i, sum) runs with i's whole sum, before any
// later row of the block, so acc may be the array visit writes.
template <class WeightOfR2, class Visit>
void half(const CellGrid& grid, const Vec2* x, Index n, Real h, int threads, Index block,
          Csr<Index>& out, Real* acc, WeightOfR2 w, Visit visit) {
  const Real h2 = h * h;
  const Index nx = grid.nx(), ny = grid.ny();
  const Index* cell_of = grid.sorted_cells();
  const Index* row_start = grid.cell_starts();
  out.build_blocks(n, threads, block, [&](Index i, Chunk<Index>& list, Index lo, Index hi) {
    if (i == lo) std::fill(acc + lo, acc + hi, Real(0));
    const Index c = cell_of[i];
    const Index cy = c / nx, cx = c - cy * nx;
    const Index x0 = std::max<Index>(cx - 1, 0), x1 = std::min<Index>(cx + 1, nx - 1);
    // Four runs of storage, the first two before lo (empty but at a
    // block's first rows of cells) and the last two after i, whose
    // weights within the block are carried on to acc.
    const Index b0 = cy > 0 ? row_start[(cy - 1) * nx + x0] : 0;
    const Index b1 = cy > 0 ? std::min(row_start[(cy - 1) * nx + x1 + 1], lo) : 0;
    const Index r0 = row_start[cy * nx + x0], r1 = row_start[cy * nx + x1 + 1];
    const Index s1 = std::min(r1, lo);
    const Index a0 = cy + 1 < ny ? row_start[(cy + 1) * nx + x0] : 0;
    const Index a1 = cy + 1 < ny ? row_start[(cy + 1) * nx + x1 + 1] : 0;
    const Index candidates = std::max<Index>(b1 - b0, 0) + std::max<Index>(s1 - r0, 0) +
                             (r1 - i - 1) + (a1 - a0);
    const std::size_t base = list.size();
    Index* found = list.extend(candidates + kSlack);
    const Vec2 xi = x[i];
    Sum sum;
    Index count = filter_run(x, xi, i, b0, b1, h2, w, found, 0, sum);
    count = filter_run(x, xi, i, r0, s1, h2, w, found, count, sum);
    count = filter_run<true>(x, xi, i, i + 1, r1, h2, w, found, count, sum, hi, acc);
    count = filter_run<true>(x, xi, i, a0, a1, h2, w, found, count, sum, hi, acc);
    list.resize(base + count);
    if constexpr (!kVectorFilter) {
      for (Index q = 0; q < count; ++q) {
        const Index j = found[q];
        const Real wj = w((xi - x[j]).squaredNorm());
        sum.scalar += wj;
        if (j > i && j < hi) acc[j] += wj;
      }
    }
    visit(i, sum.total() + acc[i]);
  });
}

// Full lists across the periodic seams of the box given to the grid's sort:
// separations are minimum images, and a periodic axis needs a box length of
// at least 2 h so that no pair meets twice. visit(i, nbrs, count).
template <class Visit>
void periodic(const CellGrid& grid, const Vec2* x, Index n, Real h, int threads,
              const PeriodicBox& box, Csr<Index>& out, Visit visit) {
  const Real h2 = h * h;
  const Index nx = grid.nx();
  const Index* cell_of = grid.sorted_cells();
  out.build(n, threads, [&](Index i, Chunk<Index>& list) {
    const Index c = cell_of[i];
    const Index cy = c / nx, cx = c - cy * nx;
    CellGrid::Span cols[2], rows[2];
    const int n_cols = CellGrid::around(cx, nx, box.x, cols);
    const int n_rows = CellGrid::around(cy, grid.ny(), box.y, rows);
    Index candidates = 0;
    grid.for_cells(rows, n_rows, cols, n_cols, [&](Index j0, Index j1) { candidates += j1 - j0; });
    const std::size_t base = list.size();
    Index* found = list.extend(candidates);
    Index count = 0;
    const Vec2 xi = x[i];
    grid.for_cells(rows, n_rows, cols, n_cols, [&](Index j0, Index j1) {
      for (Index j = j0; j < j1; ++j) {
        found[count] = j;
        count += static_cast<Index>((box.delta(xi, x[j]).squaredNorm() < h2) & (j != i));
      }
    });
    list.resize(base + count);
    visit(i, found, count);
  });
}

}  // namespace sphfluid::lists
