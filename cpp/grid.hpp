// Uniform cell grid over the particles' bounding box (cells of size h): a stable
// counting sort that yields the cell-ordered permutation, cell ranges with a guard
// entry, and the CSR neighbour list (all j != i with |r_ij| < h) built from them.
#pragma once

#include <vector>

#include "parallel.hpp"
#include "types.hpp"

namespace sphfluid {

class CellGrid {
 public:
  // Bin the n positions into cells of size `cell` and return in `order` the
  // stable cell-major permutation (order[k] = index of the k-th particle).
  void sort(const Vec2* x, Index n, Real cell, std::vector<Index>& order);

  // After the particles were permuted by `order`: neighbour list for radius h.
  void neighbours(const Vec2* x, Index n, Real h, int threads, Csr<Index>& out) const;

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
