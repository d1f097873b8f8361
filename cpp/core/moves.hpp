// A reordering given as moves: each takes len entries from src to dst. The
// sort gives one where few particles changed cell (grid.hpp), and the
// particles' state follows it in place (particles.hpp).
#pragma once

#include <algorithm>
#include <initializer_list>
#include <vector>

#include "core/types.hpp"

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
void apply_moves(const Move* blocks, std::size_t n_blocks, const Move* jumps,
                 std::size_t n_jumps, T* a, T* tmp) {
  for (std::size_t k = 0; k < n_jumps; ++k) tmp[k] = a[jumps[k].src];
  for (std::size_t k = 0; k < n_blocks; ++k) {
    const Move& b = blocks[k];
    if (b.dst < b.src) std::copy(a + b.src, a + b.src + b.len, a + b.dst);
  }
  for (std::size_t k = n_blocks; k-- > 0;) {
    const Move& b = blocks[k];
    if (b.dst > b.src) std::copy_backward(a + b.src, a + b.src + b.len, a + b.dst + b.len);
  }
  for (std::size_t k = 0; k < n_jumps; ++k) a[jumps[k].dst] = tmp[k];
}
template <class T>
void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps, T* a, T* tmp) {
  apply_moves(blocks.data(), blocks.size(), jumps.data(), jumps.size(), a, tmp);
}

// The moves cut into parts that touch disjoint ranges of entries, so that
// each can be applied by a thread of its own, the same reordering in place:
// part t is blocks [block[t], block[t + 1]) and jumps [jump[t], jump[t + 1]),
// all of whose sources and destinations lie in [at[t], at[t + 1]). Both lists
// are in the order of their destinations, so each part's moves are a run of
// each. The cuts are where the reordering keeps the entries before them
// among themselves (CellGrid::resort finds them).
struct MoveParts {
  std::vector<Index> at;                 // parts + 1 cut places: 0, ..., n
  std::vector<std::size_t> block, jump;  // parts + 1 list indices each
  int count() const { return static_cast<int>(at.size()) - 1; }
  // Whether a cut falls inside the entries (more than one part holds any).
  bool split() const {
    for (int t = 1; t < count(); ++t)
      if (at[t] > at.front() && at[t] < at.back()) return true;
    return false;
  }
  // Apply part t to a, with tmp as apply_moves' (jumps().size() entries).
  template <class T>
  void apply(int t, const std::vector<Move>& blocks, const std::vector<Move>& jumps, T* a,
             T* tmp) const {
    apply_moves(blocks.data() + block[t], block[t + 1] - block[t], jumps.data() + jump[t],
                jump[t + 1] - jump[t], a, tmp + jump[t]);
  }
};

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
