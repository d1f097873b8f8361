// Counting sort of particles into cells (the neighbour search is in grid.hpp).
// Reads positions; writes the permutation and the cell ranges.
#include "grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sphfluid {

void CellGrid::sort(const Vec2* x, Index n, Real cell_size, int threads,
                    std::vector<Index>& order, const PeriodicBox& box, bool cells_in_order) {
  // Cells a hair larger than asked: the rounding of two cell coordinates then
  // cannot put two points closer than cell_size two cells apart (with up to
  // ~1e7 cells along an axis).
  cell_size *= 1 + 1e-8;
  const int nt = threads_for(n, threads);
  Real lx = 0, ly = 0, hx = 0, hy = 0;
  if (n > 0) {
    lx = hx = x[0].x();
    ly = hy = x[0].y();
  }
  // The bounding box, each thread over its share (std::min's rule: a NaN
  // coordinate is passed over), eight points at a time where AVX-512 runs.
#pragma omp parallel num_threads(nt) reduction(min : lx, ly) reduction(max : hx, hy)
  {
    const Share mine = share_of(n, thread_rank(), thread_team_size());
    Index i = mine.first;
    const Index b1 = mine.last;
#if defined(__AVX512F__)
    if constexpr (kVector8) {
      __m512d vlx = _mm512_set1_pd(lx), vly = _mm512_set1_pd(ly);
      __m512d vhx = _mm512_set1_pd(hx), vhy = _mm512_set1_pd(hy);
      for (; i + 8 <= b1; i += 8) {
        const double* p = reinterpret_cast<const double*>(x + i);
        const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8);
        const __m512d px = x_of8(a, b), py = y_of8(a, b);
        vlx = _mm512_min_pd(px, vlx);  // px < vlx ? px : vlx, as std::min(vlx, px)
        vly = _mm512_min_pd(py, vly);
        vhx = _mm512_max_pd(px, vhx);
        vhy = _mm512_max_pd(py, vhy);
      }
      lx = _mm512_reduce_min_pd(vlx);
      ly = _mm512_reduce_min_pd(vly);
      hx = _mm512_reduce_max_pd(vhx);
      hy = _mm512_reduce_max_pd(vhy);
    }
#endif
    for (; i < b1; ++i) {
      lx = std::min(lx, x[i].x());
      ly = std::min(ly, x[i].y());
      hx = std::max(hx, x[i].x());
      hy = std::max(hy, x[i].y());
    }
  }
  Vec2 lo(lx, ly);
  const Vec2 hi(hx, hy);
  const Real inv_cell = 1 / cell_size;
  double cx = std::floor((hi.x() - lo.x()) * inv_cell) + 1;
  double cy = std::floor((hi.y() - lo.y()) * inv_cell) + 1;
  // A periodic axis spans the box with a whole number of cells of at least the
  // cell size, so that the last cell borders the first across the seam.
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
  nx_ = static_cast<Index>(cx);
  ny_ = static_cast<Index>(cy);
  lo_ = lo;
  width_ = cell_size;
  inv_width_ = inv_cell;
  const std::size_t n_cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);

  // cell_of_ first holds each particle's cell in input order, then (below,
  // with cells_in_order) in sorted order: one array of n instead of two.
  cell_of_.resize(n);
  cell_start_.assign(n_cells + 1, 0);
  order.resize(n);
  Index* cell = cell_of_.data();
  Index* start = cell_start_.data();
  const Index nx = nx_, ny = ny_;
  auto cell_index = [&](const Vec2& p) {
    // Clamped both ways: a wrapped position may round to the box's far edge.
    const Index ix = std::clamp<Index>(static_cast<Index>((p.x() - lo.x()) * inv.x()), 0, nx - 1);
    const Index iy = std::clamp<Index>(static_cast<Index>((p.y() - lo.y()) * inv.y()), 0, ny - 1);
    return iy * nx + ix;
  };
  // cell[i] = cell_index(x[i]) for i in [b0, b1), eight at a time where
  // AVX-512 runs (the same arithmetic: truncation, then the clamps).
  auto cells_of = [&](Index b0, Index b1) {
    Index i = b0;
#if defined(__AVX512F__)
    if constexpr (kVector8 && sizeof(Index) == 4) {
      const __m512d lox = _mm512_set1_pd(lo.x()), loy = _mm512_set1_pd(lo.y());
      const __m512d invx = _mm512_set1_pd(inv.x()), invy = _mm512_set1_pd(inv.y());
      const __m256i zero = _mm256_setzero_si256(), width = _mm256_set1_epi32(nx);
      const __m256i last_x = _mm256_set1_epi32(nx - 1), last_y = _mm256_set1_epi32(ny - 1);
      for (; i + 8 <= b1; i += 8) {
        const double* p = reinterpret_cast<const double*>(x + i);
        const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8);
        const __m256i tx =
            _mm512_cvttpd_epi32(_mm512_mul_pd(_mm512_sub_pd(x_of8(a, b), lox), invx));
        const __m256i ty =
            _mm512_cvttpd_epi32(_mm512_mul_pd(_mm512_sub_pd(y_of8(a, b), loy), invy));
        const __m256i ix = _mm256_min_epi32(_mm256_max_epi32(tx, zero), last_x);
        const __m256i iy = _mm256_min_epi32(_mm256_max_epi32(ty, zero), last_y);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(cell + i),
                            _mm256_add_epi32(_mm256_mullo_epi32(iy, width), ix));
      }
    }
#endif
    for (; i < b1; ++i) cell[i] = cell_index(x[i]);
  };
  if (nt == 1) {
    cells_of(0, n);
    for (Index i = 0; i < n; ++i) ++start[cell[i] + 1];
    for (std::size_t c = 0; c < n_cells; ++c) start[c + 1] += start[c];
    // Stable scatter: particles keep their relative order within a cell.
    cursor_.assign(cell_start_.begin(), cell_start_.end() - 1);
    for (Index i = 0; i < n; ++i) order[cursor_[cell[i]]++] = i;
  } else {
    // Each thread counts its block of particles into its own histogram; a
    // thread's particles of a cell go after those of the threads before it,
    // so the scatter is stable as in the serial sort.
    cursor_.assign(static_cast<std::size_t>(nt) * n_cells, 0);
#pragma omp parallel num_threads(nt)
    {
      const int t = thread_rank(), team = thread_team_size();
      const auto [b0, b1] = share_of(n, t, team);
      Index* mine = cursor_.data() + static_cast<std::size_t>(t) * n_cells;
      cells_of(b0, b1);
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
      for (Index i = b0; i < b1; ++i) order[start[cell[i]] + mine[cell[i]]++] = i;
    }
  }
  if (!cells_in_order) return;
  // Sorted, the cells are the runs of cell_start_.
#pragma omp parallel for schedule(static) num_threads(nt)
  for (std::size_t c = 0; c < n_cells; ++c)
    std::fill(cell + start[c], cell + start[c + 1], static_cast<Index>(c));
}

}  // namespace sphfluid
