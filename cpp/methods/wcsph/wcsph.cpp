// The wcsph method: weakly compressible SPH as engineers use it (Monaghan 1994,
// 2005; Becker & Teschner 2007). Summation density with the Wendland C2 kernel,
// Tait EOS clamped at rho0 (no tension), symmetric pressure gradient, Monaghan's
// artificial viscosity beside Morris' physical viscosity, surface tension as
// minus the gradient of a surface energy (surface_energy.hpp), kick-drift-kick
// time stepping, and the same walls (ghosts + reflection) as the seed method.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "solver.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

namespace {

// f(r1, d1, r2, d2) for each pair of perpendicular wall ghosts in a row (r_k
// from the ghost to the particle, d_k = |r_k|): the particle is in a corner, and
// the two walls' shares both cover the quadrant beyond it.
template <class F>
void for_each_corner(Row<Vec2> ghosts, F f) {
  for (const Vec2* a = ghosts.begin(); a != ghosts.end(); ++a)
    for (const Vec2* b = a + 1; b != ghosts.end(); ++b) {
      const Real da = a->norm(), db = b->norm();
      if (da > 0 && db > 0 && std::abs(a->dot(*b)) < Real(1e-6) * da * db) f(*a, da, *b, db);
    }
}

}  // namespace

void Solver::select_wcsph_step() {
  static const StepFn steps[kNumFeatureSets] = SPHFLUID_FEATURE_TABLE(wcsph_step_impl);
  static const EvalFn evals[kNumFeatureSets] = SPHFLUID_FEATURE_TABLE(wcsph_evaluate_impl);
  step_fn_ = steps[features_];
  eval_fn_ = evals[features_];
}

// Kick-drift-kick: v += dt/2 a; x += dt v (walls reflect); evaluate at the new
// positions (the dissipative terms with the half-step velocity); v += dt/2 a.
template <unsigned F>
void Solver::wcsph_step_impl(Real dt, Real dt_cap) {
  dt = step_size(dt, dt_cap);
  const Real half = Real(0.5) * dt;
  // The drift starts from the positions of the last evaluation (the end of
  // the previous step, or compute_forces after the state or the walls
  // changed), so the wall clearances of its find_ghosts hold for them.
  integrate<F>(dt, half);  // the first kick and the drift, checked by the guard
  mark(kIntegrate);
  if (!all_inside_) remove_outside_domain();
  mark(kDomain);
  wcsph_evaluate_kick<F>(half);  // the second kick rides on the force loop
  mark(kIntegrate);
  time_ += dt;
  ++step_count_;
}

// The fluid pairs of wcsph_evaluate_impl (pressure, artificial and physical
// viscosity), each pair once: the pair force is antisymmetric, so j gets minus
// what i gets. Blocks as in seed_pairs_once (sums in one order whatever the
// thread count). Leaves the accelerations from fluid pairs in a[].
template <bool Viscosity>
void Solver::wcsph_pairs_once() {
  const Index n = size();
  const SimParams& P = params_;
  const Wendland& W = wendland_;
  const Vec2* x = ps_.x.data();
  const Vec2* v = ps_.v.data();
  const Real* rho = ps_.rho.data();
  const Real* por2 = p_over_rho2_.data();
  const Real* inv_rho = inv_rho_.data();
  Vec2* a = ps_.a.data();
  const Real m = P.mass, hs = Real(0.5) * P.h;
  const Real eps2 = Real(0.01) * hs * hs;
  const Real av = P.alpha * P.c0 * hs;
  [[maybe_unused]] const Real eta2 = 2 * P.eta;
  const Index block = pair_block(), blocks = (n + block - 1) / block;
  if (!half_lists_ || nbrs_.rows() != n)
    throw std::logic_error("the pair-once loop needs this evaluation's half lists");
#pragma omp parallel for schedule(static) num_threads(team())
  for (Index b = 0; b < blocks; ++b) {
    const Index lo = b * block, hi = std::min(n, lo + block);
    std::fill(a + lo, a + hi, Vec2::Zero());
    for (Index i = lo; i < hi; ++i) {
      const Vec2 xi = x[i], vi = v[i];
      const Real rhoi = rho[i], pi2 = por2[i], inv_i = inv_rho[i];
      Vec2 fi = a[i];  // from the pairs with earlier particles of the block
      for (const Index j : nbrs_.row(i)) {
        // The row holds j > i and the j of earlier blocks; a pair across
        // blocks is in both rows, and each side takes its own share.
        const bool mine = j > i && j < hi;
        const Vec2 r = xi - x[j];
        const Real r2 = r.squaredNorm(), rl = std::sqrt(r2);
        const Vec2 gw = W.gradient(r, rl);
        const Vec2 vij = vi - v[j];
        Real coef = pi2 + por2[j];  // p_i/rho_i^2 + p_j/rho_j^2
        const Real vr = vij.dot(r);
        const Real inv_r2e = 1 / (r2 + eps2);  // one division for both viscosities
        if (vr < 0) coef -= av * vr * inv_r2e * 2 / (rhoi + rho[j]);  // + Pi_ij
        Vec2 fij = -(m * coef) * gw;
        if constexpr (Viscosity)  // Morris, Fox & Zhu (1997)
          fij += (m * eta2 * inv_i * inv_rho[j] * r.dot(gw) * inv_r2e) * vij;
        fi += fij;
        if (mine) a[j] -= fij;
      }
      a[i] = fi;
    }
  }
}

// The same by cell clusters (cell_pairs.hpp), without lists.
template <bool Viscosity>
void Solver::wcsph_forces_by_cells() {
#if SPHFLUID_CELL_PAIRS
  if constexpr (CellPairs::kAvailable) {
    const SimParams& P = params_;
    const Real hs = Real(0.5) * P.h;
    const Real eps2 = Real(0.01) * hs * hs, av = P.alpha * P.c0 * hs;
    const Real m_eta2 = P.mass * 2 * P.eta;
    const CellPairs::WcsphPair<Viscosity> pair(ps_.v.data(), ps_.rho.data(), p_over_rho2_.data(),
                                               inv_rho_.data(), wendland_.inv_h, wendland_.grad,
                                               P.mass, eps2, av, m_eta2);
    cell_pairs_.wcsph_forces<Viscosity>(grid_, ps_.x.data(), P.h, pair, ps_.a.data(), team());
    return;
  }
#endif
  throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
}

template <unsigned F>
void Solver::wcsph_evaluate_impl() {
  wcsph_evaluate_kick<F>(0);
}

// The evaluation; with half > 0 also the second half-kick, v += half a, each
// particle's as soon as its acceleration is known, into a fresh buffer: a
// non-finite result keeps the half-step velocities.
template <unsigned F>
void Solver::wcsph_evaluate_kick(Real half) {
  mark_ = std::chrono::steady_clock::now();
  const Index n = size();
  const SimParams& P = params_;
  const Wendland& W = wendland_;
  // summation density, self included
  if constexpr (wcsph_by_cells(F)) {
    sort_and_sum_density_by_cells(Wendland::OfR2{&W});
  } else {
    sort_and_find_neighbours<(F & kPeriodic) != 0, pairs_once(F)>(Wendland::OfR2{&W});
  }
  if constexpr ((F & kWalls) != 0) {
    // Only ghosts on a segment's interior stand for a straight wall's fluid
    // side; beyond a segment's free end the reflection alone acts.
    find_ghosts(true);
    mark(kGhosts);
  }

  if constexpr ((F & kSurfaceTension) != 0) {
    surface_.evaluate(ps_.x.data(), n, P.mass, team());
    mark(kForces);
  }
  const Real rho0 = P.rho0, B = rho0 * P.c0 * P.c0 / SimParams::kTaitGamma;
  const Real pb = P.background_pressure;
  Real* rho = ps_.rho.data();
  Real* p = ps_.p.data();
  p_over_rho2_.resize(n);
  inv_rho_.resize(n);
  Real* por2 = p_over_rho2_.data();
  Real* inv_rho = inv_rho_.data();
  if constexpr ((F & kWalls) != 0) {
    // The walls' share first, for the particles that have ghosts. Each ghost
    // stands for the wall's half-plane filled with fluid at rho0: its share of
    // the density is rho0 times the kernel's integral over it.
    ghosts_.for_each_nonempty_row(team(), [&](Index i, Row<Vec2> ghosts) {
      Real rho_i = rho[i];
      for (const Vec2& r : ghosts) rho_i += rho0 * W.wall_half(r.norm());
      // ... and a corner's quadrant once, not twice.
      for_each_corner(ghosts, [&](const Vec2&, Real d1, const Vec2&, Real d2) {
        rho_i -= rho0 * W.corner_half(d1, d2);
      });
      rho[i] = rho_i;
    });
  }
  // The EOS for all, in a loop the compiler vectorises.
#pragma omp parallel for schedule(static) num_threads(team())
  for (Index i = 0; i < n; ++i) {
    const Real rho_i = rho[i];
    // Tait, gamma = 7, plus the background pressure, clamped at 0: a free
    // surface cannot pull (negative pressures there cause the tensile
    // instability; SPlisHSPlasH's WCSPH clamps the same way). With p_b = 0 this
    // is the density clamped at rho0 from below.
    const Real r = rho_i / rho0, r2 = r * r, r3 = r2 * r;
    p[i] = std::max(B * (r3 * r3 * r - 1) + pb, Real(0));
    inv_rho[i] = 1 / rho_i;
    por2[i] = p[i] * inv_rho[i] * inv_rho[i];
  }
  mark(kDensity);

  const Vec2* x = ps_.x.data();
  const Vec2* v = ps_.v.data();
  Vec2* a = ps_.a.data();
  const Real m = P.mass, hs = Real(0.5) * P.h;  // hs: the smoothing length (support 2 hs)
  const Real eps2 = Real(0.01) * hs * hs;
  const Real av = P.alpha * P.c0 * hs;  // Monaghan: Pi = -alpha c0 hs mu / rho_bar
  [[maybe_unused]] const Real eta2 = 2 * P.eta;
  const Vec2 g = P.gravity;
  // Without periodic seams, each fluid pair once: a[] holds the pair sums when
  // the loop below starts.
  constexpr bool kPairsOnce = pairs_once(F);
  // The cell clusters have no minimum image: the gather loop below must stay off.
  static_assert(!wcsph_by_cells(F) || pairs_once(F));
  if constexpr (wcsph_by_cells(F)) {
    wcsph_forces_by_cells<(F & kViscosity) != 0>();
  } else if constexpr (kPairsOnce) {
    wcsph_pairs_once<(F & kViscosity) != 0>();
  }
  // A ghost at the foot of the perpendicular stands for the wall's half-plane
  // of fluid at rest with the particle's pressure (its positive part: walls
  // push, never pull). The pressure pair summed over that half-plane is
  // 2 p_i rho0 / rho_i^2 times the kernel's integral along the wall line,
  // pointing away from the wall. Added to f.
  [[maybe_unused]] const auto add_walls = [&](Vec2& f, Row<Vec2> ghosts, Real pi2, Real inv_i,
                                              const Vec2& vi) {
    const Real pw2 = std::max(pi2, Real(0));
    for (const Vec2& r : ghosts) {
      const Real r2 = r.squaredNorm(), rl = std::sqrt(r2);
      const Vec2 gw = W.gradient(r, rl);
      if (rl > 0) f += (2 * pw2 * rho0 * W.wall_line(rl) / rl) * r;
      const Real vr = vi.dot(r);
      if (vr < 0) f += (m * av * vr / (r2 + eps2) * inv_i) * gw;
      if constexpr ((F & kViscosity) != 0)
        f += (m * eta2 * inv_i * inv_i * r.dot(gw) / (r2 + eps2)) * vi;
    }
    // In a corner both walls' pushes include the quadrant beyond it: once only.
    for_each_corner(ghosts, [&](const Vec2& r1, Real d1, const Vec2& r2, Real d2) {
      f -= (2 * pw2 * rho0) * (W.corner_line(d1, d2) / d1 * r1 + W.corner_line(d2, d1) / d2 * r2);
    });
  };
  if constexpr (kPairsOnce && ((F & kWalls) != 0)) {
    // a[] holds the pair sums: the walls' share first, for the particles that
    // have ghosts (the same arithmetic as in the loop below otherwise).
    ghosts_.for_each_nonempty_row(team(), [&](Index i, Row<Vec2> ghosts) {
      Vec2 f = a[i];
      add_walls(f, ghosts, por2[i], inv_rho[i], v[i]);
      a[i] = f;
    });
  }
  [[maybe_unused]] const Vec2* surface_acc = surface_.accelerations();
  const bool kick = half > 0;
  Vec2* v_new = kick ? ps_.v.begin_write(n) : nullptr;
  bool bad = false;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(|| : bad)
  for (Index i = 0; i < n; ++i) {
    const Vec2 xi = x[i], vi = v[i];
    const Real rhoi = rho[i], pi2 = por2[i], inv_i = inv_rho[i];
    Vec2 f = Vec2::Zero();
    if constexpr (kPairsOnce) f = a[i];
    if constexpr (!kPairsOnce) for (const Index j : nbrs_.row(i)) {
      const Vec2 r = separation<F>(xi, x[j]);
      const Real r2 = r.squaredNorm(), rl = std::sqrt(r2);
      const Vec2 gw = W.gradient(r, rl);
      const Vec2 vij = vi - v[j];
      Real coef = pi2 + por2[j];  // p_i/rho_i^2 + p_j/rho_j^2
      const Real vr = vij.dot(r);
      const Real inv_r2e = 1 / (r2 + eps2);  // one division for both viscosities
      if (vr < 0) coef -= av * vr * inv_r2e * 2 / (rhoi + rho[j]);  // + Pi_ij
      f -= (m * coef) * gw;
      if constexpr ((F & kViscosity) != 0)  // Morris, Fox & Zhu (1997)
        f += (m * eta2 * inv_i * inv_rho[j] * r.dot(gw) * inv_r2e) * vij;
    }
    if constexpr (((F & kWalls) != 0) && !kPairsOnce) add_walls(f, ghosts_.row(i), pi2, inv_i, vi);
    if constexpr ((F & kSurfaceTension) != 0) f += surface_acc[i];
    a[i] = f + g;
    if (kick) {
      v_new[i] = vi + half * a[i];
      bad = bad || !v_new[i].allFinite();
    }
  }
  mark(kForces);
  if (!kick) return;
  if (bad) {
    for (Index i = 0; i < n; ++i)
      if (!v_new[i].allFinite())
        throw InstabilityError("step " + std::to_string(step_count_ + 1) + ": particle id " +
                               std::to_string(ps_.id[i]) + " got a non-finite velocity in the "
                               "second half-kick [check: finite] (the state kept is the "
                               "half step)");
  }
  ps_.v.commit_write();
}

}  // namespace sphfluid
