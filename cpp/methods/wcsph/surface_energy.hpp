// SurfaceEnergy: the wcsph method's surface tension, as minus the gradient of
// a surface energy sigma x (length of the free surface), measured on a fixed
// lattice of nodes in space.
//
// The fluid's colour field c(x) = sum_j V_j W_H(x - x_j), with the Wendland C2
// kernel W_H of support H = 2 h (twice the pressure kernel's) and the
// particles' volumes V_j = 1 / sum_l W_H(x_j - x_l) (self included), is about
// 1 inside the fluid at any density and 0 in the void, so the integral of
// |grad c| over the plane is the length of the surface: a jump of 1 per unit
// length across it, whatever the profile. On nodes of spacing g = dx/2, fixed
// in space (anchored on the domain's corner), the energy is
//   E_s = sigma' g^2 sum_c (sqrt(|grad c_c|^2 + eps^2) - eps),
// eps = 0.05/H keeping it smooth where the gradient vanishes; sigma' is sigma
// over the value of the sum per unit length of the flat surface of a square
// lattice of particles of spacing dx (less the lattice's own ripple, which
// the bulk has everywhere; averaged over 4 x 4 positions of the lattice
// against the nodes), so that E_s = sigma x length. The force is minus its
// gradient, in two parts: through the positions in W_H,
//   F_j = sigma' g^2 V_j sum_c H_H(x_c - x_j) n_c,
// n_c = grad c_c / sqrt(|grad c_c|^2 + eps^2) and H_H the kernel's Hessian;
// and through the volumes, a pair term like a pressure's,
//   F_j = sum_l (gamma_j + gamma_l) grad W_H(x_j - x_l),
//   gamma_j = sigma' g^2 V_j^2 sum_c n_c . grad W_H(x_c - x_j).
// Unlike a force built from each particle's own colour gradient, the energy
// counts the void side of the surface: an isolated particle carries the
// length of its own rim, so the energy cannot fall by particles leaving the
// fluid, nor by the fluid thinning out (the volumes keep c at 1 inside), and
// the forces put into the flow exactly the energy the surface gives up: a drop
// cannot shed particles without the energy to pull them free. The node sums
// are scattered and gathered in a fixed order (particles binned by position),
// so results do not depend on the thread count. Momentum is conserved up to
// the node lattice's discreteness (the lattice is fixed in space).
#pragma once

#include <cmath>
#include <vector>

#include "core/params.hpp"
#include "core/periodic.hpp"
#include "core/types.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

class SurfaceEnergy {
 public:
  // support: H; spacing: the particle lattice spacing dx (nodes at dx/2);
  // origin: where the nodes are anchored (a periodic axis: on its box).
  SurfaceEnergy(Real sigma, Real support, Real spacing, const Vec2& origin,
                const PeriodicBox& box);
  SurfaceEnergy() = default;
  // The summed-density methods' tension (wcsph with the summation, dfsph):
  // the colour kernel's support 2 h, nodes dx/2 apart; inactive without sigma.
  static SurfaceEnergy summed(const SimParams& P, const PeriodicBox& box) {
    if (!(P.sigma > 0)) return {};
    return {P.sigma, 2 * P.h, P.spacing > 0 ? P.spacing : std::sqrt(P.mass / P.rho0),
            P.domain_min, box};
  }

  // E_s of the particles at x, and for each minus its gradient over m.
  void evaluate(const Vec2* x, Index n, Real mass, int threads);
  // Of the last evaluation: E_s, J per m of depth, and the accelerations.
  Real energy() const { return energy_; }
  const Vec2* accelerations() const { return acc_.data(); }
  std::size_t bytes() const;

 private:
  // The flat-surface calibration: the sum per unit length for sigma' = 1.
  Real flat_length(Real spacing) const;
  // The phases of evaluate().
  void place_window(const Vec2* x, Index n);
  void bin_particles(const Vec2* x, Index n);
  void volumes(const Vec2* x, Index n, int threads);
  void scatter_gradient(const Vec2* x, int threads);
  void normalise_nodes(int threads);
  void node_forces(const Vec2* x, Index n, Real mass, int threads);
  void volume_forces(const Vec2* x, Index n, Real mass, int threads);
  // The traversals the phases share.
  template <class Row>
  void visit_rows(const Vec2& xj, Index row_lo, Index row_hi, Row&& row) const;
  template <class F>
  void for_near(Index j, F&& f) const;
  template <class F>
  void near_lanes(const Vec2& xj, Index j, F&& f) const;
  Vec2 sep(const Vec2& p, const Vec2& q) const {
    return box_.any() ? box_.delta(p, q) : Vec2(p - q);
  }

  Wendland w_{1};
  Real scale_ = 0, g_ = 0, eps_ = 0;
  Real gx_ = 0, gy_ = 0;  // the node spacing along x and y (g, or fitted to a period)
  Vec2 origin_{0, 0};
  PeriodicBox box_;
  // Periodic axes: the node count along them (the spacing fits the box).
  Index period_x_ = 0, period_y_ = 0;
  Real energy_ = 0;

  // This call's node window: nodes (ix0 + a, iy0 + b), a < nx_, b < ny_.
  Index ix0_ = 0, iy0_ = 0, nx_ = 0, ny_ = 0;
  std::vector<Real> node_x_, node_y_;  // grad c, then n_c, per node of the window
  std::vector<Real> row_sums_;   // per node row: the length estimate
  std::vector<Real> vol_;        // per particle: 1 / sum_l W_H(x_j - x_l)
  std::vector<Real> gamma_;      // ... and the volume term's factor
  std::vector<Vec2> acc_;        // ... and minus the gradient of E_s over m
  // Particles binned by position: bins of bin_x_ x bin_y_ nodes (at least H
  // each way), bx_ x by_ of them over the window.
  Index bin_x_ = 1, bin_y_ = 1, bx_ = 0, by_ = 0;
  Index run_ = 8;  // nodes per row visited around a particle (non-periodic x)
  std::vector<Index> bin_start_, bin_items_, bin_of_, bin_fill_;
  // Without periodic axes: positions and gamma in bin order (bin_items_).
  std::vector<Real> bin_x_pos_, bin_y_pos_, bin_gamma_;
};

}  // namespace sphfluid
