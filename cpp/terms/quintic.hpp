// The quintic spline in 2D with support h (three smoothing lengths, s = 3r/h),
// wcsph's pressure kernel with solver.pressure_kernel "quintic" in a flow that
// is not shifted (docs/method-wcsph.md, eq. W31; Morris, Fox & Zhu 1997):
//   W = 7 / (478 pi (h/3)^2) [(3 - s)^5 - 6 (2 - s)^5 + 15 (1 - s)^5]
// (each power taken where its base is positive), its gradient factor
// W'(r)/r and its value, on any lane type; the interface of Wendland's
// (terms/wendland.hpp) that the pressure and the wall tables read.
#pragma once

#include "core/types.hpp"
#include "simd/lanes.hpp"

namespace sphfluid {

struct QuinticSpline {
  Real h, h2, inv_h;
  Real to_s;  // 3 / h: s per metre
  Real w;     // 7 / (478 pi (h/3)^2)
  Real grad;  // w to_s^2: W'(r) / r = grad P(s) / s

  explicit QuinticSpline(Real h_)
      : h(h_), h2(h_ * h_), inv_h(1 / h_), to_s(3 / h_),
        w(Real(7) / (Real(478) * kPi) * to_s * to_s), grad(w * to_s * to_s) {}

  template <class L>
  SPHFLUID_INLINE L value_of(L r) const {
    L a, b, c;
    pieces(r * simd::splat<L>(to_s), a, b, c);
    const L a2 = a * a, b2 = b * b, c2 = c * c;
    return simd::splat<L>(w) *
           simd::fmadd(simd::splat<L>(15) * c2, c2 * c,
                       simd::fnmadd(simd::splat<L>(6) * b2, b2 * b, a2 * a2 * a));
  }
  // W'(r) / r = w to_s^2 P(s) / s with P(s) = -5 (3-s)^4 + 30 (2-s)^4 - 75 (1-s)^4,
  // which vanishes at s = 0 (the quotient tends to -120 w to_s^2; below
  // s = 1e-6 it is divided by 1e-6 instead, and multiplies an r_ij of that size).
  template <class L>
  SPHFLUID_INLINE L gradient_factor(L r) const {
    const L s = r * simd::splat<L>(to_s);
    L a, b, c;
    pieces(s, a, b, c);
    const L a2 = a * a, b2 = b * b, c2 = c * c;
    const L p = simd::fmadd(simd::splat<L>(30) * b2, b2,
                            simd::fnmadd(simd::splat<L>(75) * c2, c2,
                                         simd::splat<L>(-5) * a2 * a2));
    const L tiny = simd::splat<L>(Real(1e-6));
    return simd::splat<L>(grad) * p / simd::max(s, tiny);
  }
  Real value(Real r) const { return value_of(r); }
  Vec2 gradient(const Vec2& r_ij, Real r) const { return gradient_factor(r) * r_ij; }

 private:
  template <class L>
  SPHFLUID_INLINE static void pieces(L s, L& a, L& b, L& c) {
    a = simd::max(simd::splat<L>(3) - s, simd::zero<L>());
    b = simd::max(simd::splat<L>(2) - s, simd::zero<L>());
    c = simd::max(simd::splat<L>(1) - s, simd::zero<L>());
  }
};

}  // namespace sphfluid
