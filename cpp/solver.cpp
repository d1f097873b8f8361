// The seed method's step (SPEC.md, seed pseudocode 4.3) as ordered phases, each
// one parallel loop whose sums do not depend on the thread count: in gather form
// (iteration i reads its neighbours and writes only particle i), or, for the
// pair sums, over blocks fixed by the particles alone: of particles on the half
// lists (seed_pairs_once), of cell rows by cell clusters (cell_pairs.hpp).
#include "solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <sstream>

namespace sphfluid {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

std::string fmt(Real x) {
  if (std::isnan(x)) return "nan";  // not "-nan": the sign of a NaN means nothing
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

std::string fmt(const Vec2& u) { return "(" + fmt(u.x()) + ", " + fmt(u.y()) + ")"; }

// The seed's pair term (eqs. 14, 17) as the cell clusters compute it: with
// d = max(h - r, 0), t = (p_i + p_j) d^2 / r r_ij + l d (v_j - v_i) (0 where
// r = 0); i gets t / rho_j, j gets -t / rho_i, and s = -m/2 spiky_grad times
// the sums is the force density (l = eta m visc_lap / s).
template <bool Viscosity>
void seed_pair(Real h, Real l, Real p_sum, const Vec2& r, Real r2, const Vec2& dv, Real& tx,
               Real& ty) {
  const Real rl = std::sqrt(r2), hr = h - rl, d = hr < 0 ? Real(0) : hr;
  const Real g = r2 > 0 ? d * d / rl : Real(0);
  const Real fp = p_sum * g;
  tx = fp * r.x();
  ty = fp * r.y();
  if constexpr (Viscosity) {
    const Real lap = l * d;
    tx = lap * dv.x() + tx;
    ty = lap * dv.y() + ty;
  }
}

}  // namespace

Solver::Solver(const SimParams& params, std::vector<Vec2> positions, std::vector<Vec2> velocities,
               std::vector<Id> ids, std::vector<Segment> walls)
    : params_(params), kern_(params.h > 0 ? params.h : 1), wendland_(kern_.h) {
  const SimParams& P = params_;
  require(std::isfinite(P.h) && P.h > 0, "smoothing length h must be > 0");
  require(std::isfinite(P.mass) && P.mass > 0, "particle mass must be > 0");
  require(std::isfinite(P.rho0) && P.rho0 > 0, "rest density must be > 0");
  require(std::isfinite(P.k) && P.k >= 0, "gas constant k must be >= 0");
  require(std::isfinite(P.eta) && P.eta >= 0, "viscosity must be >= 0");
  require(std::isfinite(P.sigma) && P.sigma >= 0, "surface tension must be >= 0");
  require(P.gravity.allFinite(), "gravity must be finite");
  require(P.domain_min.allFinite() && P.domain_max.allFinite() &&
              (P.domain_min.array() < P.domain_max.array()).all(),
          "domain min must be below max in x and y");
  require(std::isfinite(P.surface_threshold), "surface threshold must be finite");
  require(std::isfinite(P.restitution) && P.restitution >= 0 && P.restitution <= 1,
          "restitution must be in [0, 1]");
  require(std::isfinite(P.ghost_mass_ratio) && P.ghost_mass_ratio > 0,
          "ghost mass ratio must be > 0");
  require(std::isfinite(P.ghost_density_ratio) && P.ghost_density_ratio > 0,
          "ghost density ratio must be > 0");
  require(P.threads >= 0, "threads must be >= 0");
  require(std::isfinite(P.cfl) && P.cfl > 0 && P.cfl <= 1, "cfl must be in (0, 1]");
  require(std::isfinite(P.dt_max) && P.dt_max >= 0, "dt_max must be >= 0");
  require(P.guard_density_ratio > 1 && P.guard_speed_factor > 0 && P.guard_energy_factor > 0,
          "guard limits must be positive (density ratio > 1)");
  require(P.max_retries >= 0 && P.max_retries <= 20, "max_retries must be in [0, 20]");
  require(P.method == Method::kSeed || (std::isfinite(P.c0) && P.c0 > 0),
          "wcsph needs a speed of sound c0 > 0");
  require(std::isfinite(P.alpha) && P.alpha >= 0, "artificial viscosity alpha must be >= 0");
  require(std::isfinite(P.background_pressure) && P.background_pressure >= 0,
          "background pressure must be >= 0");
  threads_ = resolve_threads(P.threads);
  box_ = PeriodicBox(P.domain_min, P.domain_max, P.periodic_x, P.periodic_y);
  require(!box_.x || box_.length.x() >= 2 * P.h,
          "a periodic x axis needs a domain at least 2 h wide");
  require(!box_.y || box_.length.y() >= 2 * P.h,
          "a periodic y axis needs a domain at least 2 h high");
  walls_ = WallSet(std::move(walls), P.h);
  require(std::isfinite(P.spacing) && P.spacing >= 0, "spacing must be >= 0");
  if (P.method == Method::kWcsph) {
    wendland_.build_wall_tables(P.spacing, P.mass / P.rho0);
    if (P.sigma > 0)  // surface_energy.hpp: colour kernel support 2 h, nodes dx/2 apart
      surface_ = SurfaceEnergy(P.sigma, 2 * P.h,
                               P.spacing > 0 ? P.spacing : std::sqrt(P.mass / P.rho0),
                               P.domain_min, box_);
  }

  select_step();
  set_state(std::move(positions), std::move(velocities), std::move(ids));
}

void Solver::select_step() {
  const SimParams& P = params_;
  features_ = (P.eta > 0 ? kViscosity : 0u) | (P.sigma > 0 ? kSurfaceTension : 0u) |
              (walls_.empty() ? 0u : kWalls) | (box_.any() ? kPeriodic : 0u);
  // One instantiation of the whole step per feature set, chosen here once.
  static const StepFn steps[kNumFeatureSets] = SPHFLUID_FEATURE_TABLE(step_impl);
  static const EvalFn evals[kNumFeatureSets] = SPHFLUID_FEATURE_TABLE(evaluate_impl);
  step_fn_ = steps[features_];
  eval_fn_ = evals[features_];
  float_pairs_ = P.float_pairs && P.method == Method::kSeed && by_cells(features_);
  if (P.method == Method::kWcsph) select_wcsph_step();
}

void Solver::set_walls(std::vector<Segment> walls) {
  wall_clear_fresh_ = false;  // until the next find_ghosts measures them anew
  walls_ = WallSet(std::move(walls), params_.h);
  select_step();
  compute_forces();
}

void Solver::add_particles(const std::vector<Vec2>& positions,
                           const std::vector<Vec2>& velocities) {
  wall_clear_fresh_ = false;  // until the next find_ghosts measures them anew
  check_state(positions, velocities, {});
  const Index n = size(), k = static_cast<Index>(positions.size());
  require(std::int64_t(n) + k < INT32_MAX, "too many particles");
  in_sort_order_ = false;
  grid_.drop_ahead();
  Id next = 0;
  for (Index i = 0; i < n; ++i) next = std::max(next, ps_.id[i] + 1);
  ps_.resize(n + k);
  for (Index i = 0; i < k; ++i) {
    ps_.x[n + i] = positions[i];
    ps_.v[n + i] = velocities[i];
    ps_.id[n + i] = next + i;
  }
  wrap_positions();
  remove_outside_domain();
  compute_forces();
  compute_energy_budget();  // pouring is an energy input: the guard's budget grows with it
}

// Wall ghosts of every particle, found once per step and reused by every pass.
void Solver::find_ghosts(bool interior_only) {
  find_ghosts(interior_only, false, [](Index, Index) {});
}

// The same; with `density`, each particle's ghosts' share of its density
// (seed 4.1, as finish_density sums it) is added to rho[] as they are found,
// and then(first, last) runs on each thread's range of particles once their
// ghosts are found, in the same parallel region.
template <class Then>
void Solver::find_ghosts(bool interior_only, bool density, Then then) {
  const Vec2* x = ps_.x.data();
  Real* rho = ps_.rho.data();
  // Returns the squared distance from x[i] to the nearest wall of its lookup cell.
  auto emit = [&](Index i, Chunk<Vec2>& out) {
    const std::size_t before = out.size();
    const Real d2 = walls_.for_each_ghost(x[i], [&](const Vec2& r, bool interior) {
      if (interior || !interior_only) out.push_back(r);
    });
    if (density && out.size() != before)
      add_ghost_density(rho[i], {out.begin() + before, out.end()});
    return d2;
  };
#if defined(__AVX512F__) && defined(__AVX512VL__)
  if constexpr (kVector8 && sizeof(Index) == 4) {
    // Eight particles at a time: most lie in lookup cells that no wall comes
    // near, and their rows are left empty in one store.
    // Each particle's clearance goes to wall_clear2_ for the integration: the
    // squared length of a path from it that meets no wall (WallSet::safe_path2
    // of the distance to the nearest wall of its lookup cell). In float: h^2
    // and its margin 2e-6 h^2 are normal floats for h from 1e-16 m to 1e19 m.
    wall_clear2_.resize(static_cast<std::size_t>(size()) + 8);
    float* clear2 = wall_clear2_.data();
    auto clearance = [&](Real d2) { return static_cast<float>(walls_.safe_path2(d2)); };
    const float far2 = clearance(params_.h * params_.h);
    ghost_balance_.begin(size(), resolve_threads(team()));
    ghosts_.build_ranges(size(), team(), ghost_balance_, [&](Index lo, Index hi, Index* start,
                                                             Chunk<Vec2>& out) {
      Index i = lo;
      for (; i + 8 <= hi; i += 8) {
        const double* p = reinterpret_cast<const double*>(x + i);
        const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8);
        const __mmask8 near = walls_.near8(0xFF, x_of8(a, b), y_of8(a, b));
        _mm256_storeu_ps(clear2 + i, _mm256_set1_ps(far2));
        if (!near) {
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(start + i),
                              _mm256_set1_epi32(static_cast<Index>(out.size())));
          continue;
        }
        for (Index k = 0; k < 8; ++k) {
          start[i + k] = static_cast<Index>(out.size());
          if (near >> k & 1) clear2[i + k] = clearance(emit(i + k, out));
        }
      }
      for (; i < hi; ++i) {
        start[i] = static_cast<Index>(out.size());
        clear2[i] = clearance(emit(i, out));
      }
      then(lo, hi);
    });
    ghost_balance_.end();
    wall_clear_fresh_ = true;
    return;
  }
#endif
  ghosts_.build(size(), team(), emit);
  if (!density) return;
  const Index n = size();
  const int nt = team();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    const Share s = share_of(n, t, nt);
    then(s.first, s.last);
  }
}

void Solver::wrap_positions() {
  if (!box_.any()) return;
  for (Index i = 0; i < size(); ++i) ps_.x[i] = box_.wrap(ps_.x[i]);
}

void Solver::set_threads(int threads) {
  require(threads >= 0, "threads must be >= 0");
  threads_ = resolve_threads(threads);
}

void Solver::check_state(const std::vector<Vec2>& x, const std::vector<Vec2>& v,
                         const std::vector<Id>& ids) const {
  require(x.size() == v.size(), "positions and velocities differ in length");
  require(ids.empty() || ids.size() == x.size(), "ids and positions differ in length");
  require(x.size() < static_cast<std::size_t>(INT32_MAX), "too many particles");
  for (std::size_t i = 0; i < x.size(); ++i) {
    require(x[i].allFinite(), "position " + std::to_string(i) + " is not finite");
    require(v[i].allFinite(), "velocity " + std::to_string(i) + " is not finite");
  }
}

void Solver::set_state(std::vector<Vec2> positions, std::vector<Vec2> velocities,
                       std::vector<Id> ids) {
  wall_clear_fresh_ = false;  // until the next find_ghosts measures them anew
  check_state(positions, velocities, ids);
  const Index n = static_cast<Index>(positions.size());
  in_sort_order_ = false;
  grid_.drop_ahead();
  ps_.resize(n);
  for (Index i = 0; i < n; ++i) {
    ps_.x[i] = positions[i];
    ps_.v[i] = velocities[i];
    ps_.id[i] = ids.empty() ? Id(i) : ids[i];
  }
  wrap_positions();
  remove_outside_domain();
  compute_forces();
  compute_energy_budget();
}

void Solver::compute_energy_budget() {
  const Index n = size();
  const SimParams& P = params_;
  const Real m = P.mass;
  Real kinetic = 0, elastic = 0;
  Vec2 centre = Vec2::Zero();
  for (Index i = 0; i < n; ++i) {
    kinetic += 0.5 * m * ps_.v[i].squaredNorm();
    centre += ps_.x[i];
    const Real r = ps_.rho[i] / P.rho0;
    if (P.method == Method::kWcsph) {
      // Tait (clamped at rho0): B/((g-1) rho0) (r^(g-1) - 1) + B (1/rho - 1/rho0) per kg
      const Real g = SimParams::kTaitGamma, B = P.rho0 * P.c0 * P.c0 / g;
      const Real rc = std::max(r, Real(1));
      elastic += m * (B / ((g - 1) * P.rho0) * (std::pow(rc, g - 1) - 1) +
                      B * (1 / (rc * P.rho0) - 1 / P.rho0));
    } else {
      // p = k (rho - rho0): k (ln(rho/rho0) + rho0/rho - 1) per kg
      elastic += m * P.k * (std::log(r) + 1 / r - 1);
    }
  }
  Real release = 0;  // the most gravity can give: the centre of mass at the domain's far corner
  if (n > 0) {
    centre /= n;
    for (const Vec2& c : {P.domain_min, P.domain_max, Vec2(P.domain_min.x(), P.domain_max.y()),
                         Vec2(P.domain_max.x(), P.domain_min.y())})
      release = std::max(release, n * m * P.gravity.dot(c - centre));
  }
  // Surface energy that tension can release: sigma times the initial surface
  // length (or, unknown, sigma n h). wcsph's tension can release at most its
  // surface energy, which counts a lone particle's rim too (more than sigma h):
  // the state's own value bounds it.
  Real surface = P.sigma * (P.surface_length > 0 ? P.surface_length : n * P.h);
  if (surface_.active()) surface = std::max(surface, surface_.energy());
  const Real c = P.sound_speed();
  const Real floor = 0.5 * n * m * (0.01 * c) * (0.01 * c);
  energy_budget_ = kinetic + release + elastic + surface + floor;
  energy_removed_ = 0;
}

void Solver::step(Real dt, int n) {
  require(std::isfinite(dt) && dt > 0, "time step must be > 0");
  require(n >= 0, "number of steps must be >= 0");
  for (int s = 0; s < n; ++s) guarded_step(dt, 0);
}

void Solver::step_adaptive(int n) {
  require(n >= 0, "number of steps must be >= 0");
  for (int s = 0; s < n; ++s) guarded_step(0, 0);
}

// A trip leaves the state of the step before, so the step can be retried as
// 2, 4, 8, ... steps of dt/2, dt/4, dt/8, ... (on_instability: "retry").
void Solver::guarded_step(Real dt, Real dt_cap) {
  try {
    (this->*step_fn_)(dt, dt_cap);
    return;
  } catch (const InstabilityError& first) {
    if (params_.max_retries == 0) throw;
    const Real full = dt > 0 ? dt : last_dt_;
    const Real t_end = time_ + full;
    std::string reason = first.what();
    for (int level = 1; level <= params_.max_retries; ++level) {
      const std::int64_t parts = std::int64_t(1) << level;
      const Real sub = full / static_cast<Real>(parts);
      if (retry_log_.size() == kRetryLog) retry_log_.erase(retry_log_.begin());
      retry_log_.push_back("retrying with dt = " + fmt(sub) + " s after: " + reason);
      ++retried_steps_;
      try {
        // Sub-steps keep whatever they completed; the last one lands on t_end.
        while (t_end - time_ > 1e-12 * std::max(Real(1), std::abs(t_end)))
          (this->*step_fn_)(std::min(sub, t_end - time_), 0);
        return;
      } catch (const InstabilityError& again) {
        reason = again.what();
      }
    }
    throw InstabilityError(reason + " (gave up after " + std::to_string(params_.max_retries) +
                           " retries with halved time steps)");
  }
}

std::int64_t Solver::advance_adaptive(Real t_end, std::int64_t max_steps) {
  require(std::isfinite(t_end), "end time must be finite");
  require(max_steps >= 0, "max_steps must be >= 0");
  std::int64_t taken = 0;
  // Stop when the rest is below round-off of the time itself.
  while (taken < max_steps && t_end - time_ > 1e-12 * std::max(Real(1), std::abs(t_end))) {
    guarded_step(0, t_end - time_);
    ++taken;
  }
  return taken;
}

// The largest dt allowed by the sound-speed/flow CFL, force and viscous
// conditions, from the accelerations just computed.
Real Solver::choose_dt(Real dt_cap) {
  const Index n = size();
  const Vec2* v = ps_.v.data();
  const Vec2* a = ps_.a.data();
  Real v2 = 0, a2 = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(max : v2, a2)
  for (Index i = 0; i < n; ++i) {
    v2 = std::max(v2, v[i].squaredNorm());
    a2 = std::max(a2, a[i].squaredNorm());
  }
  const SimParams& P = params_;
  const Real inf = std::numeric_limits<Real>::infinity();
  const Real l = P.step_length();
  Real dt = P.cfl * l / (P.sound_speed() + std::sqrt(v2));
  TimeStepLimit limit = TimeStepLimit::kCfl;
  auto consider = [&](Real candidate, TimeStepLimit why) {
    if (candidate < dt) {
      dt = candidate;
      limit = why;
    }
  };
  consider(a2 > 0 ? SimParams::kForceFactor * std::sqrt(l / std::sqrt(a2)) : inf,
           TimeStepLimit::kForce);
  consider(P.eta > 0 ? SimParams::kViscousFactor * l * l * P.rho0 / P.eta : inf,
           TimeStepLimit::kViscous);
  consider(P.dt_max > 0 ? P.dt_max : inf, TimeStepLimit::kMax);
  if (!(dt > 0) || !std::isfinite(dt))
    throw InstabilityError("step " + std::to_string(step_count_ + 1) + " (t = " + fmt(time_) +
                           " s): no finite time step satisfies the stability conditions "
                           "(max speed " + fmt(std::sqrt(v2)) + " m/s, max acceleration " +
                           fmt(std::sqrt(a2)) + " m/s^2)");
  // A step shortened to land on an end time keeps the label of the condition
  // that limits the flow itself.
  last_limit_ = limit;
  return dt_cap > 0 ? std::min(dt, dt_cap) : dt;
}

Real Solver::step_size(Real dt, Real dt_cap) {
  if (dt > 0) {
    last_limit_ = TimeStepLimit::kFixed;
  } else {
    dt = choose_dt(dt_cap);
  }
  last_dt_ = dt;
  return dt;
}

void Solver::compute_forces() { (this->*eval_fn_)(); }

// --- phases -----------------------------------------------------------------

template <unsigned F>
void Solver::step_impl(Real dt, Real dt_cap) {
  evaluate_impl<F>();
  dt = step_size(dt, dt_cap);
  integrate<F>(dt, dt);
  mark(kIntegrate);
  if (!all_inside_) remove_outside_domain();
  mark(kDomain);
  time_ += dt;
  ++step_count_;
}

template <unsigned F>
void Solver::evaluate_impl() {
  mark_ = std::chrono::steady_clock::now();
  // seed eq. 10
  if constexpr (by_cells(F)) {
    sort_and_sum_density_by_cells(Kernels::Poly6OfR2{&kern_});
  } else {
    sort_and_find_neighbours<(F & kPeriodic) != 0, pairs_once(F)>(Kernels::Poly6OfR2{&kern_});
  }
  if constexpr (by_cells(F) && (F & kWalls) != 0) {
    // The walls' share of the density with the ghost search, and the EOS in
    // the same parallel region, each thread on its range once its ghosts are
    // found.
    inv_rho_.resize(size());
    find_ghosts(false, true, [&](Index i0, Index i1) { finish_eos<F>(i0, i1); });
    mark(kGhosts);
  } else {
    if constexpr ((F & kWalls) != 0) {
      find_ghosts(false);
      mark(kGhosts);
    }
    compute_density<F>();
    mark(kDensity);
  }
  compute_accelerations<F>();
  mark(kForces);
}

void Solver::sort_by_cell() {
  const CellGrid::Reorder how =
      grid_.sort(ps_.x.data(), size(), params_.h, team(), order_, box_, in_sort_order_);
  switch (how) {
    case CellGrid::Reorder::kNone:
      break;
    case CellGrid::Reorder::kMoves:
      ps_.apply_moves(grid_.moves(), grid_.jumps(), grid_.move_parts(), order_, team());
      break;
    case CellGrid::Reorder::kOrder:
      ps_.permute_state(order_, team());
      break;
  }
  ++sort_counts_[static_cast<int>(how)];
  if (how == CellGrid::Reorder::kMoves && grid_.move_parts().split()) ++sort_counts_[3];
  in_sort_order_ = true;
  mark(kSort);
}

// Sorts the particles by cell, builds the neighbour lists, and sums the fluid
// part of each density, rho_i = m (w(0) + sum_j w(r_ij^2)), in the same pass
// while the neighbours are in cache; w is the method's kernel of r^2. With
// Once, the lists are the half lists of the pair-once loops (each pair within
// a pair block stored once).
template <bool Periodic, bool Once, class KernelOfR2>
void Solver::sort_and_find_neighbours(KernelOfR2 w) {
  static_assert(!(Periodic && Once), "the periodic seams keep full lists");
  const Index n = size();
  sort_by_cell();
  const Vec2* x = ps_.x.data();
  Real* rho = ps_.rho.data();
  const Real m = params_.mass, self = w(Real(0));
  half_lists_ = Once;
  cell_pair_count_ = -1;
  if constexpr (Periodic) {
    grid_.neighbours_periodic(x, n, params_.h, team(), box_, nbrs_,
                              [&](Index i, const Index* nbr, Index count) {
                                const Vec2 xi = x[i];
                                Real sum = self;
                                for (Index q = 0; q < count; ++q)
                                  sum += w(box_.delta(xi, x[nbr[q]]).squaredNorm());
                                rho[i] = m * sum;
                              });
  } else if constexpr (Once) {
    // rho[] carries the weights within a block until each row is done.
    grid_.neighbours_once(x, n, params_.h, team(), pair_block(), nbrs_, rho, w,
                          [&](Index i, Real sum) { rho[i] = m * (self + sum); });
  } else {
    // The sum over the neighbours is taken while the grid filters them.
    grid_.neighbours(x, n, params_.h, team(), nbrs_, w,
                     [&](Index i, const Index*, Index, Real sum) { rho[i] = m * (self + sum); });
  }
  mark(kNeighbours);
}

// The same by cell clusters (cell_pairs.hpp), for both methods: no lists; the
// blocks of cell rows are cut afresh from the sorted particles.
template <class KernelOfR2>
void Solver::sort_and_sum_density_by_cells(KernelOfR2 w) {
#if SPHFLUID_CELL_PAIRS
  if constexpr (CellPairs::kAvailable) {
    const Index n = size();
    sort_by_cell();
    half_lists_ = false;
    cell_pairs_.make_blocks(grid_, n, pair_blocks());
    if (float_pairs_) floats_.resize(n);  // filled with the EOS (finish_density)
    cell_pair_count_ = cell_pairs_.density(grid_, ps_.x.data(), params_.h, params_.mass,
                                           w(Real(0)), w, ps_.rho.data(), team());
    mark(kNeighbours);
    return;
  }
#endif
  (void)w;
  throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
}

template void Solver::sort_and_sum_density_by_cells(Wendland::OfR2);

template <bool Viscosity, class Finish>
void Solver::seed_forces_by_cells(Finish finish) {
#if SPHFLUID_CELL_PAIRS
  if constexpr (CellPairs::kAvailable) {
    if (float_pairs_) {
      const Real cw = grid_.cell_width();
      const Real s = -Real(0.5) * params_.mass * kern_.spiky_grad * cw * cw;
      const Real l = params_.eta * params_.mass * kern_.visc_lap * cw / (params_.rho0 * s);
      force_scale_ = s;
      cell_pairs_.seed_forces_float<Viscosity>(grid_, floats_, kern_.h, l, ps_.a.data(), team(),
                                               finish);
      return;
    }
    force_scale_ = seed_scale();
    const Real l = seed_lap();
    if (recip_root_) {
      cell_pairs_.seed_forces<Viscosity, true>(grid_, ps_.x.data(), ps_.v.data(), ps_.p.data(),
                                               inv_rho_.data(), kern_.h, l, ps_.a.data(), team(),
                                               finish);
    } else {
      cell_pairs_.seed_forces<Viscosity, false>(grid_, ps_.x.data(), ps_.v.data(), ps_.p.data(),
                                                inv_rho_.data(), kern_.h, l, ps_.a.data(), team(),
                                                finish);
    }
    return;
  }
#endif
  (void)finish;
  throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
}

template void Solver::sort_and_find_neighbours<false, false>(Wendland::OfR2);
template void Solver::sort_and_find_neighbours<false, true>(Wendland::OfR2);
template void Solver::sort_and_find_neighbours<true, false>(Wendland::OfR2);

std::int64_t Solver::neighbour_pairs() const {
  if (cell_pair_count_ >= 0) return 2 * cell_pair_count_;
  if (!half_lists_) return nbrs_.total();
  // Each pair is in the row of its first particle (and, across blocks, also
  // in its second's): count each once, and both directions, over the rows of
  // that evaluation (particles may have left the domain since).
  std::int64_t pairs = 0;
  for (Index i = 0; i < nbrs_.rows(); ++i)
    for (const Index j : nbrs_.row(i)) pairs += j > i;
  return 2 * pairs;
}

// Seed eq. 10: the wall ghosts' part of the density (4.1), then the EOS (eq. 15),
// for the particles [i0, i1), on the calling thread. The ghosts' part first,
// for the particles that have ghosts (find_ghosts sums it itself where it
// is asked to); then the EOS for all.
template <unsigned F>
void Solver::finish_density(Index i0, Index i1) {
  if constexpr ((F & kWalls) != 0) {
    Real* rho = ps_.rho.data();
    ghosts_.for_each_nonempty_row_in(
        i0, i1, [&](Index i, Row<Vec2> ghosts) { add_ghost_density(rho[i], ghosts); });
  }
  finish_eos<F>(i0, i1);
}

// The wall ghosts' share of a particle's density (4.1), summed in their order.
void Solver::add_ghost_density(Real& rho, Row<Vec2> ghosts) const {
  Real g = 0;
  for (const Vec2& r : ghosts) g += kern_.w_poly6(r.squaredNorm());
  rho += params_.ghost_mass_ratio * params_.mass * g;
}

// The EOS (eq. 15) of the particles [i0, i1) whose densities are complete, in
// a loop the compiler vectorises; with the float pair forces also their data.
template <unsigned F>
void Solver::finish_eos(Index i0, Index i1) {
  const Real* rho = ps_.rho.data();
  Real* p = ps_.p.data();
  Real* inv_rho = inv_rho_.data();
  const Real k = params_.k, rho0 = params_.rho0;
  if constexpr (by_cells(F)) {
    if (float_pairs_) {  // and the float pair forces' data (SeedFloats)
#if SPHFLUID_CELL_PAIRS
      CellPairs::fill_floats(grid_, ps_.x.data(), ps_.v.data(), i0, i1, floats_);
#endif
      float* pf = floats_.p.data();
      float* ir = floats_.ir.data();
      const Real inv_rho0 = 1 / rho0;
      for (Index i = i0; i < i1; ++i) {
        const Real pi = k * (rho[i] - rho0), ri = 1 / rho[i];
        p[i] = pi;
        inv_rho[i] = ri;
        pf[i] = static_cast<float>(pi * inv_rho0);
        ir[i] = static_cast<float>(rho0 * ri);
      }
      return;
    }
  }
  for (Index i = i0; i < i1; ++i) {
    p[i] = k * (rho[i] - rho0);
    inv_rho[i] = 1 / rho[i];
  }
}

// The same for all particles, each thread taking a range (the list paths).
template <unsigned F>
void Solver::compute_density() {
  const Index n = size();
  inv_rho_.resize(n);
  const int nt = team();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    const Share s = share_of(n, t, nt);
    finish_density<F>(s.first, s.last);
  }
}

// The fluid pairs of compute_accelerations (pressure, viscosity, and with
// tension the colour field's sums) with each pair evaluated once: its square
// root and division serve both particles. The
// particles are cut into blocks whose size depends only on n; within a block,
// in storage order, a pair's terms go to both particles, and a pair that
// crosses blocks is evaluated from each side (the half lists of
// CellGrid::neighbours_once hold exactly these). So every sum is taken in one
// order whatever the thread count. Leaves the force densities in a[] (and
// n_i, lap c_i in normal_, lap_c_).
template <bool Viscosity, bool Tension>
void Solver::seed_pairs_once() {
  const Index n = size();
  const Vec2* x = ps_.x.data();
  const Vec2* v = ps_.v.data();
  const Real* p = ps_.p.data();
  const Real* inv_rho = inv_rho_.data();
  Vec2* a = ps_.a.data();
  const Real m = params_.mass, h = kern_.h, l = seed_lap();
  const Index block = pair_block(), blocks = (n + block - 1) / block;
  if (!half_lists_ || nbrs_.rows() != n)
    throw std::logic_error("the pair-once loop needs this evaluation's half lists");
  force_scale_ = seed_scale();
  // The colour field's sums (eqs. 18-19), pairwise like the forces.
  [[maybe_unused]] Vec2* normal = nullptr;
  [[maybe_unused]] Real* lap_c = nullptr;
  if constexpr (Tension) {
    normal_.resize(n);
    lap_c_.resize(n);
    normal = normal_.data();
    lap_c = lap_c_.data();
  }
  [[maybe_unused]] const Real lap_self = kern_.lap_poly6(0);
#pragma omp parallel for schedule(static) num_threads(team())
  for (Index b = 0; b < blocks; ++b) {
    const Index lo = b * block, hi = std::min(n, lo + block);
    std::fill(a + lo, a + hi, Vec2::Zero());
    if constexpr (Tension) {
      std::fill(normal + lo, normal + hi, Vec2::Zero());
      for (Index i = lo; i < hi; ++i) lap_c[i] = m * inv_rho[i] * lap_self;
    }
    for (Index i = lo; i < hi; ++i) {
      const Vec2 xi = x[i];
      const Real pi = p[i], ir_i = inv_rho[i];
      [[maybe_unused]] const Vec2 vi = v[i];
      Vec2 fi = a[i];  // from the pairs with earlier particles of the block
      [[maybe_unused]] Vec2 ni = Vec2::Zero();
      [[maybe_unused]] Real li = 0;
      if constexpr (Tension) {
        ni = normal[i];
        li = lap_c[i];
      }
      for (const Index j : nbrs_.row(i)) {
        // The row holds j > i and the j of earlier blocks; a pair across
        // blocks is in both rows, and each side takes its own share.
        const bool mine = j > i && j < hi;
        const Vec2 r = xi - x[j];
        const Real r2 = r.squaredNorm();
        Real tx, ty;  // seed eqs. 14, 17
        seed_pair<Viscosity>(h, l, pi + p[j], r, r2, Viscosity ? Vec2(v[j] - vi) : Vec2(), tx,
                             ty);
        const Real ir_j = inv_rho[j];
        fi.x() = ir_j * tx + fi.x();
        fi.y() = ir_j * ty + fi.y();
        if (mine) {
          a[j].x() = a[j].x() - ir_i * tx;
          a[j].y() = a[j].y() - ir_i * ty;
        }
        if constexpr (Tension) {  // m / rho_j grad W and m / rho_j lap W (eqs. 18-19)
          const Vec2 gw = kern_.grad_poly6(r, r2);
          const Real lw = kern_.lap_poly6(r2);
          ni += (m * ir_j) * gw;
          li += (m * ir_j) * lw;
          if (mine) {
            normal[j] -= (m * ir_i) * gw;
            lap_c[j] += (m * ir_i) * lw;
          }
        }
      }
      a[i] = fi;
      if constexpr (Tension) {
        normal[i] = ni;
        lap_c[i] = li;
      }
    }
  }
}

// The wall ghosts' pressure and viscosity on a particle (seed 4.1) as the
// pair term (eqs. 14, 17) with ghosts of mass m_g and density rho_g, at rest,
// whose pressure, like the particle's in the pair, is the positive part of
// p_i: the wall pushes back as hard as the fluid presses, and never pulls.
// The sum in the units of the pair sums (times seed_scale(): force density).
template <unsigned F>
Vec2 Solver::wall_sum(Row<Vec2> ghosts, Real pi, const Vec2& vi) const {
  const Real w = params_.ghost_mass_ratio / (params_.ghost_density_ratio * params_.rho0);
  const Real p_sum = 2 * std::max(pi, Real(0)), h = kern_.h, l = seed_lap();
  Real sx = 0, sy = 0;
  for (const Vec2& r : ghosts) {
    Real tx, ty;
    seed_pair<(F & kViscosity) != 0>(h, l, p_sum, r, r.squaredNorm(), -vi, tx, ty);
    sx += tx;
    sy += ty;
  }
  return Vec2(w * sx, w * sy);
}

// Where the fluid pairs are summed once (without tension), a[] holds their
// pair sums: for the particles [i0, i1), on the calling thread, the walls'
// share first, for the particles that have ghosts, then a = s a / rho + g for
// all (s = force_scale_, the pair sums' factor), in a loop the compiler
// vectorises.
template <unsigned F>
void Solver::finish_accelerations(Index i0, Index i1) {
  Vec2* a = ps_.a.data();
  const Real* rho = ps_.rho.data();
  const Real s = force_scale_;
  if constexpr ((F & kWalls) != 0) {
    const Real* p = ps_.p.data();
    const Vec2* v = ps_.v.data();
    const Real ratio = seed_scale() / s;  // the walls' sum in the pair sums' units
    ghosts_.for_each_nonempty_row_in(i0, i1, [&](Index i, Row<Vec2> ghosts) {
      const Vec2 w = wall_sum<F>(ghosts, p[i], v[i]);
      a[i] = Vec2(ratio * w.x() + a[i].x(), ratio * w.y() + a[i].y());
    });
  }
  const Vec2 g = params_.gravity;
  Real* ad = reinterpret_cast<Real*>(a);
  for (Index i = i0; i < i1; ++i) {
    ad[2 * i] = s * ad[2 * i] / rho[i] + g.x();
    ad[2 * i + 1] = s * ad[2 * i + 1] / rho[i] + g.y();
  }
}

// Pressure (seed eq. 14), viscosity (17) and colour-field surface tension
// (18-20) as force densities; a = f / rho + g. Wall ghosts add pressure and
// viscosity only. A ghost has the density rho0 * ghost_density_ratio and mirrors
// the particle's pressure; only its positive part acts, so walls push, never pull.
template <unsigned F>
void Solver::compute_accelerations() {
  // Without periodic seams, each fluid pair once: a[] (and, with tension, the
  // colour field's sums) hold the pair sums when the loop below starts.
  constexpr bool kPairsOnce = pairs_once(F);
  // The cell clusters have no minimum image: the gather loop below must stay off.
  static_assert(!by_cells(F) || pairs_once(F));
  if constexpr (by_cells(F)) {
    // Each pair block finished as soon as its sums are complete.
    seed_forces_by_cells<(F & kViscosity) != 0>(
        [&](Index i0, Index i1) { finish_accelerations<F>(i0, i1); });
    return;
  } else if constexpr (kPairsOnce) {
    seed_pairs_once<(F & kViscosity) != 0, (F & kSurfaceTension) != 0>();
    if constexpr ((F & kSurfaceTension) == 0) {
      const Index n = size();
      const int nt = team();
#pragma omp parallel for schedule(static) num_threads(nt)
      for (int t = 0; t < nt; ++t) {
        const Share s = share_of(n, t, nt);
        finish_accelerations<F>(s.first, s.last);
      }
      return;
    }
  }
  const Index n = size();
  const Vec2* x = ps_.x.data();
  const Vec2* v = ps_.v.data();
  const Real* rho = ps_.rho.data();
  const Real* p = ps_.p.data();
  const Real* inv_rho = inv_rho_.data();
  Vec2* a = ps_.a.data();
  [[maybe_unused]] const Real m = params_.mass, sigma = params_.sigma;
  [[maybe_unused]] const Real threshold = params_.effective_surface_threshold();
  [[maybe_unused]] const Real lap_self = kern_.lap_poly6(0);
  const Real h = kern_.h, l = seed_lap(), s = seed_scale();
  force_scale_ = s;
  const Vec2 g = params_.gravity;
#pragma omp parallel for schedule(static) num_threads(team())
  for (Index i = 0; i < n; ++i) {
    const Vec2 xi = x[i];
    const Real pi = p[i], rhoi = rho[i];
    Vec2 sum = Vec2::Zero();  // the pair sums, times s the force density
    if constexpr (kPairsOnce) sum = a[i];
    [[maybe_unused]] Vec2 vi = v[i];
    [[maybe_unused]] Vec2 normal = Vec2::Zero();  // n_i = grad c_i   (eq. 18)
    [[maybe_unused]] Real lap_c = 0;              // lap c_i
    if constexpr ((F & kSurfaceTension) != 0) {
      if constexpr (kPairsOnce) {
        normal = normal_[i];
        lap_c = lap_c_[i];
      } else {
        lap_c = m / rhoi * lap_self;
      }
    }
    if constexpr (!kPairsOnce) for (const Index j : nbrs_.row(i)) {
      const Vec2 r = separation<F>(xi, x[j]);
      const Real r2 = r.squaredNorm();
      const Real inv_rho_j = inv_rho[j];
      constexpr bool kVisc = (F & kViscosity) != 0;
      Real tx, ty;  // seed eqs. 14, 17
      seed_pair<kVisc>(h, l, pi + p[j], r, r2, kVisc ? Vec2(v[j] - vi) : Vec2(), tx, ty);
      sum.x() = inv_rho_j * tx + sum.x();
      sum.y() = inv_rho_j * ty + sum.y();
      if constexpr ((F & kSurfaceTension) != 0) {
        const Real vol = m * inv_rho_j;
        normal += vol * kern_.grad_poly6(r, r2);
        lap_c += vol * kern_.lap_poly6(r2);
      }
    }
    if constexpr ((F & kWalls) != 0) sum += wall_sum<F>(ghosts_.row(i), pi, vi);
    Vec2 f = s * sum;
    if constexpr ((F & kSurfaceTension) != 0) {
      const Real norm = normal.norm();
      if (norm > threshold) f -= (sigma * lap_c / norm) * normal;  // eq. 20
    }
    a[i] = f / rhoi + g;
  }
}

// v += kick a; x += dt v (semi-implicit Euler for the seed, kick = dt; the
// first half of kick-drift-kick for wcsph, kick = dt/2), then the wall collision
// of the same particle (4.2), written into fresh buffers; the guard then checks the new state (non-finite
// values, density, speed, kinetic energy) and only a good one replaces the old.
template <unsigned F>
void Solver::integrate(Real dt, Real kick) {
  const Index n = size();
  const Vec2* x = ps_.x.data();
  const Vec2* v = ps_.v.data();
  const Vec2* a = ps_.a.data();
  const Real* rho = ps_.rho.data();
  Vec2* x_new = ps_.x.begin_write(n);
  Vec2* v_new = ps_.v.begin_write(n);
  [[maybe_unused]] const Real e = params_.restitution;
  const Real inf = std::numeric_limits<Real>::infinity();
  const bool guard = params_.guard;
  const Real rho_max = guard ? params_.guard_density_ratio * params_.rho0 : inf;
  const Real v_max = params_.guard_speed_factor * params_.sound_speed();
  const Real v2_max = guard ? v_max * v_max : inf;
  bool bad = false;
  Real v2_sum = 0;
  // The wall clearances serve this integration only.
  [[maybe_unused]] const bool clear_fresh = wall_clear_fresh_;
  wall_clear_fresh_ = false;
#if defined(__AVX512F__) && defined(__AVX512VL__)
  // Eight particles at a time (without periodic seams): the same arithmetic on
  // the interleaved x and y, the wall check for eight paths at once, and the
  // collision itself only for the paths that may meet a wall.
  if constexpr ((F & kPeriodic) == 0 && sizeof(Vec2) == 2 * sizeof(double)) {
    const Index chunks = (n + 7) / 8;
    const __m512d kv = _mm512_set1_pd(kick), dtv = _mm512_set1_pd(dt), zero = _mm512_setzero_pd();
    const __m512d v2_cap = _mm512_set1_pd(v2_max), rho_cap = _mm512_set1_pd(rho_max);
    const double* xd = reinterpret_cast<const double*>(x);
    const double* vd = reinterpret_cast<const double*>(v);
    const double* ad = reinterpret_cast<const double*>(a);
    double* xn = reinterpret_cast<double*>(x_new);
    double* vn = reinterpret_cast<double*>(v_new);
    // The clearances found by this step's find_ghosts, for the positions x.
    [[maybe_unused]] const bool clear_known =
        clear_fresh && wall_clear2_.size() >= static_cast<std::size_t>(n) + 8;
    [[maybe_unused]] const float* clear2_of = wall_clear2_.data();
    // Ahead of the next sort (CellGrid::set_ahead): the new positions'
    // bounding box (std::min's rule: a NaN is passed over), which also tells
    // whether any left the domain, their cells on the current grid, and a
    // byte per eight particles marking those whose cell changed.
    Index* const cells_ahead = grid_.can_look_ahead(n) ? grid_.ahead_cells(n) : nullptr;
    unsigned char* const moved_ahead = grid_.ahead_moved();
    const Index* const cells_now = grid_.sorted_cells();
    const CellGrid::Cells8 cells8 = grid_.cells8();
    Real lx = inf, ly = inf, hx = -inf, hy = -inf;
#pragma omp parallel num_threads(team()) reduction(|| : bad) reduction(+ : v2_sum) \
    reduction(min : lx, ly) reduction(max : hx, hy)
    {
      __m512d vlx = _mm512_set1_pd(inf), vly = vlx, vhx = _mm512_set1_pd(-inf), vhy = vhx;
#pragma omp for schedule(static)
      for (Index c = 0; c < chunks; ++c) {
        const Index i0 = 8 * c, left = std::min<Index>(8, n - i0);
        const unsigned doubles = 2u * static_cast<unsigned>(left);
        const __mmask8 lanes = left == 8 ? __mmask8(0xFF) : static_cast<__mmask8>((1u << left) - 1);
        const __mmask8 lo = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
        const __mmask8 hi = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
        // o: particles i0 .. i0 + 3; o8: i0 + 4 .. i0 + 7, kept inside the arrays
        // when the chunk has no such particles (hi is then empty).
        const std::size_t o = 2 * static_cast<std::size_t>(i0), o8 = hi ? o + 8 : o;
        const __m512d x_lo = _mm512_maskz_loadu_pd(lo, xd + o);
        const __m512d x_hi = _mm512_maskz_loadu_pd(hi, xd + o8);
        // v + kick a, then x + dt v: the scalar loop's arithmetic as GCC compiles
        // it (-ffp-contract=fast, the default with -std=gnu++17: one FMA each)
        __m512d v_lo = _mm512_fmadd_pd(kv, _mm512_maskz_loadu_pd(lo, ad + o),
                                       _mm512_maskz_loadu_pd(lo, vd + o));
        __m512d v_hi = _mm512_fmadd_pd(kv, _mm512_maskz_loadu_pd(hi, ad + o8),
                                       _mm512_maskz_loadu_pd(hi, vd + o8));
        __m512d xn_lo = _mm512_fmadd_pd(dtv, v_lo, x_lo);
        __m512d xn_hi = _mm512_fmadd_pd(dtv, v_hi, x_hi);
        _mm512_mask_storeu_pd(xn + o, lo, xn_lo);
        _mm512_mask_storeu_pd(xn + o8, hi, xn_hi);
        _mm512_mask_storeu_pd(vn + o, lo, v_lo);
        _mm512_mask_storeu_pd(vn + o8, hi, v_hi);
        auto finite = [zero](__m512d u) {  // u - u is 0 unless u is inf or NaN
          return _mm512_cmp_pd_mask(_mm512_sub_pd(u, u), zero, _CMP_EQ_OQ);
        };
        // The new positions and velocities as x and y lanes (again after any
        // collision, which may change them).
        __m512d to_x = x_of8(xn_lo, xn_hi), to_y = y_of8(xn_lo, xn_hi);
        __m512d vx = x_of8(v_lo, v_hi), vy = y_of8(v_lo, v_hi);
        if constexpr ((F & kWalls) != 0) {
          const __mmask8 ok = lanes & finite(to_x) & finite(to_y) & finite(vx) & finite(vy);
          const __m512d from_x = x_of8(x_lo, x_hi), from_y = y_of8(x_lo, x_hi);
          __mmask8 may;
          if (clear_known) {
            // A path shorter than the particle's clearance meets no wall: every
            // wall within h of it is in its lookup cell (none where no wall
            // comes near, nor off the lookup grid), and the clearance is less
            // than h / 2 and than the distance to the nearest of those walls.
            const __m512d c2 = _mm512_cvtps_pd(_mm256_loadu_ps(clear2_of + i0));
            const __m512d dx = _mm512_sub_pd(to_x, from_x), dy = _mm512_sub_pd(to_y, from_y);
            const __mmask8 short_path =
                _mm512_cmp_pd_mask(_mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy)), c2, _CMP_LT_OQ);
            may = ok & ~short_path;
          } else {
            may = walls_.may_hit8(ok, from_x, from_y, to_x, to_y);
          }
          if (may) {
            for (unsigned k = 0; k < 8; ++k) {
              if (!(may >> k & 1u)) continue;
              const Index i = i0 + static_cast<Index>(k);
              walls_.collide(x[i], x_new[i], v_new[i], e);
            }
            xn_lo = _mm512_maskz_loadu_pd(lo, xn + o);
            xn_hi = _mm512_maskz_loadu_pd(hi, xn + o8);
            v_lo = _mm512_maskz_loadu_pd(lo, vn + o);
            v_hi = _mm512_maskz_loadu_pd(hi, vn + o8);
            to_x = x_of8(xn_lo, xn_hi);
            to_y = y_of8(xn_lo, xn_hi);
            vx = x_of8(v_lo, v_hi);
            vy = y_of8(v_lo, v_hi);
          }
        }
        const __m512d v2 = _mm512_fmadd_pd(vx, vx, _mm512_mul_pd(vy, vy));
        // Written so that NaN fails every comparison and so trips.
        const __mmask8 fine = finite(to_x) & finite(to_y) &
                              _mm512_cmp_pd_mask(v2, v2_cap, _CMP_LE_OQ) &
                              _mm512_cmp_pd_mask(_mm512_maskz_loadu_pd(lanes, rho + i0), rho_cap,
                                                 _CMP_LE_OQ);
        bad = bad || (fine & lanes) != lanes;
        v2_sum += _mm512_reduce_add_pd(_mm512_maskz_mov_pd(lanes, v2));
        vlx = _mm512_mask_min_pd(vlx, lanes, to_x, vlx);
        vly = _mm512_mask_min_pd(vly, lanes, to_y, vly);
        vhx = _mm512_mask_max_pd(vhx, lanes, to_x, vhx);
        vhy = _mm512_mask_max_pd(vhy, lanes, to_y, vhy);
        if (cells_ahead) {
          const __m256i cells = cells8(to_x, to_y);
          _mm256_mask_storeu_epi32(cells_ahead + i0, lanes, cells);
          moved_ahead[c] = _mm256_mask_cmpneq_epi32_mask(
              lanes, cells, _mm256_maskz_loadu_epi32(lanes, cells_now + i0));
        }
      }
      lx = _mm512_reduce_min_pd(vlx);
      ly = _mm512_reduce_min_pd(vly);
      hx = _mm512_reduce_max_pd(vhx);
      hy = _mm512_reduce_max_pd(vhy);
    }
    const Real kinetic = 0.5 * params_.mass * v2_sum;
    if (bad || (guard &&
                !(kinetic + energy_removed_ <= params_.guard_energy_factor * energy_budget_)))
      trip(dt, x_new, v_new, rho, kinetic);
    ps_.x.commit_write();
    ps_.v.commit_write();
    if (cells_ahead) {
      grid_.set_ahead(n, Vec2(lx, ly), Vec2(hx, hy));
    } else {
      grid_.drop_ahead();
    }
    // (all finite here: the guard trips on any non-finite position)
    const Vec2 lo = params_.domain_min, hi = params_.domain_max;
    all_inside_ = lx >= lo.x() && ly >= lo.y() && hx <= hi.x() && hy <= hi.y();
    return;
  } else
#endif
  {
#pragma omp parallel for schedule(static) num_threads(team()) reduction(|| : bad) \
    reduction(+ : v2_sum)
    for (Index i = 0; i < n; ++i) {
      const Vec2 x_old = x[i];
      Vec2 vi = v[i] + kick * a[i];
      Vec2 xi = x_old + dt * vi;
      if constexpr ((F & kWalls) != 0)
        if (xi.allFinite() && vi.allFinite() && walls_.may_hit(x_old, xi))
          walls_.collide(x_old, xi, vi, e);
      if constexpr ((F & kPeriodic) != 0) xi = box_.wrap(xi);
      const Real v2 = vi.squaredNorm();
      // Written so that NaN fails every comparison and so trips.
      bad = bad || !(xi.allFinite() && v2 <= v2_max && rho[i] <= rho_max);
      v2_sum += v2;
      x_new[i] = xi;
      v_new[i] = vi;
    }
  }
  const Real kinetic = 0.5 * params_.mass * v2_sum;
  if (bad ||
      (guard && !(kinetic + energy_removed_ <= params_.guard_energy_factor * energy_budget_)))
    trip(dt, x_new, v_new, rho, kinetic);
  ps_.x.commit_write();
  ps_.v.commit_write();
  grid_.drop_ahead();
  all_inside_ = false;
}

// solver_wcsph.cpp's kick-drift-kick calls integrate<F> too: emit every one.
template void Solver::integrate<0>(Real, Real);
template void Solver::integrate<1>(Real, Real);
template void Solver::integrate<2>(Real, Real);
template void Solver::integrate<3>(Real, Real);
template void Solver::integrate<4>(Real, Real);
template void Solver::integrate<5>(Real, Real);
template void Solver::integrate<6>(Real, Real);
template void Solver::integrate<7>(Real, Real);
template void Solver::integrate<8>(Real, Real);
template void Solver::integrate<9>(Real, Real);
template void Solver::integrate<10>(Real, Real);
template void Solver::integrate<11>(Real, Real);
template void Solver::integrate<12>(Real, Real);
template void Solver::integrate<13>(Real, Real);
template void Solver::integrate<14>(Real, Real);
template void Solver::integrate<15>(Real, Real);

// Names the step, the time, the first particle that failed and the check.
void Solver::trip(Real dt, const Vec2* x_new, const Vec2* v_new, const Real* rho_new,
                  Real kinetic) const {
  const Index n = size();
  const Real rho0 = params_.rho0, c = params_.sound_speed();
  const std::string where = "step " + std::to_string(step_count_ + 1) + " (t = " +
                            fmt(time_ + dt) + " s): particle id ";
  for (Index i = 0; i < n; ++i) {
    const std::string who = where + std::to_string(ps_.id[i]);
    const std::string numbers = " (acceleration " + fmt(ps_.a[i]) + " m/s^2, density " +
                                fmt(ps_.rho[i]) + " kg/m^3, pressure " + fmt(ps_.p[i]) +
                                " Pa, position " + fmt(ps_.x[i]) + ", velocity " +
                                fmt(ps_.v[i]) + ")";
    if (!(x_new[i].allFinite() && v_new[i].allFinite()))
      throw InstabilityError(who + " got a non-finite velocity or position [check: finite]" +
                             numbers);
    if (!params_.guard && rho_new[i] > 0) continue;
    if (!(rho_new[i] <= params_.guard_density_ratio * rho0 && rho_new[i] > 0))
      throw InstabilityError(who + ": density " + fmt(rho_new[i]) + " kg/m^3 is over " +
                             fmt(params_.guard_density_ratio) + " rho0 [check: density]" +
                             numbers);
    const Real speed = v_new[i].norm();
    if (!(speed <= params_.guard_speed_factor * c))
      throw InstabilityError(who + ": speed " + fmt(speed) + " m/s is over " +
                             fmt(params_.guard_speed_factor) + " times the speed of sound " +
                             fmt(c) + " m/s [check: speed]" + numbers);
  }
  Index fastest = 0;
  for (Index i = 1; i < n; ++i)
    if (v_new[i].squaredNorm() > v_new[fastest].squaredNorm()) fastest = i;
  const std::string carried =
      energy_removed_ > 0 ? " plus " + fmt(energy_removed_) + " J/m carried out of the domain by " +
                                "the particles removed"
                          : std::string();
  throw InstabilityError(
      where + std::to_string(n > 0 ? ps_.id[fastest] : -1) + " is the fastest at " +
      fmt(n > 0 ? v_new[fastest].norm() : 0) + " m/s: the kinetic energy " + fmt(kinetic) +
      " J/m" + carried + " exceeds " + fmt(params_.guard_energy_factor) +
      " times all the energy the scene can supply (" + fmt(energy_budget_) +
      " J/m) [check: energy]");
}

void Solver::remove_outside_domain() {
  const Index n = size();
  const Vec2* x = ps_.x.data();
  const Vec2 lo = params_.domain_min, hi = params_.domain_max;
  auto inside = [&](const Vec2& p) { return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all(); };
  // Whether any particle is outside (a NaN coordinate counts as outside), in a
  // loop without branches that the compiler vectorises; where, only then.
  const Real* xd = reinterpret_cast<const Real*>(x);
  const Real lx = lo.x(), ly = lo.y(), hx = hi.x(), hy = hi.y();
  int out = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(| : out)
  for (Index i = 0; i < n; ++i)
    out |= !(xd[2 * i] >= lx) | !(xd[2 * i] <= hx) | !(xd[2 * i + 1] >= ly) |
           !(xd[2 * i + 1] <= hy);
  if (!out) return;
  Index first_out = 0;
  while (inside(x[first_out])) ++first_out;
  keep_.assign(n, 1);
  Index removed = 0;
  Real v2_out = 0;
  for (Index i = first_out; i < n; ++i)
    if (!inside(x[i])) {
      keep_[i] = 0;
      ++removed;
      v2_out += ps_.v[i].squaredNorm();
    }
  energy_removed_ += Real(0.5) * params_.mass * v2_out;
  wall_clear_fresh_ = false;  // the clearances are by storage index
  in_sort_order_ = false;     // and so is the grid's last sort
  grid_.drop_ahead();
  ps_.compact(keep_);
  removed_ += removed;
}

}  // namespace sphfluid
