// Per-particle data read into lanes for the pair sums: a traversal's group of
// lanes (or one lane, Span1, for the list loops) from arrays of double or
// float, velocities interleaved as the particles hold them or in two arrays.
// No physics here.
#pragma once

#include "core/types.hpp"
#include "simd/points.hpp"

namespace sphfluid {

// One lane at a time, as the list loops take their pairs.
struct Span1 {
  bool lanes = true;
};

// Velocities stored interleaved (the particles' own, in double) ...
struct InterleavedVelocity {
  const Vec2* v;
  template <class L, class S>
  SPHFLUID_INLINE void group(Index j, const S& s, L& vx, L& vy) const {
    if constexpr (simd::kLanes<L> == 1) {
      (void)s;
      vx = v[j].x();
      vy = v[j].y();
    } else {
#if SPHFLUID_AVX512
      simd::load_xy(v[j].data(), s, vx, vy);
#endif
    }
  }
  Real x(Index i) const { return v[i].x(); }
  Real y(Index i) const { return v[i].y(); }
};
// ... or in two arrays (the float copies).
template <class T>
struct SplitVelocity {
  const T* vx;
  const T* vy;
  template <class L, class S>
  SPHFLUID_INLINE void group(Index j, const S& s, L& x, L& y) const {
    x = simd::load<L>(vx + j, s.lanes);
    y = simd::load<L>(vy + j, s.lanes);
  }
  T x(Index i) const { return vx[i]; }
  T y(Index i) const { return vy[i]; }
};

}  // namespace sphfluid
