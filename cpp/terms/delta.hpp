// wcsph with the density from the continuity equation (docs/method-wcsph.md,
// "Continuity density, diffusion and shifting", eqs. W17-W26), each equation
// written once: the density rate of a pair with its diffusion term (W17-W18),
// the pressure coefficient of the pair force in the sum form (W19, the force
// itself is W4-W6's PairForce), the shifting sum's pair weight (W21), and the
// walls' share of the rate and the hydrostatic part of their push (W20, from
// the half-plane tables). Values in, values out.
#pragma once

#include <cmath>

#include "core/csr.hpp"
#include "core/types.hpp"
#include "simd/lanes.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wcsph.hpp"
#include "terms/wendland.hpp"

namespace sphfluid::delta {

// The constants of the rate: the particle mass, delta hs c0 (the diffusion's
// coefficient, hs = h/2 the smoothing length) and rho0 g / c0^2 (the
// hydrostatic density gradient the diffusion leaves alone).
template <class L>
struct RateConstants {
  L m, dc, hx, hy;
};

// W17-W18 for one pair on the lanes of `in` (r < h): the rates of i and j,
// from the kernel's gradient factor F (grad W_ij = F r_ij) and the volumes
// V = m / rho (zero on the lanes outside `in`).
//   continuity (the rho_i div v form):  D_i += rho_i V_j v_ij . grad W_ij,
//                                       D_j += rho_j V_i v_ij . grad W_ij
//   diffusion (Molteni & Colagrossi 2009, with the hydrostatic part taken out
//   as Fourtakas et al. 2019 do, linearised):
//     psi_ij = 2 [(rho_j - rho_i) + rho0 g . r_ij / c0^2],
//     D_i += delta hs c0 psi_ij (r_ji . grad W_ij) / r^2 V_j,  D_j gets the
//     same with psi_ji = -psi_ij and V_i;
// with r_ji . grad W_ij / r^2 = -F.
template <class L>
SPHFLUID_INLINE void rate(simd::Mask<L> in, L F, const RateConstants<L>& c, L rho_i, L rho_j,
                          L vol_i, L vol_j, L dx, L dy, L vijx, L vijy, L& di, L& dj) {
  const L zero = simd::zero<L>();
  const L vg = F * simd::fmadd(vijx, dx, vijy * dy);
  const L psi = simd::splat<L>(2) * (rho_j - rho_i + simd::fmadd(c.hx, dx, c.hy * dy));
  const L t = zero - c.dc * psi * F;
  di = simd::maskz(in, (rho_i * vg + t) * vol_j);
  dj = simd::maskz(in, (rho_j * vg - t) * vol_i);
}

// W26: a free surface holds no tension. A particle whose kernel sum (over
// the fluid and the walls' half-planes, times m / rho0) is below kSurfaceSum
// is at a free surface (it shifts along it only, W21); there its density is
// not below rho0 (the pressure of W3 not below the background's): fluid that
// spreads or breaks away at the surface carries rho0, not a stretched
// density, into the spray (the summation density's clamp, W3, where the
// surface is).
constexpr Real kSurfaceSum = 0.95;
// "shifting": "auto" shifts only a confined flow, one where no particle's
// kernel sum is below open_surface_sum at the start: halfway between the sum
// of a particle inside the lattice and that of the outer row of a flat free
// surface on it (0.75 with the support of 3 dx, 0.90 with 2 dx; a corner
// less). vol = m / rho0.
inline Real open_surface_sum(const Wendland& W, Real dx, Real vol) {
  const int reach = static_cast<int>(std::ceil(W.h / dx));
  Real inside = 0, row = 0;
  for (int k = -reach; k <= reach; ++k)
    for (int i = -reach; i <= reach; ++i) {
      const Real w = vol * W.value(dx * std::hypot(Real(i), Real(k)));
      inside += w;
      if (k <= 0) row += w;
    }
  return Real(0.5) * (inside + row);
}
inline Real surface_floor(Real rho, Real sum, Real rho0) {
  return sum < kSurfaceSum && rho < rho0 ? rho0 : rho;
}
// W26b: or the density stays as carried, and there the pressure is not below
// zero (no tension at a free surface or in spray, as W3's clamp; under a
// background pressure p_b, pressures between 0 and p_b are the suction a
// confined flow needs, behind a block in a channel); nor where the carried
// density rho is below the summed one (rho0 sum) by more than kStretched rho0:
// particles closer than their density says hold no tension, spray stretched
// in flight that has gathered again (until continuity and the diffusion have
// brought its density back) or, inside a confined flow, particles bunched
// beyond their carried density.
constexpr Real kStretched = 0.05;
inline Real surface_pressure(Real p, Real sum, Real rho, Real rho0) {
  const bool open = sum < kSurfaceSum || rho < rho0 * (sum - kStretched);
  return open && p < 0 ? Real(0) : p;
}

// W24: the normalisation of the viscous term (the Laplacian of Morris et al.
// 1997 with (r . grad W) / r^2 = F exactly): per particle
//   c_i = -2 / sum_j V_j F_ij r_ij^2,
// the factor that makes the operator exact for the isotropic part of a
// quadratic field on the particles' actual arrangement (the sum is -2 on a
// fine regular one; in the spirit of the corrected Laplacians of Schwaiger
// 2008 and Fatehi & Manzari 2011); a pair takes (c_i + c_j) / 2. The walls'
// rows add -(Psi_nn + Psi_tt) per ghost. laplacian_sum is a pair's share.
template <class L>
SPHFLUID_INLINE L laplacian_sum(L F, L r2, L v_j) {
  return v_j * F * r2;
}
inline Real laplacian_norm(Real sum) { return sum < 0 ? Real(-2) / sum : Real(1); }
inline void add_wall_laplacian(const WallTables& t, Row<Vec2> ghosts, Real& sum) {
  for (const Vec2& r : ghosts) {
    const Real rl = r.norm();
    sum -= t.wall_nn(rl) + t.wall_tt(rl);
  }
  wcsph::for_each_corner(ghosts, [&](const Vec2&, Real d1, const Vec2&, Real d2) {
    sum += t.corner_11(d1, d2) + t.corner_11(d2, d1);
  });
}

// W25: the walls' no-slip friction on a particle with velocity v_i (relative to
// the wall), normalisation c_i (W24) and 1/rho_i: W24's viscous term summed
// over the rows with Morris et al.'s extrapolated velocities (WallTables::
// wall_friction), a = -2 eta c_i / rho_i Psi_f(d) v_i per ghost (the rows'
// density rho0 cancels their volume m / rho0); the corners' quadrant is not
// taken out.
// relative(r) is v_i relative to the surface of the ghost's wall (a sliding
// lid's: the rows move with it): VelocityAsIs beside still walls,
// VelocityToSurface beside moving ones.
template <class Relative>
void add_wall_friction(const WallTables& t, Row<Vec2> ghosts, Real eta, Real c_i, Real inv_i,
                       Relative relative, Vec2& f) {
  Vec2 sum = Vec2::Zero();
  for (const Vec2& r : ghosts) sum += t.wall_friction(r.norm()) * relative(r);
  f -= (2 * eta * c_i * inv_i) * sum;
}

// W28: the artificial viscosity's alpha with the continuity density: only
// what the physical viscosity leaves to add. Monaghan's term (W5) acts in the
// continuum as a kinematic viscosity alpha hs c0 / 8 in 2D (Monaghan 2005);
// the fluid's own nu = eta / rho0 stands for 8 nu / (hs c0) of it, and
// alpha tops it up to the scene's alpha:
//   alpha' = max(0, alpha - 8 eta / (rho0 hs c0)).
// A water flow keeps its alpha (nu = 1e-6 is nothing at any resolution); a
// laminar flow resolved by its viscosity (the vortex, the channel, the
// cavity) runs with none.
inline Real artificial_alpha(Real alpha, Real eta, Real rho0, Real hs, Real c0) {
  const Real top_up = alpha - 8 * eta / (rho0 * hs * c0);
  return top_up > 0 ? top_up : Real(0);
}

// W29: the lattice's gradient normalisation. On the square lattice of spacing
// dx the pair sum of a linear field's gradient, sum_j V_j f_j grad W_ij, comes
// out S times the gradient, S = sum_j V (-F(r_j)) y_j^2 over the lattice's
// points (the continuum's 1; 0.9974 with the Wendland kernel at h = 3 dx,
// 0.967 at 2.5 dx): the pressure's pair sums (W19 with the walls' W8 and
// W20) are divided by it, so that a resting column's pressure gradient is
// rho g on the lattice. A constant on every pair: momentum is conserved as it
// is. vol = m / rho0.
template <class Kernel>
Real gradient_normalisation(const Kernel& W, Real dx, Real vol) {
  const int reach = static_cast<int>(std::ceil(W.h / dx));
  Real sum = 0;
  for (int k = -reach; k <= reach; ++k)
    for (int i = -reach; i <= reach; ++i) {
      const Real r = dx * std::hypot(Real(i), Real(k));
      if (r > 0 && r < W.h) sum -= vol * W.gradient_factor(r) * (k * dx) * (k * dx);
    }
  return sum;
}

// W19: the pressure coefficient of the pair force in the sum form,
// (p_i + p_j) / (rho_i rho_j), which takes W4's p_i/rho_i^2 + p_j/rho_j^2
// in PairForce (terms/wcsph.hpp); ir = 1 / rho.
template <class L>
SPHFLUID_INLINE L pressure_sum(L p_i, L p_j, L ir_i, L ir_j) {
  return (p_i + p_j) * ir_i * ir_j;
}

// W21: the shifting sum's weight of a pair, [1 + R (W_ij / W(dx))^4] F (its
// gradient part; grad W = F r_ij), R = 0.2 (Sun et al. 2017, after Monaghan's
// anti-clumping term), inv_wdx = 1 / W(dx).
constexpr Real kShiftR = 0.2;
template <class L>
SPHFLUID_INLINE L shift_weight(const Wendland& W, L r, L inv_wdx) {
  const L w = W.value_of(r) * inv_wdx, w2 = w * w;
  return simd::fmadd(simd::splat<L>(kShiftR), w2 * w2, simd::splat<L>(1)) * W.gradient_factor(r);
}

// W27: the shift's share of the rate (Sun et al. 2019's consistent shifting).
// A particle that a step shifts by dr moves at v + du, du = dr / dt, not at
// the fluid's v: its density changes by the divergence of its own motion and
// by the flux of the shift through it,
//   D_i += -rho_i div(du)_i + div(rho du)_i
//        = sum_j V_j [rho_i (du_i - du_j) + (rho_i du_i + rho_j du_j)] . grad W_ij,
// (the continuum's du . grad rho), so that the density follows the particles'
// spacing where the shift changes it. The pair's shares for i and j on the
// lanes of `in` (vol_i, vol_j zero elsewhere), grad W_ij = F r_ij.
template <class L>
SPHFLUID_INLINE void shift_rate(L F, L rho_i, L rho_j, L vol_i, L vol_j, L dx, L dy, L dui_x,
                                L dui_y, L duj_x, L duj_y, L& ci, L& cj) {
  const L two = simd::splat<L>(2), drho = rho_j - rho_i;
  const L ax = simd::fmadd(two * rho_i, dui_x, drho * duj_x);
  const L ay = simd::fmadd(two * rho_i, dui_y, drho * duj_y);
  const L bx = simd::fnmadd(drho, dui_x, two * rho_j * duj_x);
  const L by = simd::fnmadd(drho, dui_y, two * rho_j * duj_y);
  ci = F * simd::fmadd(ax, dx, ay * dy) * vol_j;
  cj = simd::zero<L>() - F * simd::fmadd(bx, dx, by * dy) * vol_i;
}

// W20: the walls' share of a particle's rate and the hydrostatic part of their
// push. A ghost stands for the fluid's lattice continued through the wall in
// rows fixed to it (WallTables with static rows), at rest: the rate is
// rho_i V v_i . sum grad W = -rho_i Psi(d) v_i . n, with n the unit normal
// towards the particle (a corner's quadrant once), the time derivative of
// the rows' share of a summation density; their pressure is the particle's
// extrapolated along gravity, p_j = p_i + rho_i g . (x_j - x_i) (Adami, Hu &
// Adams 2012), and their density the particle's (the fluid continued through
// the wall is as compressed as the particle: rows of mass m rho_i / rho0),
// which adds to W8's push
//   a_i += -(g . n) Psi_nn(d) n - (g . t) Psi_tt(d) t,
// t the wall's tangent; in a corner the quadrant both half-planes counted is
// taken out once: (g1 C11 + g2 C12) n1 + (g1 C12 + g2 C22) n2,
// g_k = g . n_k, C the quadrant's sums (WallTables::corner_11, corner_12).
// vi_of(r): the particle's velocity relative to the wall at the ghost at r
// (VelocityAsIs beside fixed walls; VelocityToWall beside moving ones, whose
// rows move with their wall).
template <class VelocityOf>
void add_wall_rate(const WallTables& t, Row<Vec2> ghosts, Real rho_i, const VelocityOf& vi_of,
                   Real& d) {
  for (const Vec2& r : ghosts) {
    const Real rl = r.norm();
    if (rl > 0) d -= rho_i * t.wall_line(rl) * vi_of(r).dot(r) / rl;
  }
  wcsph::for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
    d += rho_i * (t.corner_line(d1, d2) * vi_of(r1).dot(r1) / d1 +
                  t.corner_line(d2, d1) * vi_of(r2).dot(r2) / d2);
  });
}
// With normal = false only the tangential part, and no corner (dfsph, D8,
// whose solve sets the push along the normal through the particle's own
// value; with gravity along a wall's normal the quadrant is then counted by
// the other wall alone).
inline void add_wall_hydrostatic(const WallTables& t, Row<Vec2> ghosts, const Vec2& g, Vec2& f,
                                 bool normal = true) {
  for (const Vec2& r : ghosts) {
    const Real rl = r.norm();
    if (!(rl > 0)) continue;
    const Vec2 n = r / rl, tg(-n.y(), n.x());
    if (normal) {
      f += -g.dot(n) * t.wall_nn(rl) * n - g.dot(tg) * t.wall_tt(rl) * tg;
    } else {
      f += -g.dot(tg) * t.wall_tt(rl) * tg;
    }
  }
  if (!normal) return;
  wcsph::for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
    const Vec2 n1 = r1 / d1, n2 = r2 / d2;
    const Real g1 = g.dot(n1), g2 = g.dot(n2), c12 = t.corner_12(d1, d2);
    f += (g1 * t.corner_11(d1, d2) + g2 * c12) * n1 + (g1 * c12 + g2 * t.corner_11(d2, d1)) * n2;
  });
}

// W30: Monaghan's artificial viscosity (W5) on what is left of v_ij . r_ij
// after each side's linear reconstruction to the pair's midpoint, the
// limited reconstruction of Christensen (1990) that Frontiere, Raskin & Owen
// (2017) and Rosswog (2020) bring to SPH's artificial viscosity: a smooth
// flow keeps its energy (a wave is not damped by the scheme's viscosity, of
// alpha hs c0 / 8), while motion on the particles' scale (noise, an impact)
// meets the whole of it. A particle's velocity gradient from its fluid pairs,
//   G_i = sum_j V_j (v_j - v_i) (x) grad W_ij / t_i,
//   t_i = -1/2 sum_j V_j F_ij r_ij^2 (W24's fluid sum: 1 inside a fluid on the
//   lattice, 0.62 at a flat free surface, under 1/2 at a corner),
// a scalar normalisation in place of the matrix one (on the piston's waves
// within 1 % of it). Its strain E_i (the symmetric part) counts by the share
//   s_i = max(0, (|E|^2 - |Omega|^2) / (|E|^2 + |Omega|^2))
// (Omega the antisymmetric part): 1 in an irrotational flow, 0 in a simple
// shear, so that the square lattice's shear mode under pressure (the tank at
// rest's; docs, "The square lattice under pressure") stays damped. Each side
// predicts the linear part a_i = r_ij . s_i E_i r_ij of v_ij . r_ij, and W5
// acts on what is left (linear_vr, below). The walls' W9 and the strain's
// sums leave the walls' rows alone.
// A pair's share of i's sums (j's is the same with F V_i): with k = F V_j,
// (g_xx, g_xy) -= k v_ij,x (dx, dy), (g_yx, g_yy) -= k v_ij,y (dx, dy).
template <class L>
SPHFLUID_INLINE void velocity_gradient_share(L k, L dx, L dy, L vijx, L vijy, L& gxx, L& gxy,
                                             L& gyx, L& gyy) {
  const L kx = k * vijx, ky = k * vijy;
  gxx = simd::fnmadd(kx, dx, gxx);
  gxy = simd::fnmadd(kx, dy, gxy);
  gyx = simd::fnmadd(ky, dx, gyx);
  gyy = simd::fnmadd(ky, dy, gyy);
}
// The strain a particle reconstructs with, s_i E_i as (e_xx, e_yy, e_xy),
// from its sums (g_xx, g_xy), (g_yx, g_yy) and W24's fluid sum: none where
// that sum is under half a fluid's (spray: too few neighbours for a gradient).
struct Strain {
  Real xx, yy, xy;
};
inline Strain reconstruction_strain(const Vec2& gx, const Vec2& gy, Real fluid_sum) {
  const Real t = Real(-0.5) * fluid_sum;
  if (!(t > Real(0.5))) return {0, 0, 0};
  const Real xx = gx.x() / t, yy = gy.y() / t;
  const Real xy = Real(0.5) * (gx.y() + gy.x()) / t, w = Real(0.5) * (gy.x() - gx.y()) / t;
  const Real e2 = xx * xx + yy * yy + 2 * xy * xy, w2 = 2 * w * w;
  const Real share = e2 > w2 ? (e2 - w2) / (e2 + w2) : Real(0);
  return {share * xx, share * yy, share * xy};
}
// The linear part of v_ij . r_ij that the viscosity leaves out (r_ij =
// (dx, dy), r2 = r^2): each side predicts a_i = r_ij . E_i r_ij, and the pair
// takes the one nearer zero where both predict an approach (minmod), else
// none; closer than the spacing only in part, times q^2 (3 - 2 q),
// q = (r^2 / dx^2 - 1/4) / (3/4) in [0, 1] (inv_dx2 = 1 / dx^2; none within
// half a spacing), as Rosswog (2020) keeps the whole viscosity between
// particles that come too close. Never positive, so W5 (which acts where
// v_ij . r_ij less it is negative) meets only approaching pairs, each on no
// more than its approach: the reconstruction takes dissipation away, never
// adds or turns it (a pair parting more slowly than predicted is not pushed
// apart; with the harmonic mean of a_i and a_j of either sign the water dam
// break blew up, docs/method-wcsph.md).
template <class L>
SPHFLUID_INLINE L linear_vr(simd::Mask<L> in, L exx_i, L eyy_i, L exy_i, L exx_j, L eyy_j,
                            L exy_j, L dx, L dy, L r2, L inv_dx2) {
  const L zero = simd::zero<L>();
  const L xx = dx * dx, yy = dy * dy, xy2 = simd::splat<L>(Real(2)) * dx * dy;
  const L ai = simd::fmadd(exx_i, xx, simd::fmadd(eyy_i, yy, exy_i * xy2));
  const L aj = simd::fmadd(exx_j, xx, simd::fmadd(eyy_j, yy, exy_j * xy2));
  const auto both = simd::lt(simd::lt(in, ai, zero), aj, zero);
  const L one = simd::splat<L>(Real(1));
  const L q = simd::max(zero, simd::min(one, simd::fmadd(r2, inv_dx2, simd::splat<L>(Real(-0.25))) *
                                                 simd::splat<L>(Real(4) / Real(3))));
  const L close = q * q * simd::fnmadd(simd::splat<L>(Real(2)), q, simd::splat<L>(Real(3)));
  return simd::maskz(both, simd::max(ai, aj) * close);
}

}  // namespace sphfluid::delta
