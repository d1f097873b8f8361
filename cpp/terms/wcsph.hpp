// The wcsph method's equations (docs/method-wcsph.md), each written once: the
// Tait state equation (W3), the pair force of the symmetric pressure gradient
// (W4), Monaghan's artificial viscosity (W5) and Morris' viscosity (W6) on any
// lane type (simd/lanes.hpp), and the walls' shares of the density (W7), the
// pressure push (W8) and the viscous terms (W9) from the half-plane tables
// (terms/wall_tables.hpp). The density's weight (W2) is WendlandWeight
// (terms/wendland.hpp). Values in, values out.
#pragma once

#include <algorithm>
#include <cmath>

#include "boundary/walls.hpp"
#include "terms/wall_tables.hpp"
#include "core/csr.hpp"
#include "core/params.hpp"
#include "core/types.hpp"
#include "simd/lanes.hpp"
#include "terms/wendland.hpp"

namespace sphfluid::wcsph {

constexpr Real kTaitGamma = 7;

// W3: Tait, gamma = 7, B = rho0 c0^2 / 7, plus the background pressure p_b,
// clamped at 0: a free surface cannot pull (negative pressures there cause the
// tensile instability; SPlisHSPlasH's WCSPH clamps the same way). With p_b = 0
// this is the density clamped at rho0 from below.
SPHFLUID_INLINE Real pressure(Real rho, Real rho0, Real B, Real pb) {
  const Real r = rho / rho0, r2 = r * r, r3 = r2 * r;
  return std::max(B * (r3 * r3 * r - 1) + pb, Real(0));
}

// W3 solved for the density whose pressure is p above the background
// pressure: rho0 (1 + p / B)^(1/7) (W23's start, an outlet's held density).
inline Real tait_density(Real p, Real rho0, Real B) {
  return rho0 * std::pow(1 + p / B, 1 / kTaitGamma);
}

// The constants of the pair force: the particle mass, eps^2 = 0.01 hs^2,
// alpha c0 hs and 2 m eta (hs = h/2, the smoothing length of a kernel of
// support h).
template <class L>
struct PairConstants {
  L m, eps2, av, m_eta2;
};
template <class L>
PairConstants<L> pair_constants(const SimParams& P) {
  const Real hs = Real(0.5) * P.h;  // the smoothing length (support 2 hs)
  return {simd::splat<L>(P.mass), simd::splat<L>(Real(0.01) * hs * hs),
          simd::splat<L>(P.alpha * P.c0 * hs),  // Monaghan: Pi = -alpha c0 hs mu / rho_bar
          simd::splat<L>(P.mass * 2 * P.eta)};
}

// The elastic energy W3 stores per kg at rho = r rho0, B = rho0 c0^2 / 7 (its
// pressure's work, zero at rho0): B/((g-1) rho0) (r^(g-1) - 1) + B (1/rho - 1/rho0).
inline Real elastic_energy(Real r, Real rho0, Real B) {
  return B / ((kTaitGamma - 1) * rho0) * (std::pow(r, kTaitGamma - 1) - 1) +
         B * (1 / (r * rho0) - 1 / rho0);
}

// W6's coefficient (Morris, Fox & Zhu 1997): the viscous acceleration on i
// is k v_ij with k = 2 m eta / (rho_i rho_j) (r_ij . grad W) / (r^2 + eps^2),
// from m_eta2 = 2 m eta, ir = 1 / rho, r_gw = r_ij . grad W and inv_r2e =
// 1 / (r^2 + eps^2) (or 2 eta and r_ij . m grad W).
template <class L>
SPHFLUID_INLINE L morris(L m_eta2, L ir_i, L ir_j, L r_gw, L inv_r2e) {
  return m_eta2 * ir_i * ir_j * r_gw * inv_r2e;
}

// W4-W6 for one pair on the lanes of `in` (r < h), as an acceleration on i
// (j gets minus it):
//   f = -m (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) grad W(r_ij)
//       + 2 m eta / (rho_i rho_j) (r_ij . grad W) / (r^2 + eps^2) v_ij,
// Pi_ij = -alpha c0 hs (v_ij . r_ij) / (r^2 + eps^2) * 2 / (rho_i + rho_j) on
// approaching pairs (v_ij . r_ij < 0), else 0; grad W = grad (1 - q)^3 r_ij.
// With Normalised (the continuity density's W24), the viscous term is instead
//   2 m eta / (rho_i rho_j) F_ij v_ij * lap_ij,
// (r_ij . grad W) / r^2 = F_ij exactly, with no eps, and lap_ij the pair's
// normalisation (terms/delta.hpp). W30 passes the linear part of v_ij . r_ij
// (terms/delta.hpp, linear_vr), which Pi_ij then leaves out.
template <bool Viscosity, bool Normalised = false>
struct PairForce {
  template <class L>
  static SPHFLUID_INLINE void f(simd::Mask<L> in, const Wendland& W, const PairConstants<L>& c,
                                L rho_sum, L por2_sum, L ir_i, L ir_j, L dx, L dy, L r2, L vijx,
                                L vijy, L& fx, L& fy, L lap_ij = simd::zero<L>(),
                                L vr_linear = simd::zero<L>()) {
    const L zero = simd::zero<L>();
    const L s = W.gradient_factor(simd::sqrt(r2));
    const L gwx = s * dx, gwy = s * dy;
    // v_ij . r_ij, less its linear part where W30 reconstructs (the pressure
    // and the physical viscosity take the whole v_ij)
    const L vr = simd::fmadd(vijx, dx, vijy * dy) - vr_linear;
    // one division for both viscosities
    const L inv_r2e = simd::maskz_div(in, simd::splat<L>(1), r2 + c.eps2);
    L coef = por2_sum;  // p_i/rho_i^2 + p_j/rho_j^2
    const simd::Mask<L> closing = simd::lt(in, vr, zero);
    if (simd::any(closing)) {  // + Pi_ij
      const L t = c.av * vr * inv_r2e * simd::splat<L>(2);
      coef = simd::mask_sub(coef, closing, coef, simd::maskz_div(closing, t, rho_sum));
    }
    const L mc = c.m * coef;
    fx = simd::maskz_fnmadd(in, mc, gwx, zero);
    fy = simd::maskz_fnmadd(in, mc, gwy, zero);
    if constexpr (Viscosity) {  // Morris, Fox & Zhu (1997)
      L k;
      if constexpr (Normalised) {
        k = c.m_eta2 * ir_i * ir_j * s * lap_ij;
      } else {
        k = morris(c.m_eta2, ir_i, ir_j, simd::fmadd(dx, gwx, dy * gwy), inv_r2e);
      }
      fx = simd::mask3_fmadd(k, vijx, fx, in);
      fy = simd::mask3_fmadd(k, vijy, fy, in);
    }
  }
};

// f(r1, d1, r2, d2) for each pair of perpendicular wall ghosts in a row (r_k
// from the ghost to the particle, d_k = |r_k|): the particle is in a corner,
// and the two walls' shares both cover the quadrant beyond it.
template <class F>
void for_each_corner(Row<Vec2> ghosts, F f) {
  for (const Vec2* a = ghosts.begin(); a != ghosts.end(); ++a)
    for (const Vec2* b = a + 1; b != ghosts.end(); ++b) {
      const Real da = a->norm(), db = b->norm();
      if (da > 0 && db > 0 && std::abs(a->dot(*b)) < Real(1e-6) * da * db) f(*a, da, *b, db);
    }
}

// W7: the walls' share of a particle's density, added to rho: each ghost
// stands for the wall's half-plane filled with fluid at rho0; a corner's
// quadrant once, not twice.
inline void add_wall_density(const WallTables& t, Real rho0, Row<Vec2> ghosts, Real& rho) {
  for (const Vec2& r : ghosts) rho += rho0 * t.wall_half(r.norm());
  for_each_corner(ghosts, [&](const Vec2&, Real d1, const Vec2&, Real d2) {
    rho -= rho0 * t.corner_half(d1, d2);
  });
}

// W8-W9: the walls' acceleration on a particle with p / rho^2 = pi2 and
// 1/rho = inv_i, added to f; vi_of(r) is its velocity relative to the wall
// at the ghost at r (VelocityAsIs beside fixed walls; VelocityToWall beside
// moving ones, whose ghosts move with their wall). A ghost stands for the
// wall's half-plane of fluid at rest with the particle's pressure (its
// positive part: walls push, never pull) and the density rho_w (rho0 for
// the summation density; the particle's with the continuity density, W20);
// the pressure pair summed over it is 2 p_i rho_w / rho_i^2
// times the kernel's integral along the wall line, pointing away from the
// wall; the artificial and physical viscosities act as from one particle at
// rest at the ghost. In a corner both walls' pushes include the quadrant
// beyond it: once only.
template <bool Viscosity, class VelocityOf>
void add_wall_force(const WallTables& t, const Wendland& W, const PairConstants<Real>& c,
                    Real rho_w, Row<Vec2> ghosts, Real pi2, Real inv_i, const VelocityOf& vi_of,
                    Vec2& f) {
  const Real pw2 = std::max(pi2, Real(0));
  for (const Vec2& r : ghosts) {
    const Real r2 = r.squaredNorm(), rl = std::sqrt(r2);
    const Vec2 gw = W.gradient(r, rl);
    if (rl > 0) f += (2 * pw2 * rho_w * t.wall_line(rl) / rl) * r;
    const Vec2 vi = vi_of(r);
    const Real vr = vi.dot(r);
    if (vr < 0) f += (c.m * c.av * vr / (r2 + c.eps2) * inv_i) * gw;
    if constexpr (Viscosity) f += (c.m_eta2 * inv_i * inv_i * r.dot(gw) / (r2 + c.eps2)) * vi;
  }
  for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
    f -= (2 * pw2 * rho_w) * (t.corner_line(d1, d2) / d1 * r1 + t.corner_line(d2, d1) / d2 * r2);
  });
}

}  // namespace sphfluid::wcsph
