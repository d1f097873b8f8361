// Counting sort of particles into cells (the neighbour search is in grid.hpp).
// Reads positions; writes the permutation and the cell ranges.
#include "grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sphfluid {

void CellGrid::sort(const Vec2* x, Index n, Real cell_size, int threads,
                    std::vector<Index>& order, const PeriodicBox& box) {
  Vec2 lo(0, 0), hi(0, 0);
  if (n > 0) {
    lo = hi = x[0];
    for (Index i = 1; i < n; ++i) {
      lo = lo.cwiseMin(x[i]);
      hi = hi.cwiseMax(x[i]);
    }
  }
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
  const std::size_t n_cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);

  // cell_of_ first holds each particle's cell in input order, then (below) in
  // sorted order: one array of n instead of two.
  cell_of_.resize(n);
  cell_start_.assign(n_cells + 1, 0);
  Index* cell = cell_of_.data();
  const Index nx = nx_, ny = ny_;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index i = 0; i < n; ++i) {
    // Clamped both ways: a wrapped position may round to the box's far edge.
    const Index ix = std::clamp<Index>(static_cast<Index>((x[i].x() - lo.x()) * inv.x()), 0, nx - 1);
    const Index iy = std::clamp<Index>(static_cast<Index>((x[i].y() - lo.y()) * inv.y()), 0, ny - 1);
    cell[i] = iy * nx + ix;
  }
  for (Index i = 0; i < n; ++i) ++cell_start_[cell[i] + 1];
  for (std::size_t c = 0; c < n_cells; ++c) cell_start_[c + 1] += cell_start_[c];

  order.resize(n);
  // Stable scatter: particles keep their relative order within a cell.
  cursor_.assign(cell_start_.begin(), cell_start_.end() - 1);
  for (Index i = 0; i < n; ++i) order[cursor_[cell[i]]++] = i;
  // Sorted, the cells are the runs of cell_start_.
  for (std::size_t c = 0; c < n_cells; ++c)
    std::fill(cell + cell_start_[c], cell + cell_start_[c + 1], static_cast<Index>(c));
}

}  // namespace sphfluid
