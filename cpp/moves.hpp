// A reordering given as block moves: each copies len entries from src to dst,
// every source read before any destination is written (the blocks may
// overlap). The sort gives one where few particles changed cell (grid.hpp),
// and the particles' state follows it in place (particles.hpp).
#pragma once

#include <algorithm>
#include <vector>

#include "types.hpp"

namespace sphfluid {

struct Move {
  Index src, dst, len;
};


// Applies the moves to a[], with tmp[] as scratch for the entries moved (as
// many as a[] holds at most: each entry moves once at most).
template <class T>
void apply_moves(const std::vector<Move>& moves, T* a, T* tmp) {
  T* t = tmp;
  for (const Move& m : moves) t = std::copy(a + m.src, a + m.src + m.len, t);
  t = tmp;
  for (const Move& m : moves) {
    std::copy(t, t + m.len, a + m.dst);
    t += m.len;
  }
}

// The same reordering as a permutation: order[k] = the entry that goes to k.
inline void moves_to_order(const std::vector<Move>& moves, Index n, std::vector<Index>& order) {
  order.resize(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) order[k] = k;
  for (const Move& m : moves)
    for (Index q = 0; q < m.len; ++q) order[m.dst + q] = m.src + q;
}

}  // namespace sphfluid
