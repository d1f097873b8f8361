// The seed's 2D smoothing kernels (SPEC.md): poly6 (value, gradient, Laplacian),
// spiky (value, gradient) and the viscosity Laplacian, with Mueller's 3D kernels
// re-normalised for 2D. Built once from h; functions take r^2 where they can.
#pragma once

#include "core/types.hpp"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace sphfluid {

struct Kernels {
  Real h, h2;
  Real poly6, poly6_grad, poly6_lap;  // 4/(pi h^8), -24/(pi h^8), -48/(pi h^8)
  Real spiky, spiky_grad;             // 10/(pi h^5), -30/(pi h^5)
  Real visc_lap;                      // 40/(pi h^5)

  explicit Kernels(Real h_)
      : h(h_),
        h2(h_ * h_),
        poly6(4 / (kPi * pow8(h_))),
        poly6_grad(-24 / (kPi * pow8(h_))),
        poly6_lap(-48 / (kPi * pow8(h_))),
        spiky(10 / (kPi * pow5(h_))),
        spiky_grad(-30 / (kPi * pow5(h_))),
        visc_lap(40 / (kPi * pow5(h_))) {}

  // poly6: W = 4/(pi h^8) (h^2 - r^2)^3            (seed eq. 10)
  Real w_poly6(Real r2) const {
    const Real d = h2 - r2;
    return d > 0 ? poly6 * d * d * d : Real(0);
  }
  // w_poly6 as a function object, also on eight r^2 at once (the neighbour
  // filter's density; lanes with r >= h are the caller's to drop).
  struct Poly6OfR2 {
    // A polynomial in r^2, factor() times unscaled(r2) (cell_pairs.hpp sums
    // the unscaled weights and applies the factor once per particle).
    static constexpr bool kCheap = true;
    const Kernels* k;
    Real operator()(Real r2) const { return k->w_poly6(r2); }
    Real factor() const { return k->poly6; }
#if defined(__AVX512F__)
    __m512d operator()(__m512d r2) const {
      const __m512d d = _mm512_sub_pd(_mm512_set1_pd(k->h2), r2);
      return _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(_mm512_set1_pd(k->poly6), d), d), d);
    }
    __m512d unscaled(__m512d r2) const {  // (h^2 - r^2)^3
      const __m512d d = _mm512_sub_pd(_mm512_set1_pd(k->h2), r2);
      return _mm512_mul_pd(_mm512_mul_pd(d, d), d);
    }
#endif
  };
  // grad W = -24/(pi h^8) (h^2 - r^2)^2 r_ij         (colour-field normal)
  Vec2 grad_poly6(const Vec2& r_ij, Real r2) const {
    const Real d = h2 - r2;
    return d > 0 ? Vec2(poly6_grad * d * d * r_ij) : Vec2::Zero();
  }
  // lap W = -48/(pi h^8) (h^2 - r^2)(h^2 - 3 r^2)    (colour-field curvature)
  Real lap_poly6(Real r2) const {
    const Real d = h2 - r2;
    return d > 0 ? poly6_lap * d * (h2 - 3 * r2) : Real(0);
  }
  // spiky: W = 10/(pi h^5) (h - r)^3 (only its gradient enters the forces)
  Real w_spiky(Real r) const {
    const Real d = h - r;
    return d > 0 ? spiky * d * d * d : Real(0);
  }
  // grad W = -30/(pi h^5) (h - r)^2 r_ij / r, zero at r = 0   (seed eq. 14)
  Vec2 grad_spiky(const Vec2& r_ij, Real r) const {
    const Real d = h - r;
    return (d > 0 && r > 0) ? Vec2((spiky_grad * d * d / r) * r_ij) : Vec2::Zero();
  }
  // lap W_visc = 40/(pi h^5) (h - r)                (seed eq. 17)
  Real lap_visc(Real r) const {
    const Real d = h - r;
    return d > 0 ? visc_lap * d : Real(0);
  }

 private:
  static constexpr Real pow5(Real x) { return x * x * x * x * x; }
  static constexpr Real pow8(Real x) {
    const Real x2 = x * x, x4 = x2 * x2;
    return x4 * x4;
  }
};

}  // namespace sphfluid
