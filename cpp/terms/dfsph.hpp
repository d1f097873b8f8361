// The dfsph method's equations (docs/method-dfsph.md, eqs. D1-D8), each
// written once: the walls' share of sum_j m grad W_ij (D2), the stiffness
// factor (D3), the rate of density change (D4) and the pressure acceleration
// of a solve's pressure values (D5), per pair and per particle; the density
// aimed at (D7). The density (D1) is wcsph's summation with the walls' share
// (W2, W7); D8 is W20's tangential part (delta::add_wall_hydrostatic).
// Values in, values out.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/csr.hpp"
#include "core/types.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wcsph.hpp"
#include "terms/wendland.hpp"

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
// Term by term: visit(r, g) for each ghost's share g of G_i (r from the ghost
// to the particle), a corner's taken away as one share at each of its two
// ghosts.
template <class Visit>
void wall_gradient_terms(const WallTables& t, Real h, Real rho0, Row<Vec2> ghosts, Visit visit) {
  const Real step = h / WallTables::kTable;
  auto slope = [&](auto f, Real d) {
    const Real lo = std::max(d - step, Real(0)), hi = std::min(d + step, h);
    return hi > lo ? (f(hi) - f(lo)) / (hi - lo) : Real(0);
  };
  for (const Vec2& r : ghosts) {
    const Real d = r.norm();
    if (d > 0) visit(r, ((rho0 * slope([&](Real x) { return t.wall_half(x); }, d) / d) * r).eval());
  }
  wcsph::for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
    const Real s1 = slope([&](Real x) { return t.corner_half(x, d2); }, d1);
    const Real s2 = slope([&](Real x) { return t.corner_half(d1, x); }, d2);
    visit(r1, (-rho0 * s1 / d1 * r1).eval());
    visit(r2, (-rho0 * s2 / d2 * r2).eval());
  });
}
inline Vec2 wall_gradient(const WallTables& t, Real h, Real rho0, Row<Vec2> ghosts) {
  Vec2 g = Vec2::Zero();
  wall_gradient_terms(t, h, rho0, ghosts, [&](const Vec2&, const Vec2& share) { g += share; });
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
// m grad W_ij = mg; the walls' share is v_i . G_i, less sum v_w . g over
// G_i's shares g (wall_gradient_terms) where the walls move or slide, v_w
// the wall's material velocity at the share's ghost.
inline Real rate_pair(const Vec2& vij, const Vec2& mg) { return vij.dot(mg); }

// D5, a pair's share of the pressure acceleration of particle i from the
// pressure values k_i, k_j (p / rho^2), -(k_i + k_j) m grad W_ij; the walls'
// share is -k_i G_i (the wall's fluid carries no pressure value of its own).
inline Vec2 pressure_pair(Real ki, Real kj, const Vec2& mg) { return -(ki + kj) * mg; }

// D6: the solves find the values k that make the errors e (the density a
// particle would reach over the step less rho0, or D7's reference, kg/m^3)
// vanish, k >= 0 where there is a free surface (it cannot pull): M k = e with M k = -dt rate(dt a_p(k)), which
// is dt^2 R R^T for the rate's matrix R (D4 and D5 are each other's
// transposes), by conjugate residuals preconditioned with the stiffness
// factors f / dt^2 (D3, the inverse of M's diagonal: Bender & Koschier's
// Jacobi step). Jacobi itself (relaxed by 0.5; unrelaxed it diverges here)
// cannot bring the smooth errors down: in a tank 1 m deep its mean error fell
// by 1.2e-6 an iteration from 1e-3, never reaching 1e-4 within 100, and the
// 10,000-particle dam break blew up at t = 0.4 s.
//
// Each solve starts from this fraction of the previous step's values (its
// warm start; SPlisHSPlasH halves its warm starts too). With the whole
// values and the Jacobi iteration a periodic box of random velocities gained
// energy until the guard stopped it and a tank at rest from the lattice
// churned at 0.15-0.19 sqrt(gH); with conjugate gradients (D6's first
// solver) that tank's
// pressure was 16-20 % of rho0 g H off (RMS) at 1-2 s with the whole values,
// 9-16 % with half.
constexpr Real kWarmStart = 0.5;
// The divergence-free solve leaves out particles whose density (D1) is
// below this fraction of rho0: short of neighbours, their velocities are
// not a fluid's divergence (SPlisHSPlasH likewise skips particles with few
// neighbours); without it, spray was shot off at hundreds of m/s.
constexpr Real kDeficient = 0.8;

// D7: the density the constant-density solve aims at. With a free surface
// rho0. In a confined fluid (periodic, or filling its walls) the particles
// cannot change the area they fill, and the summed density (D1) of a
// disordered set lies above the lattice's on average (the lattice's
// neighbours sum W's Laplacian to a positive value, balancing its peak at
// r = 0, so that random offsets add to each sum): a mean excess that no
// motion of an incompressible fluid removes. Aimed at rho0, the solve chased
// it every step and turned it into velocity (a periodic box's random
// velocities grew from 0.01 to 0.06 m/s RMS in 0.2 s). A confined fluid's
// solves aim at the particles' mean density instead (the pressure
// equation's compatibility condition in a closed domain), with values of
// either sign: its pressure is known up to a constant, and expansion is
// undone as compression is.
inline Real reference_density(const Real* rho, Index n, Real rho0, bool free_surface) {
  if (free_surface || n == 0) return rho0;
  Real sum = 0;
  for (Index i = 0; i < n; ++i) sum += rho[i];
  return sum / static_cast<Real>(n);
}
// A particle's share of a solve's error sum (D6): with a free surface only
// compression counts (max(e, 0)); in a confined fluid, whose values may be
// negative (D7), |e| / 2 (the same for errors of zero mean).
inline Real error_share(Real e, bool confined) {
  return confined ? Real(0.5) * std::abs(e) : std::max(e, Real(0));
}
// A free surface is there when some particle's |sum_j m grad W_ij + G_i / 2|
// (about 0 inside the fluid and beside a wall, where G_i is twice the
// missing fluid's static sum, D2) exceeds half that of the outer row of a
// flat free surface on the lattice of spacing dx (particle mass m): unlike a
// density threshold, this holds for a compressed fluid too. Returns the
// threshold's square.
inline Real free_surface_gradient2(const Wendland& W, Real dx, Real m) {
  const int reach = static_cast<int>(std::ceil(W.h / dx));
  Real gy = 0;  // the row at y = 0 with the rows below: the sum points up
  for (int k = -reach; k < 0; ++k)
    for (int i = -reach; i <= reach; ++i) {
      const Real x = dx * i, y = dx * k, r = std::hypot(x, y);
      gy -= m * W.gradient_factor(r) * y;  // grad_i W_ij with r_ij = -(x, y)
    }
  const Real half = Real(0.5) * gy;
  return half * half;
}
}  // namespace sphfluid::dfsph
