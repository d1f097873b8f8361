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

  Real value(Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return 0;
    const Real a = 1 - q, a2 = a * a;
    return w * a2 * a2 * (1 + 4 * q);
  }
  // grad W = -140/(pi h^4) (1 - q)^3 r_ij: no division by r, finite at r = 0.
  Vec2 gradient(const Vec2& r_ij, Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return Vec2::Zero();
    const Real a = 1 - q;
    return (grad * a * a * a) * r_ij;
  }
  // lap W = W'' + W'/r = -140/(pi h^4) (1 - q)^2 (2 - 5q)
  Real laplacian(Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return 0;
    const Real a = 1 - q;
    return lap * a * a * (2 - 5 * q);
  }
};

// wcsph eq. W2: a pair's weight in the density, W of r^2 on any lane type
// (value(), the same arithmetic; 0 where rounding puts r / h at 1 or past).
struct WendlandWeight {
  static constexpr bool kCheap = false;  // a square root: summed where r < h only
  Real inv_h, w;
  explicit WendlandWeight(const Wendland& k) : inv_h(k.inv_h), w(k.w) {}
  template <class L>
  SPHFLUID_INLINE L operator()(L r2) const {
    const L q = simd::sqrt(r2) * simd::splat<L>(inv_h);
    const L a = simd::max(simd::splat<L>(1) - q, simd::zero<L>()), a2 = a * a;
    return simd::splat<L>(w) * a2 * a2 * simd::fmadd(simd::splat<L>(4), q, simd::splat<L>(1));
  }
};

}  // namespace sphfluid
