// The seed method's equations (docs/method-seed.md), each written once on any
// lane type (simd/lanes.hpp): the state equation (15), the pair term of the
// pressure (14) and viscosity (17) forces, the colour field's pair shares
// (18-19) and the surface tension (20). The density's weight (10) is
// Poly6Weight (terms/kernels.hpp). Values in, values out: the traversals and
// the method's step decide where they come from and go.
#pragma once

#include <cmath>

#include "core/types.hpp"
#include "simd/lanes.hpp"
#include "terms/kernels.hpp"

namespace sphfluid::seed {

// Seed eq. 15: p = k (rho - rho0).
SPHFLUID_INLINE Real pressure(Real k, Real rho, Real rho0) { return k * (rho - rho0); }

// Seed eqs. 14 and 17 for one pair, on the lanes of `in` (r < h): with r_ij =
// (dx, dy), velocities v_i and v_j, d = max(h - r, 0) and d^2 / r taken as 0
// at r = 0,
//   t = (p_i + p_j) d^2 / r r_ij + l d (v_j - v_i).
// Particle i gets t / rho_j and j gets -t / rho_i; s = -m/2 spiky_grad times
// those sums is the force density: -sum_j m (p_i + p_j) / (2 rho_j) grad
// W_spiky(r_ij) + eta sum_j m (v_j - v_i) / rho_j lap W_visc(r_ij), with
// l = eta m visc_lap / s (in consistent units: a caller may scale lengths,
// pressures and densities, with s and l to match). With RecipRoot, 1/r comes
// from rsqrt14 and two Newton steps (a few ulp off the rounded root; eight
// doubles only) instead of a square root and a division.
template <bool Viscosity, bool RecipRoot = false>
struct PairForce {
  template <class L>
  static SPHFLUID_INLINE void t(simd::Mask<L> in, L h, L l, L p_sum, L dx, L dy, L r2,
                                simd::ScalarOf<L> vix, simd::ScalarOf<L> viy, L vjx, L vjy,
                                L& tx, L& ty) {
    const L zero = simd::zero<L>();
    const simd::Mask<L> nz = simd::gt(in, r2, zero);
    L d, g;  // d = max(h - r, 0) (r may round to just past h); g = d^2 / r
    if constexpr (RecipRoot) {
      const L y = simd::recip_sqrt(nz, r2, 2);
      d = simd::max(h - r2 * y, zero);
      g = d * d * y;
    } else {
      const L r = simd::sqrt(r2);
      d = simd::max(h - r, zero);
      g = simd::maskz_div(nz, d * d, r);
    }
    const L fp = p_sum * g;
    // (lanes outside the support are zero by mask, not by product)
    tx = simd::maskz_mul(in, fp, dx);
    ty = simd::maskz_mul(in, fp, dy);
    if constexpr (Viscosity) {
      const L lap = simd::maskz_mul(in, l, d);
      tx = simd::mask_fmadd(lap, in, vjx - simd::splat<L>(vix), tx);
      ty = simd::mask_fmadd(lap, in, vjy - simd::splat<L>(viy), ty);
    }
  }
};

// Seed eqs. 18-19: a pair's share of the colour field's gradient and
// Laplacian, times m / rho_j: grad W_poly6(r_ij) = g r_ij and lap W_poly6(r_ij)
// = lap, for r < h.
struct ColourField {
  Kernels k;
  explicit ColourField(const Kernels& kernels) : k(kernels) {}
  template <class L>
  SPHFLUID_INLINE void pair(L r2, L& g, L& l) const {
    k.poly6_derivatives(r2, g, l);
  }
  // The particle's own share of lap c (r = 0).
  Real self_lap() const { return k.poly6_lap * k.h2 * k.h2; }
};

// Seed eq. 20: the surface tension force density -sigma lap c n / |n| where
// |n| exceeds the threshold (Mueller et al. 2003), else none.
inline Vec2 tension(const Vec2& normal, Real lap_c, Real sigma, Real threshold) {
  const Real norm = normal.norm();
  return norm > threshold ? Vec2(-(sigma * lap_c / norm) * normal) : Vec2::Zero();
}

}  // namespace sphfluid::seed
