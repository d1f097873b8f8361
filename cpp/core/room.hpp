// Room in a vector for n entries, half as many again when it must grow: the
// arrays over a grid that follows the fluid's bounding box (the neighbour
// cells, the tension's nodes and bins) would otherwise reallocate at every
// step of a flow that spreads step by step (a dam break's front, a drop).
#pragma once

#include <cstddef>
#include <vector>

namespace sphfluid {

template <class T>
void room(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) v.reserve(n + n / 2);
}

}  // namespace sphfluid
