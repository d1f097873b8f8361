// Pair sums over neighbour lists (neighbours/lists.hpp), one scalar pair at a
// time: each pair once over the half lists, or every neighbour of each
// particle (the full lists, across periodic seams by minimum images). A
// visitor from the method does the arithmetic with its terms:
//   acc = v.begin(i); v.pair(acc, i, j, r_ij, r^2, mine) for each listed j;
//   v.end(i, acc)
// where `mine` says that j's share is this pair's to add (half lists: j after
// i within i's block). Each sum is taken in one order whatever the thread
// count. No physics here.
#pragma once

#include <algorithm>

#include "core/csr.hpp"
#include "core/types.hpp"

namespace sphfluid::pair_loops {

// The particles cut into blocks of `block` in storage order: within a block
// a pair's terms go to both particles (j's share added as the pair is met),
// and a pair across blocks is in both rows, each side taking its own share
// (the half lists hold exactly these). v.begin_block(lo, hi) runs first on
// each block, by the thread that then takes it.
template <class Visitor>
void once(const Csr<Index>& nbrs, const Vec2* x, Index n, Index block, int threads,
          Visitor& v) {
  const Index blocks = (n + block - 1) / block;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index b = 0; b < blocks; ++b) {
    const Index lo = b * block, hi = std::min(n, lo + block);
    v.begin_block(lo, hi);
    for (Index i = lo; i < hi; ++i) {
      auto acc = v.begin(i);
      const Vec2 xi = x[i];
      for (const Index j : nbrs.row(i)) {
        // The row holds j > i and the j of earlier blocks; a pair across
        // blocks is in both rows, and each side takes its own share.
        const Vec2 r = xi - x[j];
        v.pair(acc, i, j, r, r.squaredNorm(), j > i && j < hi);
      }
      v.end(i, acc);
    }
  }
}

// Each particle gathers from every neighbour on its full list; sep(a, b) is
// the separation a - b (a minimum image across periodic seams).
template <class Sep, class Visitor>
void gather(const Csr<Index>& nbrs, const Vec2* x, Index n, int threads, Sep sep, Visitor& v) {
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index i = 0; i < n; ++i) {
    auto acc = v.begin(i);
    const Vec2 xi = x[i];
    for (const Index j : nbrs.row(i)) {
      const Vec2 r = sep(xi, x[j]);
      v.pair(acc, i, j, r, r.squaredNorm(), false);
    }
    v.end(i, acc);
  }
}

}  // namespace sphfluid::pair_loops
