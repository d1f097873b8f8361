// Counting sort of particles into cells and the cell-range neighbour search.
// Reads positions; writes the permutation, cell ranges and the CSR neighbour list.
#include "grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sphfluid {

void CellGrid::sort(const Vec2* x, Index n, Real cell, std::vector<Index>& order) {
  Vec2 lo(0, 0), hi(0, 0);
  if (n > 0) {
    lo = hi = x[0];
    for (Index i = 1; i < n; ++i) {
      lo = lo.cwiseMin(x[i]);
      hi = hi.cwiseMax(x[i]);
    }
  }
  inv_cell_ = 1 / cell;
  origin_ = lo;
  const double cx = std::floor((hi.x() - lo.x()) * inv_cell_) + 1;
  const double cy = std::floor((hi.y() - lo.y()) * inv_cell_) + 1;
  // The solver removes particles that leave the finite domain, and the scene
  // loader bounds the domain's cell count, so this only trips on a logic error.
  if (!(cx * cy < 2.0e9))
    throw std::runtime_error("cell grid of " + std::to_string(cx) + " x " + std::to_string(cy) +
                             " cells is too large");
  nx_ = static_cast<Index>(cx);
  ny_ = static_cast<Index>(cy);
  const std::size_t n_cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);

  unsorted_cell_.resize(n);
  cell_start_.assign(n_cells + 1, 0);
  for (Index i = 0; i < n; ++i) {
    const Index ix = std::min<Index>(static_cast<Index>((x[i].x() - lo.x()) * inv_cell_), nx_ - 1);
    const Index iy = std::min<Index>(static_cast<Index>((x[i].y() - lo.y()) * inv_cell_), ny_ - 1);
    const Index c = iy * nx_ + ix;
    unsorted_cell_[i] = c;
    ++cell_start_[c + 1];
  }
  for (std::size_t c = 0; c < n_cells; ++c) cell_start_[c + 1] += cell_start_[c];

  order.resize(n);
  cell_of_.resize(n);
  // Stable scatter: particles keep their relative order within a cell.
  cursor_.assign(cell_start_.begin(), cell_start_.end() - 1);
  for (Index i = 0; i < n; ++i) {
    const Index c = unsorted_cell_[i];
    const Index k = cursor_[c]++;
    order[k] = i;
    cell_of_[k] = c;
  }
}

void CellGrid::neighbours(const Vec2* x, Index n, Real h, int threads, Csr<Index>& out) const {
  const Real h2 = h * h;
  build_csr<Index>(n, threads, out, [&](Index i, std::vector<Index>& list) {
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
    list.resize(base + candidates);
    Index* out = list.data() + base;
    Index count = 0;
    for (Index yy = y0; yy <= y1; ++yy) {
      // Cells x0..x1 of one row are contiguous in the sorted storage.
      const Index j0 = cell_start_[yy * nx_ + x0], j1 = cell_start_[yy * nx_ + x1 + 1];
      for (Index j = j0; j < j1; ++j) {
        out[count] = j;
        count += static_cast<Index>(((xi - x[j]).squaredNorm() < h2) & (j != i));
      }
    }
    list.resize(base + count);
  });
}

}  // namespace sphfluid
