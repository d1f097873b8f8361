// The Solver: the parameters checked, the method made and specialised, the
// particles set, the guard's budget, the steps and their retries.
#include "solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace sphfluid {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

// The parameters, checked (std::invalid_argument naming the first bad one).
const SimParams& checked(const SimParams& P) {
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
  method_entry(P.method).check(P);  // the method's own parameters
  const Vec2 length = P.domain_max - P.domain_min;
  require(!P.periodic_x || length.x() >= 2 * P.h,
          "a periodic x axis needs a domain at least 2 h wide");
  require(!P.periodic_y || length.y() >= 2 * P.h,
          "a periodic y axis needs a domain at least 2 h high");
  return P;
}

}  // namespace

Solver::Solver(const SimParams& params, std::vector<Vec2> positions, std::vector<Vec2> velocities,
               std::vector<Id> ids, std::vector<Segment> walls)
    : params_(checked(params)), ctx_(params_, std::move(walls)) {
  const MethodEntry& entry = method_entry(params_.method);
  ctx_.sound_speed = entry.sound_speed(params_);
  ctx_.step_length = entry.step_length(params_);
  ctx_.sound_limits_step = entry.sound_limits_step;
  method_ = entry.make(ctx_);
  ctx_.on_added = [this](Index first) { method_->particles_added(first); };
  ctx_.rebudget = [this] { compute_energy_budget(); };
  select_step();
  set_state(std::move(positions), std::move(velocities), std::move(ids));
}

void Solver::select_step() {
  const SimParams& P = params_;
  features_ = (P.eta > 0 ? kViscosity : 0u) | (P.sigma > 0 ? kSurfaceTension : 0u) |
              (ctx_.walls.empty() ? 0u : kWalls) | (ctx_.box.any() ? kPeriodic : 0u);
  method_->select(features_);
}

void Solver::set_walls(std::vector<Segment> walls) {
  ctx_.ghosts.stale();  // until the next ghost search measures them anew
  ctx_.walls = WallSet(std::move(walls), params_.h);
  select_step();
  compute_forces();
}

void Solver::set_wall_velocities(const std::vector<Vec2>& velocities) {
  ctx_.walls.set_velocities(velocities);
  compute_forces();
  compute_energy_budget();
}

void Solver::set_wall_motions(std::vector<WallMotion> motions,
                              const std::vector<Index>& motion_of) {
  ctx_.ghosts.stale();
  ctx_.walls.set_motions(std::move(motions), motion_of, ctx_.time());
  select_step();
  compute_forces();
  compute_energy_budget();
}

void Solver::set_flows(std::vector<Emitter> emitters, std::vector<Sink> sinks,
                       std::vector<Outlet> outlets, Real spacing) {
  ctx_.flows.set(std::move(emitters), std::move(sinks), std::move(outlets), spacing);
  const Index before = ctx_.size();
  ctx_.flows_set();
  if (ctx_.size() == before) {
    method_->flows_changed();
    return;
  }
  compute_forces();  // the inlets' buffers, evaluated with the rest
  compute_energy_budget();
}

void Solver::set_threads(int threads) {
  require(threads >= 0, "threads must be >= 0");
  ctx_.set_threads(threads);
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
  check_state(positions, velocities, ids);
  const Index n = static_cast<Index>(positions.size());
  ParticleSet& ps = ctx_.ps;
  ctx_.particles_changed();
  ctx_.balance.placed += std::int64_t(n) - size();
  ps.resize(n);
  for (Index i = 0; i < n; ++i) {
    ps.x[i] = positions[i];
    ps.v[i] = velocities[i];
    ps.id[i] = ids.empty() ? Id(i) : ids[i];
  }
  ctx_.release_outlets();
  if (ctx_.flows.has_inlets() || ctx_.flows.has_outlets()) {
    ctx_.flows.unfill_empty_buffers(ps.x.data(), n);
    ctx_.flows_set();  // a buffer the new state left empty, filled again
  }
  method_->particles_added(0);
  particles_set();
}

void Solver::settle_fluid() {
  if (!method_->fluid_filled()) return;  // the constructor's evaluation stands
  ctx_.particles_changed();
  particles_set();
}

void Solver::add_particles(const std::vector<Vec2>& positions,
                           const std::vector<Vec2>& velocities) {
  check_state(positions, velocities, {});
  ParticleSet& ps = ctx_.ps;
  const Index n = size(), k = static_cast<Index>(positions.size());
  require(std::int64_t(n) + k < INT32_MAX, "too many particles");
  ctx_.particles_changed();
  Id top = -1;  // the largest id in use
  for (Index i = 0; i < n; ++i) top = std::max(top, ps.id[i]);
  require(top < std::numeric_limits<Id>::max() - Id(k),
          "no fresh ids left: the largest id in use is " + std::to_string(top));
  const Id next = top + 1;
  ctx_.balance.placed += k;
  ps.resize(n + k);
  for (Index i = 0; i < k; ++i) {
    ps.x[n + i] = positions[i];
    ps.v[n + i] = velocities[i];
    ps.id[n + i] = next + i;
  }
  method_->particles_added(n);
  particles_set();  // pouring is an energy input: the guard's budget grows with it
}

Snapshot Solver::snapshot() const {
  Snapshot s;
  for (const FieldBase* f : ctx_.ps.fields()) {
    const auto* first = static_cast<const unsigned char*>(f->raw());
    const std::size_t bytes = f->size() * f->components() * f->scalar_bytes();
    s.fields.push_back({f->name(), f->components(), f->scalar_bytes(), f->integral(),
                        std::vector<unsigned char>(first, first + bytes)});
  }
  s.time = ctx_.time();
  s.last_dt = ctx_.last_dt();
  s.step_count = ctx_.step_count();
  s.removed = ctx_.removed();
  s.wall_crossings = ctx_.wall_crossings();
  s.retried_steps = retried_steps_;
  s.last_limit = ctx_.last_limit();
  s.energy_budget = ctx_.energy_budget;
  s.energy_removed = ctx_.energy_removed;
  s.balance = ctx_.balance;
  s.emitter_travel = ctx_.flows.travelled();
  s.method = method_->carried();
  return s;
}

// The method's numbers first (they may make fields), then every field, which
// must match the snapshot's one for one; nothing is evaluated: the fields
// hold the last evaluation's results.
void Solver::restore(const Snapshot& s) {
  std::size_t n = 0;
  for (const Snapshot::FieldData& d : s.fields) {
    const std::size_t value = d.components * d.scalar_bytes;
    require(value > 0 && d.bytes.size() % value == 0,
            "checkpoint: field '" + d.name + "' is not whole values");
    if (&d == &s.fields.front()) n = d.bytes.size() / value;
    require(d.bytes.size() / value == n, "checkpoint: field '" + d.name +
                                             "' differs in length from '" +
                                             s.fields.front().name + "'");
  }
  require(n < static_cast<std::size_t>(INT32_MAX), "checkpoint: too many particles");
  ctx_.flows.set_travelled(s.emitter_travel);
  method_->restore_carried(s.method);
  const auto& fields = ctx_.ps.fields();
  auto find = [&](const FieldBase* f) -> const Snapshot::FieldData* {
    for (const Snapshot::FieldData& d : s.fields)
      if (d.name == f->name()) return &d;
    return nullptr;
  };
  require(fields.size() == s.fields.size(),
          "checkpoint: it holds " + std::to_string(s.fields.size()) +
              " particle fields, this run has " + std::to_string(fields.size()));
  for (const FieldBase* f : fields) {
    const Snapshot::FieldData* d = find(f);
    require(d != nullptr, std::string("checkpoint: no field '") + f->name() + "'");
    require(d->components == f->components() && d->scalar_bytes == f->scalar_bytes() &&
                d->integral == f->integral(),
            std::string("checkpoint: field '") + f->name() + "' has another type");
  }
  ctx_.particles_changed();
  for (FieldBase* f : fields) f->assign(find(f)->bytes.data(), n);
  ctx_.restore_clock(s.time, s.step_count, s.last_dt, s.last_limit, s.removed,
                     s.wall_crossings);
  ctx_.walls.move_to(s.time);
  ctx_.ghosts.stale();
  ctx_.energy_budget = s.energy_budget;
  ctx_.energy_removed = s.energy_removed;
  ctx_.balance = s.balance;
  retried_steps_ = s.retried_steps;
  retry_log_.clear();
}

void Solver::particles_set() {
  ctx_.wrap_positions();
  ctx_.remove_outside_domain();
  compute_forces();
  compute_energy_budget();
}

void Solver::compute_energy_budget() {
  const Index n = size();
  const SimParams& P = params_;
  const ParticleSet& ps = ctx_.ps;
  const Real m = P.mass;
  Real kinetic = 0;
  Vec2 centre = Vec2::Zero();
  for (Index i = 0; i < n; ++i) {
    kinetic += 0.5 * m * ps.v[i].squaredNorm();
    centre += ps.x[i];
  }
  const Real elastic = method_->elastic_energy();
  Real release = 0;  // the most gravity can give: the centre of mass at the domain's far corner
  if (n > 0) {
    centre /= n;
    for (const Vec2& c : {P.domain_min, P.domain_max, Vec2(P.domain_min.x(), P.domain_max.y()),
                         Vec2(P.domain_max.x(), P.domain_min.y())})
      release = std::max(release, n * m * P.gravity.dot(c - centre));
  }
  // Surface energy that tension can release: sigma times the initial surface
  // length (or, unknown, sigma n h). A method whose tension is a surface
  // energy's can release at most that energy, which counts a lone particle's
  // rim too (more than sigma h): the state's own value bounds it.
  Real surface = P.sigma * (P.surface_length > 0 ? P.surface_length : n * P.h);
  surface = std::max(surface, method_->surface_energy());
  const Real c = ctx_.sound_speed;
  const Real floor = 0.5 * n * m * (0.01 * c) * (0.01 * c);
  // A wall whose surface slides, or that moves, drags the fluid at most to
  // its own speed.
  Real drag = 0.5 * n * m * ctx_.walls.top_speed() * ctx_.walls.top_speed();
  for (const Segment& w : ctx_.walls.segments())
    drag = std::max(drag, 0.5 * n * m * w.velocity.squaredNorm());
  // An inlet pushes the fluid ahead of it; where the flow narrows or takes a
  // profile it runs faster than the inflow: twice its top speed is allowed.
  const Real inflow = 2 * ctx_.flows.top_inflow_speed();
  drag = std::max(drag, 0.5 * n * m * inflow * inflow);
  ctx_.energy_budget = kinetic + release + elastic + surface + floor + drag;
  ctx_.energy_removed = 0;
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
  ctx_.ps.own_fields();  // a view taken before the step keeps what it showed
  try {
    method_->step(dt, dt_cap);
    return;
  } catch (const InstabilityError& first) {
    if (params_.max_retries == 0) throw;
    const Real full = dt > 0 ? dt : ctx_.last_dt();
    const Real t_end = ctx_.time() + full;
    std::string reason = first.what();
    for (int level = 1; level <= params_.max_retries; ++level) {
      const std::int64_t parts = std::int64_t(1) << level;
      const Real sub = full / static_cast<Real>(parts);
      if (retry_log_.size() == kRetryLog) retry_log_.erase(retry_log_.begin());
      retry_log_.push_back("retrying with dt = " + fmt(sub) + " s after: " + reason);
      ++retried_steps_;
      try {
        // Sub-steps keep whatever they completed; the last one lands on t_end.
        while (t_end - ctx_.time() > 1e-12 * std::max(Real(1), std::abs(t_end)))
          method_->step(std::min(sub, t_end - ctx_.time()), 0);
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
  while (taken < max_steps &&
         t_end - ctx_.time() > 1e-12 * std::max(Real(1), std::abs(t_end))) {
    guarded_step(0, t_end - ctx_.time());
    ++taken;
  }
  return taken;
}

std::vector<std::pair<std::string, std::size_t>> Solver::memory_bytes() const {
  return {{"particles", ctx_.ps.bytes()},
          {"sort", ctx_.search.sort_bytes()},
          {"neighbours", ctx_.search.list_bytes()},
          {"wall ghosts", ctx_.ghosts.bytes()},
          {"scratch", method_->bytes() + ctx_.scratch_bytes()}};
}

}  // namespace sphfluid
