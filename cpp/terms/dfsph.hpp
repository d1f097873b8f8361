// The dfsph method's equations (docs/method-dfsph.md, eqs. D1-D6), each
// written once: the walls' share of sum_j m grad W_ij (D2), the stiffness
// factor (D3), the rate of density change (D4) and the pressure acceleration
// of a solve's pressure values (D5), per pair and per particle. The density
// (D1) is wcsph's summation with the walls' share (W2, W7). Values in,
// values out.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/csr.hpp"
#include "core/types.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wcsph.hpp"

namespace sphfluid::dfsph {

// D2: the walls' share of sum_j m grad_i W_ij, G_i, taken as the gradient of
// their share of the density (W7) in the particle's position, so that the
// rate D4 predicts the change of the density D1 itself: each ghost adds
// rho0 half'(d) r / d (r from the ghost to the particle, d = |r|; half
// decreases away from the wall), a corner takes its quadrant's away once.
// With the lattice tables the wall's fluid is the particle's mirror image,
// which approaches twice as fast as the particle: a static half-plane's sum
// (W8's line table) would predict half the change. Derivatives by central
// differences over two table cells.
inline Vec2 wall_gradient(const WallTables& t, Real h, Real rho0, Row<Vec2> ghosts) {
  const Real step = h / WallTables::kTable;
  auto slope = [&](auto f, Real d) {
    const Real lo = std::max(d - step, Real(0)), hi = std::min(d + step, h);
    return hi > lo ? (f(hi) - f(lo)) / (hi - lo) : Real(0);
  };
  Vec2 g = Vec2::Zero();
  for (const Vec2& r : ghosts) {
    const Real d = r.norm();
    if (d > 0) g += (rho0 * slope([&](Real x) { return t.wall_half(x); }, d) / d) * r;
  }
  wcsph::for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
    const Real s1 = slope([&](Real x) { return t.corner_half(x, d2); }, d1);
    const Real s2 = slope([&](Real x) { return t.corner_half(d1, x); }, d2);
    g -= rho0 * (s1 / d1 * r1 + s2 / d2 * r2);
  });
  return g;
}

// D3: the stiffness factor of a particle with s = sum_j m grad W_ij + G_i and
// q = sum_j |m grad W_ij|^2 (the walls do not move: they enter s only),
//   f_i = 1 / (|s|^2 + q),
// so that a pressure value k_i (p_i / rho_i^2) changes the particle's density
// over a step dt by -dt^2 k_i / f_i through its own and its neighbours'
// velocities (D5 with k_j = 0). A particle with no neighbours and no wall
// gets 0: no pressure acts on it.
inline Real stiffness_factor(const Vec2& s, Real q) {
  const Real d = s.squaredNorm() + q;
  return d > Real(1e-30) ? 1 / d : Real(0);
}

// D4, a pair's share of d rho_i / dt: m (v_i - v_j) . grad W_ij, with
// m grad W_ij = mg; the walls' share is v_i . G_i (walls at rest).
inline Real rate_pair(const Vec2& vij, const Vec2& mg) { return vij.dot(mg); }

// D5, a pair's share of the pressure acceleration of particle i from the
// pressure values k_i, k_j (p / rho^2), -(k_i + k_j) m grad W_ij; the walls'
// share is -k_i G_i (the wall's fluid carries no pressure value of its own).
inline Vec2 pressure_pair(Real ki, Real kj, const Vec2& mg) { return -(ki + kj) * mg; }

// D6: a solve's update of a pressure value from the particle's error e (the
// density it would reach over the step less rho0, kg/m^3), relaxed by omega
// and projected on k >= 0 (a free surface cannot pull):
//   dk = max(k + omega e f / dt^2, 0) - k.
// Bender & Koschier take omega = 1; in 2D with this kernel (support of 2
// spacings) that Jacobi iteration diverges (measured: a periodic box of
// random velocities, the error falls for ~10 iterations, then grows), and
// omega = 0.5 (IISPH's, Ihmsen et al. 2014) converges.
constexpr Real kRelaxation = 0.5;
// The divergence-free solve leaves out particles whose density (D1) is
// below this fraction of rho0: short of neighbours, their velocities are
// not a fluid's divergence (SPlisHSPlasH likewise skips particles with few
// neighbours); without it, spray was shot off at hundreds of m/s.
constexpr Real kDeficient = 0.8;
inline Real pressure_change(Real k, Real e, Real f, Real inv_dt2) {
  const Real next = k + kRelaxation * e * f * inv_dt2;
  return (next > 0 ? next : Real(0)) - k;
}

}  // namespace sphfluid::dfsph
