// The dfsph method's step (docs/method-dfsph.md) as ordered phases, each one
// parallel loop over the pair table whose sums do not depend on the thread
// count (per particle in list order, across particles by block_sum): the
// constant-density solve, semi-implicit Euler (the kick and the drift with
// the wall collision), then at the new positions the summation density (D1)
// with the walls (W7, D2), the stiffness factors (D3), the divergence-free
// solve, and the non-pressure accelerations (with D8).
#include "methods/dfsph/dfsph.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "integrate.hpp"
#include "terms/delta.hpp"
#include "terms/wcsph.hpp"

namespace sphfluid {

DfsphMethod::DfsphMethod(Context& ctx)
    : ctx_(ctx), P_(ctx.params()), kernel_(P_.h), weight_(kernel_), walls_(kernel_) {
  walls_.build(P_.spacing, P_.mass / P_.rho0);
  surface_ = SurfaceEnergy::summed(P_, ctx.box);
  const Real dx = P_.spacing > 0 ? P_.spacing : std::sqrt(P_.mass / P_.rho0);
  surface_g2_ = dfsph::free_surface_gradient2(kernel_, dx, P_.mass);
}

void DfsphMethod::select(unsigned features) {
  static constexpr auto steps = feature_table<Steps, StepFn>();
  static constexpr auto evals = feature_table<Evaluations, EvalFn>();
  step_fn_ = steps[features];
  eval_fn_ = evals[features];
}

void DfsphMethod::particles_added(Index first) {
  for (Index i = first; i < ctx_.size(); ++i) {
    kappa_[i] = kappa_v_[i] = 0;
    a_last_[i] = Vec2::Zero();
  }
}

std::size_t DfsphMethod::bytes() const {
  return (factor_.capacity() + e_.capacity() + dk_.capacity() + rho0s_.capacity() +
          wall_rate_.capacity() +
          inv_rho_.capacity() + x_.capacity() + r_.capacity() + z_.capacity() +
          p_.capacity() + az_.capacity() + ap_.capacity() + partial_.capacity()) *
             sizeof(Real) +
         active_.capacity() + roles_.capacity() +
         du_.capacity() * sizeof(Vec2) +
         (first_.capacity() + pair_j_.capacity()) * sizeof(Index) +
         (wall_g_.capacity() + a_np_.capacity() + u_.capacity() + pair_mg_.capacity()) *
             sizeof(Vec2) +
         walls_.bytes() + surface_.bytes();
}

// Semi-implicit Euler around the two solves (Bender & Koschier 2017, Alg. 1):
// the predicted velocities v + dt a made to keep rho0 over the step, the
// drift with them, then at the new positions the velocities made
// divergence-free and the next step's non-pressure accelerations.
template <unsigned F>
void DfsphMethod::step_impl(Real dt, Real dt_cap) {
  ParticleSet& ps = ctx_.ps;
  if (!evaluated_ || a_np_.size() != static_cast<std::size_t>(ps.size())) {
    neighbours<F>();  // restored from a checkpoint: evaluated afresh
    non_pressure<F>();
  }
  // The step's force condition reads each particle's larger acceleration:
  // the non-pressure one, or the last step's whole one (with the pressure's).
  Vec2* a = ps.a.data();
  // The flow's own step, with the non-pressure accelerations alone in the
  // force condition: the density solve undoes the present error over it.
  std::copy(a_np_.begin(), a_np_.end(), a);
  ctx_.step_size(dt, dt_cap);
  undo_dt_ = ctx_.free_dt();
  for (Index i = 0; i < ps.size(); ++i)
    a[i] = a_last_[i].squaredNorm() > a_np_[i].squaredNorm() ? a_last_[i] : a_np_[i];
  dt = ctx_.step_size(dt, dt_cap);
  std::copy(a_np_.begin(), a_np_.end(), a);  // (a retried step starts over)
  ctx_.timer.start();
  density_solve(dt);
  std::copy(a, a + ps.size(), a_last_.data());
  ctx_.timer.mark(kSolve);
  ctx_.integrate<(F & kWalls) != 0, (F & kPeriodic) != 0>(dt, dt);
  ctx_.timer.mark(kIntegrate);
  ctx_.leave_domain();
  ctx_.timer.mark(kDomain);
  neighbours<F>();
  divergence_solve(dt);
  ctx_.timer.mark(kSolve);
  non_pressure<F>();
  ctx_.advance(dt);
}

// D1 (W2 with the walls' W7), D2 and D3; whether a free surface is there (D7).
template <unsigned F>
void DfsphMethod::neighbours() {
  ParticleSet& ps = ctx_.ps;
  ctx_.timer.start();
  ctx_.search.lists<(F & kPeriodic) != 0, false>(ps, P_.h, P_.mass, ctx_.team(), ctx_.box,
                                                  weight_, ctx_.timer);
  const Index n = ps.size();
  const Real rho0 = P_.rho0;
  Real* rho = ps.rho.data();
  wall_g_.assign(n, Vec2::Zero());
  wall_rate_.clear();
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.find(ctx_.walls, ps.x.data(), n, P_.h, ctx_.team(), true);
    ctx_.timer.mark(kGhosts);
    const WallSet& ws = ctx_.walls;
    if (ws.moves()) wall_rate_.assign(n, 0);
    const Vec2* x = ps.x.data();
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
      Real rho_i = rho[i];
      wcsph::add_wall_density(walls_, rho0, ghosts, rho_i);
      rho[i] = rho_i;
      if (ws.moves()) {  // D4's walls' velocities, share by share
        Vec2 g = Vec2::Zero();
        Real w = 0;
        dfsph::wall_gradient_terms(walls_, P_.h, rho0, ghosts, [&](const Vec2& r, const Vec2& s) {
          g += s;
          w += ws.motion_velocity_at(x[i] - r).dot(s);
        });
        wall_g_[i] = g;
        wall_rate_[i] = w;
      } else {
        wall_g_[i] = dfsph::wall_gradient(walls_, P_.h, rho0, ghosts);
      }
    });
  }
  // The pair table: each particle's neighbours and m grad W_ij, in list order,
  // with the sums of D3 taken as it is filled.
  const Csr<Index>& lists = ctx_.search.lists();
  first_.resize(n + 1);
  first_[0] = 0;
  for (Index i = 0; i < n; ++i) {
    const Row<Index> row = lists.row(i);
    first_[i + 1] = first_[i] + static_cast<Index>(row.end() - row.begin());
  }
  pair_j_.resize(first_[n]);
  pair_mg_.resize(first_[n]);
  factor_.resize(n);
  const Real m = P_.mass;
  const Vec2* x = ps.x.data();
  const PeriodicBox& box = ctx_.box;
  Real s2 = 0;  // the largest |s_i - G_i / 2|^2 (D7's free surface)
#pragma omp parallel for schedule(static) num_threads(ctx_.team()) reduction(max : s2)
  for (Index i = 0; i < n; ++i) {
    Vec2 sum = Vec2::Zero();
    Real q = 0;
    Index k = first_[i];
    for (const Index j : lists.row(i)) {
      Vec2 r;
      if constexpr ((F & kPeriodic) != 0) {
        r = box.delta(x[i], x[j]);
      } else {
        r = x[i] - x[j];
      }
      const Vec2 mg = (m * kernel_.gradient_factor(std::sqrt(r.squaredNorm()))) * r;
      pair_j_[k] = j;
      pair_mg_[k++] = mg;
      sum += mg;
      q += mg.squaredNorm();
    }
    factor_[i] = dfsph::stiffness_factor(sum + wall_g_[i], q);
    s2 = std::max(s2, (sum + Real(0.5) * wall_g_[i]).squaredNorm());  // D7
  }
  free_surface_ = s2 > surface_g2_;
  find_buffers();
  ctx_.timer.mark(kDensity);
}

// The inlets' and outlets' buffers (boundary/flows.hpp) in the solves: an
// inlet's particles keep the inflow's velocity (no value moves them) and
// carry the fluid's values beside them (extrapolate_inflow); an outlet's held
// particles (Context::outlet_held) hold the reference pressure, a value of 0
// (the density solve adds the hydrostatic head under gravity, solve()),
// their velocities moved by their neighbours' values. Neither is an unknown
// of the conjugate residuals (whose matrix is then M without the buffers'
// rows and columns and with the inlets' velocities held: still symmetric and
// positive semi-definite) nor counts in the error.
void DfsphMethod::find_buffers() {
  const Index n = ctx_.size();
  const Flows& flows = ctx_.flows;
  roles_.clear();
  unknowns_ = n;
  if (!flows.has_inlets() && !flows.has_outlets()) return;
  roles_.resize(n);
  const Vec2* x = ctx_.ps.x.data();
  const std::int8_t* held = ctx_.outlet_held();
  Index unknowns = 0;
#pragma omp parallel for schedule(static) num_threads(ctx_.team()) reduction(+ : unknowns)
  for (Index i = 0; i < n; ++i) {
    roles_[i] = flows.in_inlet(x[i]) ? kInflow : held && held[i] ? kOutflow : kFree;
    unknowns += roles_[i] == kFree;
  }
  unknowns_ = unknowns;
}

// W6 and W9 (physical viscosity, no artificial one), D8, the tension, gravity;
// the pressure the last density solve found, p = k rho^2.
template <unsigned F>
void DfsphMethod::non_pressure() {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  Vec2* a = ps.a.data();
  const Real* rho = ps.rho.data();
  const Vec2* v = ps.v.data();
  if constexpr ((F & kViscosity) != 0) {
    // W6 over the pair table (its m grad W_ij, no kernel to evaluate again)
    // and W9's walls.
    inv_rho_.resize(n);
    for (Index i = 0; i < n; ++i) inv_rho_[i] = 1 / rho[i];
    wcsph::PairConstants<Real> c = wcsph::pair_constants<Real>(P_);
    c.av = 0;
    const Real eta2 = 2 * P_.eta;
    const Vec2* x = ps.x.data();
    const PeriodicBox& box = ctx_.box;
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i) {
      const Vec2 xi = x[i], vi = v[i];
      const Real ir_i = inv_rho_[i];
      Vec2 f = Vec2::Zero();
      for (Index q = first_[i]; q < first_[i + 1]; ++q) {
        const Index j = pair_j_[q];
        Vec2 r;
        if constexpr ((F & kPeriodic) != 0) {
          r = box.delta(xi, x[j]);
        } else {
          r = xi - x[j];
        }
        f += wcsph::morris(eta2, ir_i, inv_rho_[j], r.dot(pair_mg_[q]),
                           1 / (r.squaredNorm() + c.eps2)) *
             (vi - v[j]);
      }
      if constexpr ((F & kWalls) != 0) {
        const Row<Vec2> ghosts = ctx_.ghosts.row(i);
        if (ctx_.walls.moving()) {  // v_i relative to the wall's surface at each ghost
          wcsph::add_wall_force<true>(walls_, kernel_, c, P_.rho0, ghosts, 0, ir_i,
                                      VelocityToSurface{ctx_.walls, xi, vi}, f);
        } else {
          wcsph::add_wall_force<true>(walls_, kernel_, c, P_.rho0, ghosts, 0, ir_i,
                                      VelocityAsIs{vi}, f);
        }
      }
      a[i] = f;
    }
  } else {
    std::fill(a, a + n, Vec2::Zero());
  }
  // The walls' fluid's pressure along the wall (W20's tangential part, D8).
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
      delta::add_wall_hydrostatic(walls_, ghosts, P_.gravity, a[i], false);
    });
  }
  if constexpr ((F & kSurfaceTension) != 0)
    surface_.evaluate(ps.x.data(), n, P_.mass, ctx_.team());
  ctx_.add_gravity_and_kick(0, (F & kSurfaceTension) != 0 ? surface_.accelerations() : nullptr);
  a_np_.assign(a, a + n);
  evaluated_ = true;
  // (an outlet's held particle: the pressure the density solve held it at)
  Real* p = ps.p.data();
  const std::int8_t* held = ctx_.outlet_held();
  const Real* head = ctx_.outlet_pressure();
  for (Index i = 0; i < n; ++i)
    p[i] = held && held[i] ? head[i] : kappa_[i] * rho[i] * rho[i];
  ctx_.timer.mark(kForces);
}

void DfsphMethod::density_solve(Real dt) {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const Vec2* v = ps.v.data();
  Vec2* a = ps.a.data();
  u_.resize(n);
  const char* role = roles_.empty() ? nullptr : roles_.data();
  for (Index i = 0; i < n; ++i) u_[i] = role && role[i] == kInflow ? v[i] : v[i] + dt * a[i];
  // The density's present error (from the reference, D7) is undone over the
  // flow's own step (undo_dt_, step_impl): a step shortened to land on an
  // end time, or by the last step's pressure accelerations in the force
  // condition, takes its share of it. Undone within a short step it takes an
  // acceleration growing as 1 / dt^2, which shortens the next step further:
  // the 10,000-particle dam break blew up so at an end time, and
  // the 1,000,000-particle one's step fell from 3 ms to 3 us in 13 steps
  // until the guard stopped it.
  const Real share = std::min(dt / undo_dt_, Real(1));
  const Real ref = dfsph::reference_density(ps.rho.data(), n, P_.rho0, free_surface_);
  rho0s_.resize(n);
  for (Index i = 0; i < n; ++i) rho0s_[i] = P_.rho0 + share * (ps.rho[i] - ref);
  const Solve s = solve(u_.data(), kappa_.data(), rho0s_.data(), dt, P_.density_tolerance, true);
  const Real inv_dt = 1 / dt;
  for (Index i = 0; i < n; ++i) a[i] = (u_[i] - v[i]) * inv_dt;
  stats_.density_iterations = s.iterations;
  stats_.density_error = s.error;
  stats_.iterations += s.iterations;
  if (!s.converged) ++stats_.unconverged;
}

void DfsphMethod::divergence_solve(Real dt) {
  ParticleSet& ps = ctx_.ps;
  rho0s_.assign(ps.size(), P_.rho0);
  // A particle short of neighbours (spray, a thin sheet) takes no part: its
  // base is so low that it never asks for pressure (SPlisHSPlasH skips the
  // divergence of particles with few neighbours likewise).
  for (Index i = 0; i < ps.size(); ++i)
    if (ps.rho[i] < dfsph::kDeficient * P_.rho0) rho0s_[i] = -std::numeric_limits<Real>::infinity();
  const Solve s = solve(ps.v.data(), kappa_v_.data(), rho0s_.data(), dt,
                        P_.divergence_tolerance);
  stats_.divergence_iterations = s.iterations;
  stats_.divergence_error = s.error;
  stats_.iterations += s.iterations;
  if (!s.converged) ++stats_.unconverged;
}

// The solve (D6): half the last values act first (the warm start), then
// conjugate residuals on the particles that ask for pressure (an error above
// 0, or a value above 0; in a confined fluid all, D7), preconditioned by the
// stiffness factors, until the predicted mean error is within the
// tolerance; the values are then projected on k >= 0 (with a free surface)
// and applied, and the errors measured again (another pass if the
// projection left them above it). Iterations: matrix products.
DfsphMethod::Solve DfsphMethod::solve(Vec2* u, Real* k, const Real* base, Real dt, Real tol,
                                      bool head) {
  Solve s;
  const Index n = ctx_.size();
  if (n == 0) {
    s.converged = true;
    return s;
  }
  for (std::vector<Real>* v : {&x_, &r_, &z_, &p_, &az_, &ap_, &dk_, &e_}) v->resize(n);
  active_.resize(n);
  du_.resize(n);
  // (an outlet's held value, p = k rho^2: the reference pressure, 0, plus the
  // head; no iteration changes it)
  const Real* held = head ? ctx_.outlet_pressure() : nullptr;
  const Real* rho = ctx_.ps.rho.data();
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    dk_[i] = roles_.empty() || roles_[i] != kOutflow ? dfsph::kWarmStart * k[i]
             : held                                  ? held[i] / (rho[i] * rho[i])
                                                     : Real(0);
    k[i] = 0;
  }
  apply(u, k, dt);
  const Real norm = 1 / (static_cast<Real>(std::max(unknowns_, Index(1))) * P_.rho0);
  s.error = errors(u, base, dt) * norm;
  while (std::isfinite(s.error)) {
    if (s.iterations >= P_.min_iterations && s.error <= tol) {
      s.converged = true;
      break;
    }
    if (s.iterations >= P_.max_iterations) break;
    const int before = s.iterations;
    conjugate_residuals(k, dt, tol / norm, s.iterations);
    if (s.iterations == before) {  // nothing asks for pressure (or can be given it)
      s.converged = s.error <= tol;
      break;
    }
    const bool project = free_surface_;  // on k >= 0
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i)
      dk_[i] = project ? std::max(k[i] + x_[i], Real(0)) - k[i] : x_[i];
    if (!roles_.empty()) extrapolate_inflow(k);
    apply(u, k, dt);
    s.error = errors(u, base, dt) * norm;
  }
  return s;
}

// An inlet's buffer carries the fluid's values across its line (a zero
// gradient, as Tafuni et al. 2018 extrapolate the pressure into their inlet
// buffers; here each inflow particle takes the Shepard average, weights W,
// of its fluid neighbours' k + dk): the fluid beside the line then feels no
// jump to the buffer's value. A buffer at 0 instead pushed the first column
// back into the inlet and the next one forward (the validation channel at
// 10 across: values alternating between about 5 kPa and 0 along the first
// columns, the particles at the line 7-9 % compressed, stopped by the guard
// at step 6). The conjugate residuals leave these values out (their matrix
// stays symmetric); the error measured after each round sees them.
void DfsphMethod::extrapolate_inflow(const Real* k) {
  const Index n = ctx_.size();
  const Vec2* x = ctx_.ps.x.data();
  const PeriodicBox& box = ctx_.box;
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    if (roles_[i] != kInflow) continue;
    Real sw = 0, sk = 0;
    for (Index q = first_[i]; q < first_[i + 1]; ++q) {
      const Index j = pair_j_[q];
      if (roles_[j] != kFree) continue;
      const Real w = kernel_.value(std::sqrt(box.delta(x[i], x[j]).squaredNorm()));
      sw += w;
      sk += w * (k[j] + dk_[j]);
    }
    dk_[i] = (sw > 0 ? sk / sw : Real(0)) - k[i];
  }
}

// D6's conjugate residuals from x = 0 for M x = e on the active particles,
// M x = -dt rate(dt a_p(x)) (D4 of D5: the density change the values x
// make over the step, with the sign that makes M positive semi-definite:
// M = dt^2 R R^T for the rate's matrix R), preconditioned by P = f / dt^2.
// Each iteration minimises the residual's P-norm over a growing space, so
// the residual never grows. Conjugate gradients minimise the error's M-norm
// instead, and their residual can grow: on a lattice deformed by one step of
// the Taylor-Green vortex a residual within the tolerance (forced on by
// min_iterations) grew 400-fold within eight iterations while the values
// chased the deformed lattice's near-null directions, and that one solve
// took 97 % of the vortex's speed; the 20,000-particle dam break blew up at
// t = 0.39 s (it runs to 1 s with these). Stops when the
// residuals' error sum is at most `tol` (after at least min_iterations
// products in all), at the most iterations, or when a direction brings
// nothing. Each loop is parallel, its sums in fixed blocks (block_sum).
void DfsphMethod::conjugate_residuals(const Real* k, Real dt, Real tol, int& iterations) {
  const Real inv_dt2 = 1 / (dt * dt);
  start_residuals(k, inv_dt2);
  if (iterations >= P_.max_iterations) return;
  Real zaz = product(dt);  // az = M z
  ++iterations;
  Real apap = directions(0, true, inv_dt2);
  while (zaz > 0) {
    if (!(apap > 0)) return;
    const Real err = residual_step(zaz / apap, inv_dt2);
    if ((iterations >= P_.min_iterations && err <= tol) || iterations >= P_.max_iterations) return;
    const Real zaz_next = product(dt);
    ++iterations;
    const Real beta = zaz_next / zaz;
    zaz = zaz_next;
    apap = directions(beta, false, inv_dt2);
  }
}

// The active set (an error above 0 or a value above 0; in a confined fluid
// every particle with a finite error), x = 0, r = e, z = P r.
void DfsphMethod::start_residuals(const Real* k, Real inv_dt2) {
  const bool confined = !free_surface_;
  const Index n = ctx_.size();
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    const bool on = std::isfinite(e_[i]) && (confined || e_[i] > 0 || k[i] > 0) &&
                    (roles_.empty() || roles_[i] == kFree);
    active_[i] = on;
    x_[i] = 0;
    r_[i] = on ? e_[i] : 0;
    z_[i] = r_[i] * factor_[i] * inv_dt2;
  }
}

// p = z + beta p, Mp = Mz + beta Mp (the first: p = z, Mp = Mz); returns
// (Mp)^T P (Mp).
Real DfsphMethod::directions(Real beta, bool first, Real inv_dt2) {
  return inv_dt2 * block_sum(ctx_.size(), ctx_.team(), partial_, [&](Index i) {
           p_[i] = first ? z_[i] : z_[i] + beta * p_[i];
           ap_[i] = first ? az_[i] : az_[i] + beta * ap_[i];
           return ap_[i] * ap_[i] * factor_[i];
         });
}

// x += alpha p, r -= alpha M p, z = P r; the residuals' error sum.
Real DfsphMethod::residual_step(Real alpha, Real inv_dt2) {
  const bool confined = !free_surface_;
  return block_sum(ctx_.size(), ctx_.team(), partial_, [&](Index i) {
    x_[i] += alpha * p_[i];
    r_[i] -= alpha * ap_[i];
    z_[i] = r_[i] * factor_[i] * inv_dt2;
    return dfsph::error_share(r_[i], confined);
  });
}

// az = M z (conjugate_residuals): the velocity change du = dt a_p(z) (D5),
// then -dt times its rate (D4) on the active particles; returns z^T M z.
Real DfsphMethod::product(Real dt) {
  const Index n = ctx_.size();
  const Real* z = z_.data();
  // (two loops, the first the plain one: one loop through a lambda for the
  // particle, with or without buffers, cost the 10k dam break 4 %)
  if (roles_.empty()) {
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i) du_[i] = dt * pressure_acceleration(i, [z](Index j) {
      return z[j];
    });
  } else {
    const char* role = roles_.data();  // an inlet's buffer: no value moves it
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i)
      du_[i] = role[i] == kInflow
                   ? Vec2(Vec2::Zero())
                   : Vec2(dt * pressure_acceleration(i, [z](Index j) { return z[j]; }));
  }
  return block_sum(n, ctx_.team(), partial_, [&](Index i) {
    az_[i] = active_[i] ? -dt * rate(i, du_.data()) : Real(0);
    return z_[i] * az_[i];
  });
}

// e = base + dt rate(u) - rho0 (D4, with the walls' own velocities); the sum
// of the error shares.
Real DfsphMethod::errors(const Vec2* u, const Real* base, Real dt) {
  const Real rho0 = P_.rho0;
  const bool confined = !free_surface_;
  const Real* wall = wall_rate_.empty() ? nullptr : wall_rate_.data();
  const auto error = [&](Index i) {
    e_[i] = base[i] + dt * (rate(i, u) - (wall ? wall[i] : Real(0))) - rho0;
    return dfsph::error_share(e_[i], confined);
  };
  if (roles_.empty()) return block_sum(ctx_.size(), ctx_.team(), partial_, error);
  const char* role = roles_.data();  // the buffers' errors do not count
  return block_sum(ctx_.size(), ctx_.team(), partial_, [&](Index i) {
    const Real share = error(i);
    return role[i] == kFree ? share : Real(0);
  });
}

// u += dt a_p(dk) (D5; not in an inlet's buffer), k += dk.
void DfsphMethod::apply(Vec2* u, Real* k, Real dt) {
  const Real* dk = dk_.data();
  const Index n = ctx_.size();
  const char* role = roles_.empty() ? nullptr : roles_.data();
  if (!role) {
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i) {
      u[i] += dt * pressure_acceleration(i, [dk](Index j) { return dk[j]; });
      k[i] += dk[i];
    }
  } else {
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i) {
      if (role[i] != kInflow)
        u[i] += dt * pressure_acceleration(i, [dk](Index j) { return dk[j]; });
      k[i] += dk[i];
    }
  }
}

}  // namespace sphfluid
