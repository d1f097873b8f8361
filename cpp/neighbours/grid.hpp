// Uniform cell grid over the particles' bounding box (cells of size h): a stable
// counting sort that yields the cell-ordered permutation, cell ranges with a guard
// entry, and the CSR neighbour lists built from them: full (all j != i with
// |r_ij| < h) or half (each pair within a block of particles once).
// Along a periodic axis the grid spans the box exactly (cells of at least h)
// and the neighbour cells wrap around.
#pragma once

#include <algorithm>
#include <vector>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "neighbours/moves.hpp"
#include "core/parallel.hpp"
#include "boundary/periodic.hpp"
#include "core/types.hpp"

namespace sphfluid {

class CellGrid {
 public:
  // How sort() reorders the particles.
  enum class Reorder { kNone, kMoves, kOrder };

  // Bins the n positions into cells of size `cell_size` for the stable
  // cell-major order: particles by cell, those of a cell in their input order.
  // Returns kOrder with the permutation in `order` (order[k] = index of the
  // k-th particle), or, where `in_last_order` says the particles are those
  // of the last sort in its order (moved since, nothing else) and the grid is
  // the same, kNone if no particle changed cell, or kMoves with moves() that
  // reorder them, when few did (`order` then served as scratch).
  // The sort uses the threads from kParallelMin particles on (parallel.hpp).
  // Along box's periodic axes the positions must lie in the box. The cells are
  // made 1e-8 larger than cell_size (see grid.cpp).
  Reorder sort(const Vec2* x, Index n, Real cell_size, int threads, std::vector<Index>& order,
               const PeriodicBox& box = PeriodicBox(), bool in_last_order = false);
  // kMoves: the blocks that shift and the single particles that jump
  // (apply_moves in moves.hpp).
  const std::vector<Move>& moves() const { return moves_; }
  const std::vector<Move>& jumps() const { return jumps_; }
  // The same moves cut into parts of disjoint ranges, one for each thread.
  const MoveParts& move_parts() const { return parts_; }

#if defined(__AVX512F__)
  // The cells of eight points on a grid with corner lo, inverse cell widths
  // inv and nx x ny cells, as sort() computes them: truncation, then the
  // clamps.
  struct Cells8 {
    __m512d lox, loy, invx, invy;
    __m256i width, last_x, last_y;
    Cells8(const Vec2& lo, const Vec2& inv, Index nx, Index ny)
        : lox(_mm512_set1_pd(lo.x())),
          loy(_mm512_set1_pd(lo.y())),
          invx(_mm512_set1_pd(inv.x())),
          invy(_mm512_set1_pd(inv.y())),
          width(_mm256_set1_epi32(nx)),
          last_x(_mm256_set1_epi32(nx - 1)),
          last_y(_mm256_set1_epi32(ny - 1)) {}
    __m256i operator()(__m512d x, __m512d y) const {
      const __m256i zero = _mm256_setzero_si256();
      const __m256i tx = _mm512_cvttpd_epi32(_mm512_mul_pd(_mm512_sub_pd(x, lox), invx));
      const __m256i ty = _mm512_cvttpd_epi32(_mm512_mul_pd(_mm512_sub_pd(y, loy), invy));
      const __m256i ix = _mm256_min_epi32(_mm256_max_epi32(tx, zero), last_x);
      const __m256i iy = _mm256_min_epi32(_mm256_max_epi32(ty, zero), last_y);
      return _mm256_add_epi32(_mm256_mullo_epi32(iy, width), ix);
    }
  };
  // This grid's (a grid over no periodic axis).
  Cells8 cells8() const { return Cells8(lo_, Vec2(inv_width_, inv_width_), nx_, ny_); }
#endif
  // A look ahead for the next sort, from the integration that moves the
  // particles (over no periodic axis): the new positions' bounding box and,
  // written into ahead_cells(n), their cells on this grid. The next sort of n
  // particles takes the box, and the cells and marks if the grid stays the
  // same (a particle outside it changes the box, so none was clamped).
  // Anything else that moves or reorders the particles drops it.
  // Whether the last sort was of n particles on a grid of cells: only then
  // do sorted_cells() hold n entries to compare against.
  bool can_look_ahead(Index n) const { return n > 0 && sorted_n_ == n && n_cells() > 0; }
  Index* ahead_cells(Index n) {
    cell_in_.resize(n);
    ahead_moved_.resize(static_cast<std::size_t>(n) / 8 + 1);
    return cell_in_.data();
  }
  // ... and for each eight particles from 8 k on, ahead_moved()[k] marks
  // those whose cell differs from sorted_cells() (the last sort's).
  unsigned char* ahead_moved() { return ahead_moved_.data(); }
  const Index* sorted_cells() const { return cell_of_.data(); }
  void set_ahead(Index n, const Vec2& lo, const Vec2& hi) {
    ahead_n_ = n;
    ahead_lo_ = lo;
    ahead_hi_ = hi;
  }
  void drop_ahead() { ahead_n_ = -1; }

  // After the particles were permuted by `order`: neighbour list for radius h.
  // visit(i, nbrs, count, sum) runs right after particle i's list is built,
  // with sum = the sum of w(|r_ij|^2) over its neighbours, taken in the same
  // pass over the candidates (the solver's density). w(r2) is called with a
  // Real, and, where the AVX-512 filter runs, with a __m512d of eight r2.
  template <class WeightOfR2, class Visit>
  void neighbours(const Vec2* x, Index n, Real h, int threads, Csr<Index>& out, WeightOfR2 w,
                  Visit visit) const {
    const Real h2 = h * h;
    out.build(n, threads, [&](Index i, Chunk<Index>& list) {
      const Index c = cell_of_[i];
      const Index cy = c / nx_, cx = c - cy * nx_;
      const Index x0 = std::max<Index>(cx - 1, 0), x1 = std::min<Index>(cx + 1, nx_ - 1);
      const Index y0 = std::max<Index>(cy - 1, 0), y1 = std::min<Index>(cy + 1, ny_ - 1);
      const Vec2 xi = x[i];
      // Branch-free: write every candidate, advance only for real neighbours.
      Index candidates = 0;
      for (Index yy = y0; yy <= y1; ++yy)
        candidates += cell_start_[yy * nx_ + x1 + 1] - cell_start_[yy * nx_ + x0];
      const std::size_t base = list.size();
      Index* found = list.extend(candidates + kSlack);
      Index count = 0;
      Sum sum;
      for (Index yy = y0; yy <= y1; ++yy) {
        // Cells x0..x1 of one row are contiguous in the sorted storage.
        const Index j0 = cell_start_[yy * nx_ + x0], j1 = cell_start_[yy * nx_ + x1 + 1];
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
  void neighbours_once(const Vec2* x, Index n, Real h, int threads, Index block, Csr<Index>& out,
                       Real* acc, WeightOfR2 w, Visit visit) const {
    const Real h2 = h * h;
    out.build_blocks(n, threads, block, [&](Index i, Chunk<Index>& list, Index lo, Index hi) {
      if (i == lo) std::fill(acc + lo, acc + hi, Real(0));
      const Index c = cell_of_[i];
      const Index cy = c / nx_, cx = c - cy * nx_;
      const Index x0 = std::max<Index>(cx - 1, 0), x1 = std::min<Index>(cx + 1, nx_ - 1);
      // Four runs of storage, the first two before lo (empty but at a
      // block's first rows of cells) and the last two after i, whose
      // weights within the block are carried on to acc.
      const Index* row_start = cell_start_.data();
      const Index b0 = cy > 0 ? row_start[(cy - 1) * nx_ + x0] : 0;
      const Index b1 = cy > 0 ? std::min(row_start[(cy - 1) * nx_ + x1 + 1], lo) : 0;
      const Index r0 = row_start[cy * nx_ + x0], r1 = row_start[cy * nx_ + x1 + 1];
      const Index s1 = std::min(r1, lo);
      const Index a0 = cy + 1 < ny_ ? row_start[(cy + 1) * nx_ + x0] : 0;
      const Index a1 = cy + 1 < ny_ ? row_start[(cy + 1) * nx_ + x1 + 1] : 0;
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

  // The same across the periodic seams of the box given to sort(): separations
  // are minimum images, and a periodic axis needs a box length of at least 2 h
  // so that no pair meets twice.
  template <class Visit>
  void neighbours_periodic(const Vec2* x, Index n, Real h, int threads, const PeriodicBox& box,
                           Csr<Index>& out, Visit visit) const {
    const Real h2 = h * h;
    out.build(n, threads, [&](Index i, Chunk<Index>& list) {
      const Index c = cell_of_[i];
      const Index cy = c / nx_, cx = c - cy * nx_;
      Span cols[2], rows[2];
      const int n_cols = around(cx, nx_, box.x, cols), n_rows = around(cy, ny_, box.y, rows);
      Index candidates = 0;
      for_cells(rows, n_rows, cols, n_cols, [&](Index j0, Index j1) { candidates += j1 - j0; });
      const std::size_t base = list.size();
      Index* found = list.extend(candidates);
      Index count = 0;
      const Vec2 xi = x[i];
      for_cells(rows, n_rows, cols, n_cols, [&](Index j0, Index j1) {
        for (Index j = j0; j < j1; ++j) {
          found[count] = j;
          count += static_cast<Index>((box.delta(xi, x[j]).squaredNorm() < h2) & (j != i));
        }
      });
      list.resize(base + count);
      visit(i, found, count);
    });
  }

  std::size_t bytes() const {
    return (cell_start_.capacity() + cell_of_.capacity() + cell_in_.capacity() +
            cursor_.capacity() + movers_.capacity()) *
               sizeof(Index) +
           ahead_moved_.capacity() +
           inserts_.capacity() * sizeof(Insert) +
           (moves_.capacity() + jumps_.capacity()) * sizeof(Move);
  }
  Index nx() const { return nx_; }
  Index ny() const { return ny_; }
  std::size_t n_cells() const { return cell_start_.empty() ? 0 : cell_start_.size() - 1; }
  // Particles of cell c (after the permutation): [cell_start(c), cell_start(c + 1)).
  Index cell_start(std::size_t c) const { return cell_start_[c]; }
  const Index* cell_starts() const { return cell_start_.data(); }
  // Along a non-periodic axis the sort puts a position p in the cell
  // (p - origin) * inv_width(), truncated and clamped to the grid: cells of
  // width cell_width(), a hair more than the size asked (a periodic axis
  // spans its box instead).
  const Vec2& origin() const { return lo_; }
  Real cell_width() const { return width_; }
  Real inv_width() const { return inv_width_; }

 private:
  static constexpr Index kSlack = 8;  // filter_run may write 8 lanes past its hits
  // Whether filter_run takes eight candidates at a time (and sums the weights).
  static constexpr bool kVectorFilter = kVector8;

  // The weight sum of one particle: eight lanes where the AVX-512 filter runs,
  // and a scalar for the scalar loop.
  struct Sum {
#if defined(__AVX512F__)
    __m512d lanes = _mm512_setzero_pd();
#endif
    Real scalar = 0;
    Real total() const {
#if defined(__AVX512F__)
      return _mm512_reduce_add_pd(lanes) + scalar;
#else
      return scalar;
#endif
    }
  };

  // Appends to found[count..] the j in [j0, j1), j != i, with |x_i - x_j|^2 < h2,
  // and (kVectorFilter) adds w(|x_i - x_j|^2) of each to sum; returns the new
  // count. found has room for j1 - j0 + kSlack more entries.
  // With Carry (a run after i), the weight of each hit j < carry_end is also
  // added to acc[j] (kVectorFilter; the scalar filter leaves the weights to its caller).
  template <bool Carry = false, class WeightOfR2>
  static Index filter_run(const Vec2* x, const Vec2& xi, Index i, Index j0, Index j1, Real h2,
                          const WeightOfR2& w, Index* found, Index count, Sum& sum,
                          Index carry_end = 0, Real* acc = nullptr) {
    Index j = j0;
#if defined(__AVX512F__)
    if constexpr (kVectorFilter) {
      // Eight candidates at a time: de-interleave their x and y, compare, and
      // compress the indices of the hits into found (same order as the scalar loop).
      const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
      const __m512d cx = _mm512_set1_pd(xi.x()), cy = _mm512_set1_pd(xi.y());
      const __m512d limit = _mm512_set1_pd(h2);
      // Eight candidates at a time; the last, partial group through masked
      // loads (its unused lanes are never hits).
      for (; j < j1; j += 8) {
        const Index left = j1 - j;
        const double* p = x[j].data();
        __m512d lo, hi;
        __mmask8 valid = 0xFF;
        if (left >= 8) {
          lo = _mm512_loadu_pd(p);
          hi = _mm512_loadu_pd(p + 8);
        } else {
          const unsigned doubles = 2u * static_cast<unsigned>(left);  // 2 .. 14
          lo = _mm512_maskz_loadu_pd(static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1), p);
          hi = _mm512_maskz_loadu_pd(
              static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1), p + 8);
          valid = static_cast<__mmask8>((1u << left) - 1);
        }
        const __m512d dx = _mm512_sub_pd(x_of8(lo, hi), cx);
        const __m512d dy = _mm512_sub_pd(y_of8(lo, hi), cy);
        const __m512d d2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
        __mmask8 hit = _mm512_mask_cmp_pd_mask(valid, d2, limit, _CMP_LT_OQ);
        if (static_cast<unsigned>(i - j) < 8u) hit &= static_cast<__mmask8>(~(1u << (i - j)));
        const __m512d wv = w(d2);
        sum.lanes = _mm512_mask_add_pd(sum.lanes, hit, sum.lanes, wv);
        if constexpr (Carry) {
          // Candidates are consecutive particles: their acc is one vector.
          const Index room = carry_end - j;  // lanes [0, room) are in i's block
          const __mmask8 carry =
              hit & (room >= 8 ? 0xFF : room > 0 ? static_cast<__mmask8>((1u << room) - 1) : 0);
          _mm512_mask_storeu_pd(acc + j, carry,
                                _mm512_add_pd(_mm512_maskz_loadu_pd(carry, acc + j), wv));
        }
        // Compress in a register, then store all eight lanes (found has 8
        // entries of slack beyond the candidates): a compress straight to
        // memory is microcoded on some CPUs (measured 2x slower here).
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(found + count),
                            _mm256_maskz_compress_epi32(
                                hit, _mm256_add_epi32(_mm256_set1_epi32(j), lanes)));
        count += static_cast<Index>(__builtin_popcount(hit));
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

  struct Span {
    Index first, last;  // inclusive cell indices along one axis
  };
  // The cells next to cell c (of nc along the axis), as one or two runs of
  // consecutive indices; a wrapping axis of fewer than 3 cells is one run of all.
  static int around(Index c, Index nc, bool wrap, Span* runs) {
    if (!wrap) {
      runs[0] = {std::max<Index>(c - 1, 0), std::min<Index>(c + 1, nc - 1)};
      return 1;
    }
    if (nc < 3) {
      runs[0] = {0, nc - 1};
      return 1;
    }
    if (c == 0) {
      runs[0] = {0, 1};
      runs[1] = {nc - 1, nc - 1};
      return 2;
    }
    if (c == nc - 1) {
      runs[0] = {0, 0};
      runs[1] = {nc - 2, nc - 1};
      return 2;
    }
    runs[0] = {c - 1, c + 1};
    return 1;
  }
  // f(j0, j1) for the storage range of each row's run of cells.
  template <class F>
  void for_cells(const Span* rows, int n_rows, const Span* cols, int n_cols, F f) const {
    for (int r = 0; r < n_rows; ++r)
      for (Index yy = rows[r].first; yy <= rows[r].last; ++yy)
        for (int k = 0; k < n_cols; ++k)
          f(cell_start_[yy * nx_ + cols[k].first], cell_start_[yy * nx_ + cols[k].last + 1]);
  }

  Index nx_ = 0, ny_ = 0;
  Vec2 lo_ = Vec2::Zero();
  Real width_ = 0, inv_width_ = 0;
  std::vector<Index> cell_start_;  // n_cells + 1 (last entry is the guard)
  // Where few particles changed cell since the last sort (same n and grid):
  // moves that put them in place, or false where too many did; scratch holds
  // n entries.
  bool resort(Index n, int threads, bool marked, std::vector<Index>& scratch);

  std::vector<Index> cell_of_;     // cell of each particle, in sorted order
  std::vector<Index> cell_in_;     // cell of each particle, in input order
  std::vector<Index> cursor_;  // scatter position per cell (per thread and cell)
  Index sorted_n_ = -1;        // particles of the last sort (-1: none yet)
  Index ahead_n_ = -1;         // set_ahead's particles (-1: no look ahead)
  Vec2 ahead_lo_ = Vec2::Zero(), ahead_hi_ = Vec2::Zero();
  std::vector<unsigned char> ahead_moved_;  // by eight particles
  // resort's scratch: the particles that changed cell (by input index), where
  // each goes (its cell, index, and the input place it goes before), and the
  // moves.
  struct Insert {
    Index cell, index, before;
  };
  int failures_ = 0, skip_ = 0;  // resort's give-ups in a row; sorts it still waits
  std::vector<Index> movers_;
  std::vector<Insert> inserts_;
  std::vector<Move> moves_, jumps_;
  MoveParts parts_;
  std::vector<Index> cut_at_;  // resort's cuts so far
};

}  // namespace sphfluid
