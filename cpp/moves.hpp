// A reordering given as moves: each takes len entries from src to dst. The
// sort gives one where few particles changed cell (grid.hpp), and the
// particles' state follows it in place (particles.hpp).
#pragma once

#include <algorithm>
#include <initializer_list>
#include <vector>

#include "types.hpp"

namespace sphfluid {

struct Move {
  Index src, dst, len;
};

// A reordering in place (CellGrid::resort): blocks that shift, in the order
// of their destinations, which do not overlap, and jumps of single entries.
// tmp[] holds the jumps' entries meanwhile. A block's source may lie under
// the destination of another only where that cannot hurt: under a block
// shifted down, no later block's source (the blocks keep their order) and no
// earlier one shifted up (it sits below its destination); likewise up. So
// the blocks shifted down go first, in order, then those shifted up, in
// reverse order, each copied in the direction that spares its own source;
// the jumps' sources are saved first and their destinations written last.
template <class T>
void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps, T* a, T* tmp) {
  for (std::size_t k = 0; k < jumps.size(); ++k) tmp[k] = a[jumps[k].src];
  for (const Move& b : blocks)
    if (b.dst < b.src) std::copy(a + b.src, a + b.src + b.len, a + b.dst);
  for (auto b = blocks.rbegin(); b != blocks.rend(); ++b)
    if (b->dst > b->src) std::copy_backward(a + b->src, a + b->src + b->len, a + b->dst + b->len);
  for (std::size_t k = 0; k < jumps.size(); ++k) a[jumps[k].dst] = tmp[k];
}

// The same reordering as a permutation: order[k] = the entry that goes to k.
inline void moves_to_order(const std::vector<Move>& blocks, const std::vector<Move>& jumps,
                           Index n, std::vector<Index>& order) {
  order.resize(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) order[k] = k;
  for (const std::vector<Move>* moves : {&blocks, &jumps})
    for (const Move& m : *moves)
      for (Index q = 0; q < m.len; ++q) order[m.dst + q] = m.src + q;
}

}  // namespace sphfluid
