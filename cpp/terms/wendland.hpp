// The Wendland C2 kernel in 2D with support h, wcsph's kernel (docs/method-wcsph.md,
// eq. W1): W = 7/(pi h^2) (1 - q)^4 (1 + 4q), q = r/h < 1, its gradient and
// Laplacian, and its value as a density weight of r^2 on any lane type.
#pragma once

#include <cmath>

#include "core/types.hpp"
#include "simd/lanes.hpp"

namespace sphfluid {

struct Wendland {
  Real h, h2, inv_h;
  Real w, grad, lap;  // 7/(pi h^2), -140/(pi h^4), -140/(pi h^4)

  explicit Wendland(Real h_)
      : h(h_), h2(h_ * h_), inv_h(1 / h_), w(7 / (kPi * h_ * h_)),
        grad(-140 / (kPi * h_ * h_ * h_ * h_)), lap(-140 / (kPi * h_ * h_ * h_ * h_)) {}

  // The kernel on any lane type, each written once (0 from q = 1 on):
  // a = max(1 - q, 0); W = w a^4 (1 + 4q); grad W = grad a^3 r_ij (no
  // division by r, finite at r = 0), of which gradient_factor is the factor.
  template <class L>
  SPHFLUID_INLINE L one_minus_q(L q) const {
    return simd::max(simd::splat<L>(1) - q, simd::zero<L>());
  }
  template <class L>
  SPHFLUID_INLINE L value_of(L r) const {
    const L q = r * simd::splat<L>(inv_h), a = one_minus_q(q), a2 = a * a;
    return simd::splat<L>(w) * a2 * a2 * simd::fmadd(simd::splat<L>(4), q, simd::splat<L>(1));
  }
  template <class L>
  SPHFLUID_INLINE L gradient_factor(L r) const {
    return gradient_times(simd::splat<L>(grad), r);
  }
  // c a^3 for a factor c that includes grad (a volume times it, say): the
  // gradient factor scaled, with one product fewer.
  template <class L>
  SPHFLUID_INLINE L gradient_times(L c, L r) const {
    const L a = one_minus_q(r * simd::splat<L>(inv_h));
    return c * a * a * a;
  }
  Real value(Real r) const { return value_of(r); }
  Vec2 gradient(const Vec2& r_ij, Real r) const { return gradient_factor(r) * r_ij; }
  // lap W = W'' + W'/r = -140/(pi h^4) (1 - q)^2 (2 - 5q)
  Real laplacian(Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return 0;
    const Real a = 1 - q;
    return lap * a * a * (2 - 5 * q);
  }
};

// wcsph eq. W2: a pair's weight in the density, W of r^2 on any lane type.
struct WendlandWeight {
  static constexpr bool kCheap = false;  // a square root: summed where r < h only
  Wendland k;
  explicit WendlandWeight(const Wendland& kernel) : k(kernel) {}
  template <class L>
  SPHFLUID_INLINE L operator()(L r2) const {
    return k.value_of(simd::sqrt(r2));
  }
};

}  // namespace sphfluid
