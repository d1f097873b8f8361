// Uniform cell grid over the particles' bounding box (cells of size h): a stable
// counting sort that yields the cell-ordered permutation (or, where few
// particles changed cell, the moves that put them in place) and the cell
// ranges with a guard entry, which the neighbour lists and the cell clusters
// read. Along a periodic axis the grid spans the box exactly (cells of at
// least h) and the neighbour cells wrap around.
#pragma once

#include <algorithm>
#include <vector>

#include "core/periodic.hpp"
#include "core/parallel.hpp"
#include "core/types.hpp"
#include "core/moves.hpp"
#include "simd/ints.hpp"

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

#if SPHFLUID_AVX512
  // The cells of eight points on a grid with corner lo, inverse cell widths
  // inv and nx x ny cells, as sort() computes them: truncation, then the
  // clamps.
  struct Cells8 {
    simd::D8 lox, loy, invx, invy;
    simd::I8 width, last_x, last_y;
    Cells8(const Vec2& lo, const Vec2& inv, Index nx, Index ny)
        : lox(simd::D8::splat(lo.x())),
          loy(simd::D8::splat(lo.y())),
          invx(simd::D8::splat(inv.x())),
          invy(simd::D8::splat(inv.y())),
          width(simd::I8::splat(nx)),
          last_x(simd::I8::splat(nx - 1)),
          last_y(simd::I8::splat(ny - 1)) {}
    simd::I8 operator()(simd::D8 x, simd::D8 y) const {
      const simd::I8 zero = simd::I8::splat(0);
      const simd::I8 ix = min(max(simd::truncate((x - lox) * invx), zero), last_x);
      const simd::I8 iy = min(max(simd::truncate((y - loy) * invy), zero), last_y);
      return iy * width + ix;
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
  //
  // can_look_ahead: whether the last sort was of n particles on a grid of
  // cells (only then do sorted_cells() hold n entries to compare against).
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
  // Particles of cell c (after the permutation): [cell_starts()[c], cell_starts()[c + 1]).
  const Index* cell_starts() const { return cell_start_.data(); }
  // Along a non-periodic axis the sort puts a position p in the cell
  // (p - origin) * inv_width(), truncated and clamped to the grid: cells of
  // width cell_width(), a hair more than the size asked (a periodic axis
  // spans its box instead).
  const Vec2& origin() const { return lo_; }
  Real cell_width() const { return width_; }
  Real inv_width() const { return inv_width_; }

  // Runs of cells for the periodic lists (neighbours/lists.hpp).
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

 private:
  // sort()'s parts: the bounding box of the positions (or the look ahead's),
  // the grid over it (returns whether it is the last sort's grid for the same
  // particles), the cells of particles [b0, b1), and the counting sort.
  void bounding_box(const Vec2* x, Index n, int nt, Vec2& lo, Vec2& hi) const;
  bool lay_out(Index n, const Vec2& lo, const Vec2& hi, Real cell_size, const PeriodicBox& box,
               bool in_last_order);
  void cells_of(const Vec2* x, Index b0, Index b1);
  void counting_sort(const Vec2* x, Index n, int nt, bool cells_known, std::vector<Index>& order);
  // resort()'s parts: the particles that changed cell (false where there are
  // too many), the moves that put them in place (with the places where they
  // may be cut into parts), the cell ranges after them, and the parts.
  bool find_movers(Index n, bool marked);
  void plan_moves(Index n, int parts);
  void first_cuts(Index n, int parts);
  void offer_cuts(Index n, int parts, Index a, Index b);
  void shift_cell_starts();
  void cut_parts(int parts, std::vector<Index>& scratch);

  Index nx_ = 0, ny_ = 0;
  Vec2 lo_ = Vec2::Zero();
  Vec2 inv_ = Vec2::Zero();  // the inverse cell widths (a periodic axis spans its box)
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
