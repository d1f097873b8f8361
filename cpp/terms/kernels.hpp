// The seed's 2D smoothing kernels (docs/method-seed.md, "Kernels"): poly6
// (value, gradient, Laplacian), spiky (value, gradient) and the viscosity
// Laplacian, Mueller's 3D kernels re-normalised for 2D. Built once from h;
// functions take r^2 where they can. All are zero for r >= h.
#pragma once

#include "core/types.hpp"
#include "simd/lanes.hpp"

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

  // poly6 and its derivatives on any lane type, each written once, for
  // r < h (the scalar forms below are zero beyond): d = h^2 - r^2 and
  //   W = 4/(pi h^8) d^3                            (seed eq. 10)
  //   grad W = -24/(pi h^8) d^2 r_ij = g r_ij        (colour-field normal)
  //   lap W = -48/(pi h^8) d (h^2 - 3 r^2)           (colour-field curvature)
  template <class L>
  SPHFLUID_INLINE L poly6_cube(L r2) const {  // d^3, W over 4/(pi h^8)
    const L d = simd::splat<L>(h2) - r2;
    return d * d * d;
  }
  template <class L>
  SPHFLUID_INLINE L poly6_of(L r2) const {
    const L d = simd::splat<L>(h2) - r2;
    return simd::splat<L>(poly6) * d * d * d;
  }
  template <class L>
  SPHFLUID_INLINE void poly6_derivatives(L r2, L& g, L& l) const {
    const L d = simd::splat<L>(h2) - r2;
    g = simd::splat<L>(poly6_grad) * d * d;
    l = simd::splat<L>(poly6_lap) * d * (simd::splat<L>(h2) - simd::splat<L>(3) * r2);
  }
  Real w_poly6(Real r2) const { return r2 < h2 ? poly6_of(r2) : Real(0); }
  Vec2 grad_poly6(const Vec2& r_ij, Real r2) const {
    if (!(r2 < h2)) return Vec2::Zero();
    Real g, l;
    poly6_derivatives(r2, g, l);
    return g * r_ij;
  }
  Real lap_poly6(Real r2) const {
    if (!(r2 < h2)) return 0;
    Real g, l;
    poly6_derivatives(r2, g, l);
    return l;
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

// Seed eq. 10: a pair's weight in the density, poly6 of r^2, on any lane type,
// for pairs with r < h. A polynomial in r^2 (kCheap): a sum may take the
// unscaled weights (h^2 - r^2)^3 and apply factor() once per particle.
struct Poly6Weight {
  static constexpr bool kCheap = true;
  Kernels k;
  explicit Poly6Weight(const Kernels& kernels) : k(kernels) {}
  template <class L>
  SPHFLUID_INLINE L unscaled(L r2) const {
    return k.poly6_cube(r2);
  }
  template <class L>
  SPHFLUID_INLINE L operator()(L r2) const {
    return k.poly6_of(r2);
  }
  Real factor() const { return k.poly6; }
};

}  // namespace sphfluid
