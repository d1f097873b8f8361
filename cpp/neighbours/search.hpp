// The neighbour search of a step, for every method: the particles sorted into
// cells (by moves where few changed cell), then either neighbour lists (full,
// half or across periodic seams) or the cell clusters' blocks, with the
// fluid part of each density summed in the same pass while the neighbours
// are in cache (the method's weight of r^2 and the particle mass).
#pragma once

#include <array>
#include <stdexcept>
#include <vector>

#include "core/periodic.hpp"
#include "core/csr.hpp"
#include "core/particles.hpp"
#include "core/timer.hpp"
#include "core/types.hpp"
#include "neighbours/cell_pairs.hpp"
#include "neighbours/grid.hpp"
#include "neighbours/lists.hpp"
#include "terms/density.hpp"

namespace sphfluid {

class NeighbourSearch {
 public:
  // The pair passes' blocks, a number that depends on n alone (so the sums
  // do not depend on the thread count): one up to kPairBlockMin particles, then
  // an even number, 2 ceil(n / (2 kPairBlockSize)) up to kPairBlocks, so that
  // two threads take equal shares. pair_block() is their size in particles
  // (the list loops); the cell clusters cut as near as whole cell rows allow.
  // A pair across two blocks is evaluated from each side, so blocks cost: at
  // 10k particles 2 blocks (of ~8k at most) ran 3.5 % faster than 10 (of ~1k)
  // on one thread, 4.8 % on two.
  static constexpr Index kPairBlocks = 16, kPairBlockMin = 1024, kPairBlockSize = 8192;
  static Index pair_blocks(Index n) {
    if (n <= kPairBlockMin) return 1;
    return static_cast<Index>(std::min<std::int64_t>(
        kPairBlocks, 2 * ((std::int64_t(n) + 2 * kPairBlockSize - 1) / (2 * kPairBlockSize))));
  }
  static Index pair_block(Index n) {
    return std::max<Index>(1, (n + pair_blocks(n) - 1) / pair_blocks(n));
  }

  // The particles into cell order (the sort phase). h: the cell size.
  void sort(ParticleSet& ps, Real h, int threads, const PeriodicBox& box, PhaseTimer& timer) {
    const CellGrid::Reorder how =
        grid_.sort(ps.x.data(), ps.size(), h, threads, order_, box, in_sort_order_);
    switch (how) {
      case CellGrid::Reorder::kNone:
        break;
      case CellGrid::Reorder::kMoves:
        ps.apply_moves(grid_.moves(), grid_.jumps(), grid_.move_parts(), order_, threads);
        break;
      case CellGrid::Reorder::kOrder:
        ps.permute_state(order_, threads);
        break;
    }
    ++sort_counts_[static_cast<int>(how)];
    if (how == CellGrid::Reorder::kMoves && grid_.move_parts().split()) ++sort_counts_[3];
    in_sort_order_ = true;
    timer.mark(kSort);
  }

  // Sorts the particles, builds the neighbour lists for support h, and sums
  // the fluid part of each density, rho_i = m (w(0) + sum_j w(r_ij^2)), in
  // the same pass; w is the method's weight of r^2. With Once, the lists are
  // the half lists of the pair-once loops (each pair within a pair block
  // stored once); with Periodic, minimum images across the box's seams. The
  // sums go to ps.rho, or to `sums` (n entries) when given.
  template <bool Periodic, bool Once, class WeightOfR2>
  void lists(ParticleSet& ps, Real h, Real m, int threads, const PeriodicBox& box, WeightOfR2 w,
             PhaseTimer& timer, Real* sums = nullptr) {
    static_assert(!(Periodic && Once), "the periodic seams keep full lists");
    const Index n = ps.size();
    sort(ps, h, threads, box, timer);
    const Vec2* x = ps.x.data();
    Real* rho = sums ? sums : ps.rho.data();
    const Real self = w(Real(0));
    half_lists_ = Once;
    cell_pair_count_ = -1;
    if constexpr (Periodic) {
      lists::periodic(grid_, x, n, h, threads, box, nbrs_,
                      [&](Index i, const Index* nbr, Index count) {
                        const Vec2 xi = x[i];
                        Real sum = self;
                        for (Index q = 0; q < count; ++q)
                          sum += w(box.delta(xi, x[nbr[q]]).squaredNorm());
                        rho[i] = summation_density(m, 0, sum);
                      });
    } else if constexpr (Once) {
      // rho[] carries the weights within a block until each row is done.
      lists::half(grid_, x, n, h, threads, pair_block(n), nbrs_, rho, w,
                  [&](Index i, Real sum) { rho[i] = summation_density(m, self, sum); });
    } else {
      lists::full(grid_, x, n, h, threads, nbrs_, w,
                  [&](Index i, const Index*, Index, Real sum) {
                    rho[i] = summation_density(m, self, sum);
                  });
    }
    timer.mark(kNeighbours);
  }

  // The same by cell clusters (cell_pairs.hpp): no lists; the blocks of cell
  // rows are cut afresh from the sorted particles. The sums go to ps.rho, or
  // to `sums` (n entries) when given.
  template <class WeightOfR2>
  void clusters(ParticleSet& ps, Real h, Real m, int threads, WeightOfR2 w, PhaseTimer& timer,
                Real* sums = nullptr) {
#if SPHFLUID_AVX512
    if constexpr (CellPairs::kAvailable) {
      const Index n = ps.size();
      sort(ps, h, threads, PeriodicBox(), timer);
      half_lists_ = false;
      cells_.make_blocks(grid_, n, pair_blocks(n));
      cell_pair_count_ = cells_.density(grid_, ps.x.data(), h, m, w(Real(0)), w,
                                        sums ? sums : ps.rho.data(), threads);
      timer.mark(kNeighbours);
      return;
    }
#endif
    (void)ps, (void)h, (void)m, (void)threads, (void)w, (void)timer, (void)sums;
    throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
  }

  // The particles no longer in the last sort's order (added, removed, or
  // replaced): the next sort starts afresh.
  void forget_order() {
    in_sort_order_ = false;
    grid_.drop_ahead();
  }

  const CellGrid& grid() const { return grid_; }
  CellGrid& grid() { return grid_; }
  const CellPairs& cells() const { return cells_; }
  const Csr<Index>& lists() const { return nbrs_; }
  // Whether lists() holds this evaluation's half lists for n particles.
  bool has_half_lists(Index n) const { return half_lists_ && nbrs_.rows() == n; }

  // Total number of neighbour pairs (i, j), j != i, of the last evaluation.
  std::int64_t pairs() const {
    if (cell_pair_count_ >= 0) return 2 * cell_pair_count_;
    if (!half_lists_) return nbrs_.total();
    // Each pair is in the row of its first particle (and, across blocks, also
    // in its second's): count each once, and both directions, over the rows of
    // that evaluation (particles may have left the domain since).
    std::int64_t pairs = 0;
    for (Index i = 0; i < nbrs_.rows(); ++i)
      for (const Index j : nbrs_.row(i)) pairs += j > i;
    return 2 * pairs;
  }
  // Sorts since the search was made, by what they did to the order: none
  // changed, few particles moved in place, or a full permutation
  // (CellGrid::Reorder); then how many of the moves were cut into parts for
  // the threads.
  const std::array<std::int64_t, 4>& sort_counts() const { return sort_counts_; }
  std::size_t sort_bytes() const { return grid_.bytes() + order_.capacity() * sizeof(Index); }
  std::size_t list_bytes() const { return nbrs_.bytes() + cells_.bytes(); }

 private:
  CellGrid grid_;
  std::vector<Index> order_;
  // The particles are in the order of the grid's last sort, only moved since
  // (the next sort may then move just those that changed cell).
  bool in_sort_order_ = false;
  std::array<std::int64_t, 4> sort_counts_{};
  Csr<Index> nbrs_;
  bool half_lists_ = false;  // nbrs_ holds lists::half's lists
  CellPairs cells_;
  std::int64_t cell_pair_count_ = -1;  // pairs of the last evaluation by cells, else -1
};

}  // namespace sphfluid
