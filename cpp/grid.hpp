// Uniform cell grid over the particles' bounding box (cells of size h): a stable
// counting sort that yields the cell-ordered permutation, cell ranges with a guard
// entry, and the CSR neighbour list (all j != i with |r_ij| < h) built from them.
#pragma once

#include <algorithm>
#include <vector>

#include "parallel.hpp"
#include "types.hpp"

namespace sphfluid {

class CellGrid {
 public:
  // Bin the n positions into cells of size `cell` and return in `order` the
  // stable cell-major permutation (order[k] = index of the k-th particle).
  void sort(const Vec2* x, Index n, Real cell_size, int threads, std::vector<Index>& order);

  // After the particles were permuted by `order`: neighbour list for radius h.
  // visit(i, nbrs, count) runs right after particle i's list is built, while
  // its neighbours are still in cache (the solver sums densities there).
  template <class Visit>
  void neighbours(const Vec2* x, Index n, Real h, int threads, Csr<Index>& out,
                  Visit visit) const {
    const Real h2 = h * h;
    build_csr<Index>(n, threads, out, [&](Index i, Chunk<Index>& list) {
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
      Index* found = list.extend(candidates);
      Index count = 0;
      for (Index yy = y0; yy <= y1; ++yy) {
        // Cells x0..x1 of one row are contiguous in the sorted storage.
        const Index j0 = cell_start_[yy * nx_ + x0], j1 = cell_start_[yy * nx_ + x1 + 1];
        for (Index j = j0; j < j1; ++j) {
          found[count] = j;
          count += static_cast<Index>(((xi - x[j]).squaredNorm() < h2) & (j != i));
        }
      }
      list.resize(base + count);
      visit(i, found, count);
    });
  }

  Index nx() const { return nx_; }
  Index ny() const { return ny_; }
  std::size_t n_cells() const { return cell_start_.empty() ? 0 : cell_start_.size() - 1; }
  // Particles of cell c (after the permutation): [cell_start(c), cell_start(c + 1)).
  Index cell_start(std::size_t c) const { return cell_start_[c]; }

 private:
  Vec2 origin_{0, 0};
  Real inv_cell_ = 1;
  Index nx_ = 0, ny_ = 0;
  std::vector<Index> cell_start_;  // n_cells + 1 (last entry is the guard)
  std::vector<Index> cell_of_;     // cell of each particle, in sorted order
  std::vector<Index> unsorted_cell_;  // cell of each particle before sorting
  std::vector<Index> cursor_;         // scatter position per cell
};

}  // namespace sphfluid
