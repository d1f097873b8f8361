// The optional terms a scene may use, as compile-time flags, and the table of
// a step's instantiations over every set of them, generated rather than
// listed: a method's step is specialised once per feature set (unused terms
// compiled out with `if constexpr`), and the one a scene needs is picked once.
#pragma once

#include <array>
#include <cstddef>
#include <utility>

namespace sphfluid {

enum Feature : unsigned {
  kViscosity = 1u << 0,       // eta > 0
  kSurfaceTension = 1u << 1,  // sigma > 0
  kWalls = 1u << 2,           // at least one wall segment
  kPeriodic = 1u << 3,        // the domain wraps along x and/or y
};
constexpr unsigned kNumFeatureSets = 16;

// Whether a step with these features evaluates each fluid pair once, from half
// neighbour lists or cell clusters: not across periodic seams (minimum
// images), which keep full lists and the gather loop.
constexpr bool pairs_once(unsigned features) { return (features & kPeriodic) == 0; }

namespace features {
template <class Entry, class Fn, std::size_t... F>
constexpr std::array<Fn*, sizeof...(F)> table(std::index_sequence<F...>) {
  return {&Entry::template run<static_cast<unsigned>(F)>...};
}
}  // namespace features

// Entry::run<F> for every feature set F, as pointers of type Fn*, indexed by F.
template <class Entry, class Fn>
constexpr std::array<Fn*, kNumFeatureSets> feature_table() {
  return features::table<Entry, Fn>(std::make_index_sequence<kNumFeatureSets>{});
}

}  // namespace sphfluid
