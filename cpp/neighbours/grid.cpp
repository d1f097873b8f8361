// Counting sort of particles into cells, and the resort that moves only the
// particles that changed cell (the neighbour lists are in lists.hpp). Reads
// positions; writes the permutation or the moves, and the cell ranges.
#include "neighbours/grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "core/room.hpp"
#include "simd/points.hpp"

namespace sphfluid {

CellGrid::Reorder CellGrid::sort(const Vec2* x, Index n, Real cell_size, int threads,
                                 std::vector<Index>& order, const PeriodicBox& box,
                                 bool in_last_order) {
  // Cells a hair larger than asked: the rounding of two cell coordinates then
  // cannot put two points closer than cell_size two cells apart (with up to
  // ~1e7 cells along an axis).
  cell_size *= 1 + 1e-8;
  const int nt = threads_for(n, threads);
  // The integration's look ahead (set_ahead) gives the bounding box, and the
  // cells below where the grid stays the same.
  const bool ahead = ahead_n_ == n && !box.any();
  ahead_n_ = -1;
  Vec2 lo = ahead_lo_, hi = ahead_hi_;
  if (!ahead) bounding_box(x, n, nt, lo, hi);
  const bool same = lay_out(n, lo, hi, cell_size, box, in_last_order);
  cell_in_.resize(n);
  if (same) {
    // The particles in the last sort's order: where few changed cell, they
    // are moved into place and the cell ranges adjusted (resort); else the
    // counting sort below, with these cells. With the look ahead, cell_in_
    // holds them already (ahead_cells).
    if (!ahead) {
      if (nt == 1) {
        cells_of(x, 0, n);
      } else {
#pragma omp parallel for schedule(static) num_threads(nt)
        for (int t = 0; t < nt; ++t) {
          const Share s = share_of(n, t, nt);
          cells_of(x, s.first, s.last);
        }
      }
    }
    if (resort(n, nt, ahead, order))
      return moves_.empty() && jumps_.empty() ? Reorder::kNone : Reorder::kMoves;
  }
  counting_sort(x, n, nt, same, order);
  return Reorder::kOrder;
}

// The bounding box, each thread over its share (std::min's rule: a NaN
// coordinate is passed over), eight points at a time where the lanes run.
void CellGrid::bounding_box(const Vec2* x, Index n, int nt, Vec2& lo, Vec2& hi) const {
  Real lx = 0, ly = 0, hx = 0, hy = 0;
  if (n > 0) {
    lx = hx = x[0].x();
    ly = hy = x[0].y();
  }
#pragma omp parallel num_threads(nt) reduction(min : lx, ly) reduction(max : hx, hy)
  {
    const Share mine = share_of(n, thread_rank(), thread_team_size());
    Index i = mine.first;
    const Index b1 = mine.last;
#if SPHFLUID_AVX512
    if constexpr (kVector8) {
      using simd::D8;
      D8 vlx = D8::splat(lx), vly = D8::splat(ly), vhx = D8::splat(hx), vhy = D8::splat(hy);
      for (; i + 8 <= b1; i += 8) {
        D8 px, py;
        simd::load_xy8(x[i].data(), px, py);
        vlx = min(px, vlx);  // p < v ? p : v, as std::min(v, p)
        vly = min(py, vly);
        vhx = max(px, vhx);
        vhy = max(py, vhy);
      }
      lx = simd::reduce_min(vlx);
      ly = simd::reduce_min(vly);
      hx = simd::reduce_max(vhx);
      hy = simd::reduce_max(vhy);
    }
#endif
    for (; i < b1; ++i) {
      lx = std::min(lx, x[i].x());
      ly = std::min(ly, x[i].y());
      hx = std::max(hx, x[i].x());
      hy = std::max(hy, x[i].y());
    }
  }
  lo = Vec2(lx, ly);
  hi = Vec2(hx, hy);
}

// The grid over the box [lo, hi]: its corner on a lattice of cells fixed in
// space (a whole number of cells from the coordinates' origin), not at the
// lowest particle, so that a particle changes cell only when it crosses a
// cell's edge, not when the bounding box moves, and the order changes little
// from step to step. A periodic axis spans the box with a whole number of
// cells of at least the cell size, so that the last cell borders the first
// across the seam.
bool CellGrid::lay_out(Index n, const Vec2& lo_box, const Vec2& hi, Real cell_size,
                       const PeriodicBox& box, bool in_last_order) {
  const Real inv_cell = 1 / cell_size;
  Vec2 lo(std::floor(lo_box.x() * inv_cell) * cell_size,
          std::floor(lo_box.y() * inv_cell) * cell_size);
  double cx = std::floor((hi.x() - lo.x()) * inv_cell) + 1;
  double cy = std::floor((hi.y() - lo.y()) * inv_cell) + 1;
  Vec2 inv(inv_cell, inv_cell);
  if (box.x) {
    lo.x() = box.lo.x();
    cx = std::max(1.0, std::floor(box.length.x() / cell_size));
    inv.x() = cx / box.length.x();
  }
  if (box.y) {
    lo.y() = box.lo.y();
    cy = std::max(1.0, std::floor(box.length.y() / cell_size));
    inv.y() = cy / box.length.y();
  }
  // The solver removes particles that leave the finite domain, and the scene
  // loader bounds the domain's cell count, so this only trips on a logic error.
  if (!(cx * cy < 2.0e9))
    throw std::runtime_error("cell grid of " + std::to_string(cx) + " x " + std::to_string(cy) +
                             " cells is too large");
  const Index nx = static_cast<Index>(cx), ny = static_cast<Index>(cy);
  const bool same = in_last_order && n == sorted_n_ && !box.any() && nx == nx_ && ny == ny_ &&
                    lo == lo_ && cell_size == width_;
  nx_ = nx;
  ny_ = ny;
  lo_ = lo;
  inv_ = inv;
  width_ = cell_size;
  inv_width_ = inv_cell;
  return same;
}

// cell_in_[i] for i in [b0, b1): truncation, then the clamps (both ways: a
// wrapped position may round to the box's far edge), eight at a time where
// the lanes run (the same arithmetic).
void CellGrid::cells_of(const Vec2* x, Index b0, Index b1) {
  Index* cell = cell_in_.data();
  Index i = b0;
#if SPHFLUID_AVX512
  if constexpr (kVector8 && sizeof(Index) == 4) {
    const Cells8 cells8(lo_, inv_, nx_, ny_);
    for (; i + 8 <= b1; i += 8) {
      simd::D8 px, py;
      simd::load_xy8(x[i].data(), px, py);
      cells8(px, py).store(cell + i);
    }
  }
#endif
  for (; i < b1; ++i) {
    const Vec2& p = x[i];
    const Index ix = clamp_cell((p.x() - lo_.x()) * inv_.x(), nx_ - 1);
    const Index iy = clamp_cell((p.y() - lo_.y()) * inv_.y(), ny_ - 1);
    cell[i] = iy * nx_ + ix;
  }
}

// The counting sort: the cell ranges, the permutation, and the cells in
// sorted order (for the next sort's resort, and the neighbour lists). The
// cells of the particles are in cell_in_ already where cells_known.
void CellGrid::counting_sort(const Vec2* x, Index n, int nt, bool cells_known,
                             std::vector<Index>& order) {
  const std::size_t n_cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  const Index* cell = cell_in_.data();
  cell_of_.resize(n);
  room(cell_start_, n_cells + 1);
  room(cursor_, static_cast<std::size_t>(nt) * n_cells + 1);
  cell_start_.assign(n_cells + 1, 0);
  order.resize(n);
  Index* sorted = cell_of_.data();
  Index* start = cell_start_.data();
  sorted_n_ = n;
  if (nt == 1) {
    if (!cells_known) cells_of(x, 0, n);
    for (Index i = 0; i < n; ++i) ++start[cell[i] + 1];
    for (std::size_t c = 0; c < n_cells; ++c) start[c + 1] += start[c];
    // Stable scatter: particles keep their relative order within a cell.
    cursor_.assign(cell_start_.begin(), cell_start_.end());  // (resort's scratch: n_cells + 1)
    for (Index i = 0; i < n; ++i) {
      const Index c = cell[i], k = cursor_[c]++;
      order[k] = i;
      sorted[k] = c;
    }
    return;
  }
  // Each thread counts its block of particles into its own histogram; a
  // thread's particles of a cell go after those of the threads before it, so
  // the scatter is stable as in the serial sort.
  cursor_.assign(static_cast<std::size_t>(nt) * n_cells, 0);
#pragma omp parallel num_threads(nt)
  {
    const int t = thread_rank(), team = thread_team_size();
    const auto [b0, b1] = share_of(n, t, team);
    Index* mine = cursor_.data() + static_cast<std::size_t>(t) * n_cells;
    if (!cells_known) cells_of(x, b0, b1);
    for (Index i = b0; i < b1; ++i) ++mine[cell[i]];
#pragma omp barrier
#pragma omp for schedule(static)
    for (std::size_t c = 0; c < n_cells; ++c) {
      Index sum = 0;
      for (int s = 0; s < team; ++s) {
        Index& k = cursor_[static_cast<std::size_t>(s) * n_cells + c];
        const Index count = k;
        k = sum;
        sum += count;
      }
      start[c + 1] = sum;
    }
#pragma omp single
    for (std::size_t c = 0; c < n_cells; ++c) start[c + 1] += start[c];
    for (Index i = b0; i < b1; ++i) {
      const Index c = cell[i], k = start[c] + mine[c]++;
      order[k] = i;
      sorted[k] = c;
    }
  }
}

// The particles are in the last sort's order and cell_in_ holds their cells
// now (the grid unchanged). The stable counting sort would keep every
// particle whose cell did not change (a stayer) in its order, and put each
// other one (a mover) among them by its cell and then its index: before the
// stayers of its new cell if it comes from below their range, after them if
// from above. So the stayers move as blocks, shifted by the movers taken out
// and put in before them, and the cell ranges change only between each
// mover's old cell and its new one.
bool CellGrid::resort(Index n, int threads, bool marked, std::vector<Index>& scratch) {
  moves_.clear();
  jumps_.clear();
  const int parts = threads > 1 ? threads : 1;
  if (cut_at_.capacity() < static_cast<std::size_t>(parts) + 1) {  // (no allocation later)
    for (auto* cuts : {&cut_at_, &parts_.at}) cuts->reserve(static_cast<std::size_t>(parts) + 1);
    for (auto* cuts : {&parts_.block, &parts_.jump})
      cuts->reserve(static_cast<std::size_t>(parts) + 1);
  }
  parts_.at.assign({0, n});
  if (skip_ > 0) {  // it gave up lately: not before this many sorts have gone by
    --skip_;
    return false;
  }
  // Where the counting sort costs less: many movers (n / 64 or more). Then
  // the next tries wait 1, 3 or 7 sorts. However far the movers shift the
  // stayers (each those between its old place and its new one by one: at 10k
  // particles in the dam break about 60 each, at 1M over a thousand), each
  // entry moves once at most, in runs, split between the threads
  // (MoveParts). Measured on the 10k dam break, seed-float, 2 threads: up to
  // n / 16 movers and moves of up to half the particles (the rule before the
  // parts), 5,000 fixed steps from t = 0.014 s as the flow splashes took
  // 27.9 us a step to sort and 1 s with adaptive steps (larger, so more
  // movers a step) 0.51-0.54 s; with no limit on the moves, 19.1 us but
  // 0.55-0.56 s (the resort's planning and jumps grow with the movers); up to
  // n / 64 movers and no limit on the moves, 19.5 us and 0.48-0.53 s.
  if (!find_movers(n, marked)) {
    moves_.clear();
    jumps_.clear();
    failures_ = std::min(failures_ + 1, 3);
    skip_ = (1 << failures_) - 1;
    return false;
  }
  if (!movers_.empty()) {  // else the order, the ranges and cell_of_ hold as they are
    plan_moves(n, parts);
    shift_cell_starts();
    cut_parts(parts, scratch);
  }
  failures_ = 0;
  return true;
}

// movers_: the particles whose cell changed (cell_in_ against cell_of_), in
// order, from the integration's marks where `marked`; false if they are
// n / 64 or more.
bool CellGrid::find_movers(Index n, bool marked) {
  const Index* now = cell_in_.data();
  const Index* was = cell_of_.data();
  // The scratch at its largest from the start: no allocation in later steps.
  const std::size_t most = static_cast<std::size_t>(n / 64) + 1;
  if (movers_.capacity() < most + 16) {
    movers_.reserve(most + 16);  // (the scans below stop a group of 16 early)
    inserts_.reserve(most);
    moves_.reserve(2 * most + 1);  // a block of stayers before and after each mover
    jumps_.reserve(most);
  }
  movers_.clear();
  bool full = false;  // more movers than movers_ holds
  if (marked) {  // the integration's marks, eight particles a byte
    const unsigned char* mark = ahead_moved_.data();
    const Index chunks = (n + 7) / 8;
    for (Index c = 0; c < chunks && !full; ++c) {
      for (unsigned b = mark[c]; b != 0; b &= b - 1)
        movers_.push_back(8 * c + static_cast<Index>(__builtin_ctz(b)));
      full = movers_.size() + 8 > movers_.capacity();
    }
  } else {
    Index k = 0;
#if SPHFLUID_AVX512
    if constexpr (sizeof(Index) == 4) {
      for (; k + 16 <= n && !full; k += 16) {
        for (unsigned m = simd::differ16(now + k, was + k); m != 0; m &= m - 1)
          movers_.push_back(k + static_cast<Index>(__builtin_ctz(m)));
        full = movers_.size() + 16 > movers_.capacity();
      }
    }
#endif
    for (; k < n && !full; ++k) {
      if (now[k] != was[k]) movers_.push_back(k);
      full = movers_.size() == movers_.capacity();
    }
  }
  return !full && movers_.size() < most;
}

// The moves: walk the input in order: the stayers before each event go on as
// a block, the movers put in before place e come before it, a mover at e
// leaves. Where as many movers have been put in as have left, all of them
// from before the current place, the entries before it stay among
// themselves: the moves can be cut into parts there (MoveParts), one a
// thread, each cut as near as can be to the thread's even share (cut_at_).
void CellGrid::plan_moves(Index n, int parts) {
  const Index* now = cell_in_.data();
  const Index* start = cell_start_.data();
  const std::size_t m = movers_.size();
  inserts_.clear();
  for (const Index i : movers_) {
    const Index c = now[i];
    inserts_.push_back({c, i, i < start[c] ? start[c] : start[c + 1]});
  }
  std::sort(inserts_.begin(), inserts_.end(), [](const Insert& a, const Insert& b) {
    return a.cell < b.cell || (a.cell == b.cell && a.index < b.index);
  });
  Index next = 0, out = 0;  // the next input place, the next output place
  Index last_in = -1;       // the largest input place of the movers put in so far
  first_cuts(n, parts);
  auto may_cut = [&](Index a, Index b) { offer_cuts(n, parts, a, b); };
  auto stayers_to = [&](Index e) {
    if (e > next) {
      if (out != next) moves_.push_back({next, out, e - next});
      out += e - next;
    }
    next = e;
  };
  std::size_t r = 0, q = 0;
  while (r < m || q < m) {
    const Index e = std::min(r < m ? movers_[r] : n, q < m ? inserts_[q].before : n);
    if (parts > 1 && q == r && last_in < next) may_cut(next, e);
    stayers_to(e);
    for (; q < m && inserts_[q].before == e; ++q, ++out) {
      last_in = std::max(last_in, inserts_[q].index);
      if (inserts_[q].index != out) jumps_.push_back({inserts_[q].index, out, 1});
    }
    if (r < m && movers_[r] == e) {
      ++next;
      ++r;
    }
  }
  if (parts > 1 && q == r && last_in < next) may_cut(next, n);
  stayers_to(n);
  if (out != n) throw std::logic_error("resort: the moves do not place every particle");
}

// cut_at_ before any place is offered: each thread's cut at the nearer of 0
// and n (always places to cut at).
void CellGrid::first_cuts(Index n, int parts) {
  cut_at_.assign(static_cast<std::size_t>(parts) + 1, 0);
  cut_at_[parts] = n;
  for (int t = 1; t < parts; ++t) {
    const Index goal = share_of(n, t, parts).first;
    cut_at_[t] = goal < n - goal ? 0 : n;
  }
}

// Places [a, b] are all places to cut at: each thread's cut moves to the one
// nearest its even share, if nearer than its cut so far.
void CellGrid::offer_cuts(Index n, int parts, Index a, Index b) {
  for (int t = 1; t < parts; ++t) {
    const Index goal = share_of(n, t, parts).first;
    const Index c = std::clamp(goal, a, b);
    if (std::abs(c - goal) < std::abs(cut_at_[t] - goal)) cut_at_[t] = c;
  }
}

// start[c] counts the particles in cells below c: each mover changes it
// between its old cell and its new one, cell by cell where that is short,
// else by a running sum over all cells.
void CellGrid::shift_cell_starts() {
  const Index* now = cell_in_.data();
  const Index* was = cell_of_.data();
  Index* start = cell_start_.data();
  const std::size_t n_cells = cell_start_.size() - 1;
  std::int64_t span = 0;  // cells crossed
  for (const Index i : movers_) span += std::abs(now[i] - was[i]);
  if (span <= static_cast<std::int64_t>(n_cells)) {
    for (const Index i : movers_) {
      const Index a = was[i], b = now[i];
      for (Index c = a + 1; c <= b; ++c) --start[c];
      for (Index c = b + 1; c <= a; ++c) ++start[c];
    }
    return;
  }
  room(cursor_, n_cells + 1);
  cursor_.assign(n_cells + 1, 0);  // how start[c]'s change differs from start[c - 1]'s
  for (const Index i : movers_) {
    --cursor_[was[i] + 1];
    ++cursor_[now[i] + 1];
  }
  Index change = 0;
  for (std::size_t c = 1; c <= n_cells; ++c) {
    change += cursor_[c];
    start[c] += change;
  }
}

// The parts: each list's moves with destinations before each cut; then the
// cells in the new order (the last sort's permutation, of n entries, holds
// the jumps' meanwhile), each part by its thread.
void CellGrid::cut_parts(int parts, std::vector<Index>& scratch) {
  parts_.at.assign(cut_at_.begin(), cut_at_.end());
  for (int t = 1; t < parts; ++t) parts_.at[t] = std::max(parts_.at[t], parts_.at[t - 1]);
  parts_.block.resize(static_cast<std::size_t>(parts) + 1);
  parts_.jump.resize(static_cast<std::size_t>(parts) + 1);
  auto before = [](const std::vector<Move>& list, Index at) {
    return static_cast<std::size_t>(
        std::lower_bound(list.begin(), list.end(), at,
                         [](const Move& mv, Index place) { return mv.dst < place; }) -
        list.begin());
  };
  for (int t = 0; t <= parts; ++t) {
    parts_.block[t] = before(moves_, parts_.at[t]);
    parts_.jump[t] = before(jumps_, parts_.at[t]);
  }
  if (parts > 1) {
#pragma omp parallel for schedule(static) num_threads(parts)
    for (int t = 0; t < parts; ++t)
      parts_.apply(t, moves_, jumps_, cell_in_.data(), scratch.data());
  } else {
    apply_moves(moves_, jumps_, cell_in_.data(), scratch.data());
  }
  cell_of_.swap(cell_in_);
}

}  // namespace sphfluid
