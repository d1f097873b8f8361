// The shared services of a step that are not the integration: the time-step
// control, the guard's messages, the domain's edge and the periodic wrap.
#include "context.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "terms/wcsph.hpp"

namespace sphfluid {

std::string fmt(Real x) {
  if (std::isnan(x)) return "nan";  // not "-nan": the sign of a NaN means nothing
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

std::string fmt(const Vec2& u) { return "(" + fmt(u.x()) + ", " + fmt(u.y()) + ")"; }

Context::Context(const SimParams& params, std::vector<Segment> segments)
    : box(params.domain_min, params.domain_max, params.periodic_x, params.periodic_y),
      walls(std::move(segments), params.h),
      params_(params),
      threads_(resolve_threads(params.threads)) {}

// The largest dt allowed by the sound-speed/flow CFL, force and viscous
// conditions (SimParams), from the accelerations just computed.
Real Context::choose_dt(Real dt_cap) {
  const Index n = size();
  const Vec2* v = ps.v.data();
  const Vec2* a = ps.a.data();
  Real v2 = 0, a2 = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(max : v2, a2)
  for (Index i = 0; i < n; ++i) {
    v2 = std::max(v2, v[i].squaredNorm());
    a2 = std::max(a2, a[i].squaredNorm());
  }
  const SimParams& P = params_;
  const Real inf = std::numeric_limits<Real>::infinity();
  const Real l = step_length;
  // (a moving wall's speed counts: it may not move more than the flow a step)
  const Real c = sound_limits_step ? sound_speed : Real(0);
  Real dt = P.cfl * l / (c + std::sqrt(v2) + walls.max_speed());
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
  free_dt_ = dt;
  return dt_cap > 0 ? std::min(dt, dt_cap) : dt;
}

Real Context::step_size(Real dt, Real dt_cap) {
  if (dt > 0) {
    last_limit_ = TimeStepLimit::kFixed;
    free_dt_ = dt;
  } else {
    dt = choose_dt(dt_cap);
  }
  last_dt_ = dt;
  return dt;
}

void Context::trip(Real dt, const Vec2* x_new, const Vec2* v_new, const Real* rho_new,
                   Real kinetic) const {
  const Index n = size();
  const Real rho0 = params_.rho0, c = sound_speed;
  const std::string where = "step " + std::to_string(step_count_ + 1) + " (t = " +
                            fmt(time_ + dt) + " s): particle id ";
  for (Index i = 0; i < n; ++i) {
    const std::string who = where + std::to_string(ps.id[i]);
    const std::string numbers = " (acceleration " + fmt(ps.a[i]) + " m/s^2, density " +
                                fmt(ps.rho[i]) + " kg/m^3, pressure " + fmt(ps.p[i]) +
                                " Pa, position " + fmt(ps.x[i]) + ", velocity " +
                                fmt(ps.v[i]) + ")";
    if (!(x_new[i].allFinite() && v_new[i].allFinite()))
      throw InstabilityError(who + " got a non-finite velocity or position [check: finite]" +
                             numbers);
    if (!params_.guard && rho_new[i] > 0) continue;
    if (!(rho_new[i] <= params_.guard_density_ratio * rho0 && rho_new[i] > 0))
      throw InstabilityError(who + ": density " + fmt(rho_new[i]) + " kg/m^3 is " +
                             (rho_new[i] > 0 ? "over " + fmt(params_.guard_density_ratio) +
                                                   " rho0"
                                             : std::string("not positive")) +
                             " [check: density]" + numbers);
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
      energy_removed > 0 ? " plus " + fmt(energy_removed) + " J/m carried out of the domain by " +
                               "the particles removed"
                         : std::string();
  throw InstabilityError(
      where + std::to_string(n > 0 ? ps.id[fastest] : -1) + " is the fastest at " +
      fmt(n > 0 ? v_new[fastest].norm() : 0) + " m/s: the kinetic energy " + fmt(kinetic) +
      " J/m" + carried + " exceeds " + fmt(params_.guard_energy_factor) +
      " times all the energy the scene can supply (" + fmt(energy_budget) +
      " J/m) [check: energy]");
}

void Context::remove_outside_domain() {
  const Index n = size();
  const Vec2* x = ps.x.data();
  const Vec2 lo = params_.domain_min, hi = params_.domain_max;
  auto inside = [&](const Vec2& p) {
    return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  };
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
  removed_ += remove_where(first_out, [&](const Vec2& p) { return !inside(p); });
}

template <class Out>
Index Context::remove_where(Index first_out, Out out) {
  const Index n = size();
  keep_.assign(n, 1);
  Index removed = 0;
  Real v2_out = 0;
  for (Index i = first_out; i < n; ++i)
    if (out(ps.x[i])) {
      keep_[i] = 0;
      ++removed;
      v2_out += ps.v[i].squaredNorm();
    }
  if (removed == 0) return 0;
  energy_removed += Real(0.5) * params_.mass * v2_out;
  particles_changed();  // the clearances and the grid's last sort are by storage index
  ps.compact(keep_);
  return removed;
}

void Context::exchange() {
  if (flows.has_sinks()) {
    const Index n = size();
    const Vec2* x = ps.x.data();
    int any = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(| : any)
    for (Index i = 0; i < n; ++i) any |= flows.sunk(x[i]);
    if (any) balance.sunk += remove_where(0, [&](const Vec2& p) { return flows.sunk(p); });
  }
  new_x_.clear();
  new_v_.clear();
  try {
    flows.emit(time_, last_dt_, new_x_, new_v_);
  } catch (const std::length_error& e) {
    throw InstabilityError("step " + std::to_string(step_count_ + 1) + " (t = " +
                           fmt(time_ + last_dt_) + " s): " + e.what() + " [check: emitter]");
  }
  if (!new_x_.empty()) append(size());
  if (flows.has_inlets()) hold_inlets();
}

void Context::flows_set() {
  if (flows.has_outlets() && !held_) {
    held_ = std::make_unique<Field<std::int8_t>>(ps, "outlet_held", FieldKind::kState);
    head_ = std::make_unique<Field<Real>>(ps, "outlet_pressure", FieldKind::kState);
  } else if (!flows.has_outlets()) {
    held_.reset();
    head_.reset();
  }
  new_x_.clear();
  new_v_.clear();
  flows.fill_inlets(time_, new_x_, new_v_);
  if (!new_x_.empty()) append(size());
  new_x_.clear();
  flows.fill_outlets(new_x_, ps.x.data(), size(), params_.h);
  new_v_.assign(new_x_.size(), Vec2::Zero());
  if (!new_x_.empty()) append(size(), false);
}

void Context::append(Index n, bool entered) {
  const Index k = static_cast<Index>(new_x_.size());
  if (std::int64_t(n) + k >= INT32_MAX)
    throw std::length_error("the emitters would pass the core's particle limit (2^31 - 1)");
  Id top = -1;  // fresh ids: one above the largest in use
  for (Index i = 0; i < n; ++i) top = std::max(top, ps.id[i]);
  particles_changed();
  ps.resize(n + k);
  for (Index i = 0; i < k; ++i) {
    ps.x[n + i] = new_x_[i];
    ps.v[n + i] = new_v_[i];
    ps.id[n + i] = top + 1 + i;
    if (held_) (*held_)[n + i] = 0;
    if (head_) (*head_)[n + i] = 0;
  }
  // The new particles' energy enters the guard's budget once they are
  // evaluated, at the next integration (budget_stale).
  budget_stale = true;
  (entered ? balance.entered : balance.placed) += k;
  if (on_added) on_added(n);
}

// The particles in an outlet's buffer move straight out at the mean speed
// across the line of the fluid within a support before it in their lane (a
// zero gradient: a lane's particles keep their distances, and none drifts
// into a wall beside the buffer): the step's accelerations are taken back
// from their velocity and path. A lane whose fluid is at rest or flows back
// holds its particles at rest (no backflow through the line: water at rest
// against an outlet stays at rest); one with no fluid before it leaves them
// free. Past the buffer they leave (counted as out). The lanes' sums run in
// index order, the same for any thread count.
void Context::hold_outlets() {
  const Index n = size();
  Vec2* x = ps.x.data();
  Vec2* v = ps.v.data();
  std::int8_t* held = held_->data();
  Real* rho = ps.rho.data();
  const Real dt = last_dt_, reach = params_.h;
  places_.resize(n);
  Flows::Place* place = places_.data();
  int leaving = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(| : leaving)
  for (Index i = 0; i < n; ++i) {
    place[i] = flows.outlet_place(x[i], reach);
    leaving |= place[i].zone == Flows::kPast;
  }
  outlet_lanes(place, held);
  const std::vector<Vec2>& lane_v = lane_v_;
  const std::vector<Real>& surface = surface_;
  // The carried density (continuity) held at the density of its pressure: the
  // reference pressure plus the hydrostatic head (a summed density's pressure
  // is set by the method from outlet_pressure()).
  const bool pressure = params_.continuity;
  const Real rho0 = params_.rho0, g = params_.gravity.norm();
  const Real B = rho0 * params_.c0 * params_.c0 / wcsph::kTaitGamma;
  const Vec2 up = g > 0 ? Vec2(-params_.gravity / g) : Vec2::Zero();
  Real* head = head_->data();
#pragma omp parallel for schedule(static) num_threads(team()) reduction(| : leaving)
  for (Index i = 0; i < n; ++i) {
    held[i] = place[i].zone == Flows::kHeld && lane_count_[place[i].lane] > 0;
    head[i] = 0;
    if (!held[i]) continue;
    // (along the outlet only: the drift across it, walls' reflections
    // included, stands, and a reflected particle is not pushed back)
    const Vec2 u = lane_v[place[i].lane];
    const Real along_u = u.norm();
    const Vec2 out = along_u > 0 ? Vec2(u / along_u)
                                 : flows.outlet_of_lane(place[i].lane).direction;
    x[i] -= dt * (v[i].dot(out) - along_u) * out;
    v[i] = u;
    const Real depth = surface[flows.outlet_index_of_lane(place[i].lane)] - x[i].dot(up);
    if (depth > 0) head[i] = rho0 * g * depth;
    if (pressure) rho[i] = head[i] > 0 ? wcsph::tait_density(head[i], rho0, B) : rho0;
    leaving |= flows.outlet_place(x[i], reach).zone == Flows::kPast;  // moved past it now
  }
  search.grid().drop_ahead();  // positions changed since the integration looked ahead
  if (leaving)
    balance.out += remove_where(0, [&](const Vec2& p) {
      return flows.outlet_place(p, reach).zone == Flows::kPast;
    });
}

// From the fluid before the outlets' lines (`place`: each particle's), in one
// pass in index order:
// - each lane's velocity: straight out at the mean speed across the line,
//   zero where that flows back (lane_count_: how many particles it averages,
//   0 where none is before the line);
// - each outlet's free surface, the level its held particles' hydrostatic
//   pressure is measured from (Tafuni et al. 2018 hold an outflow's pressure
//   hydrostatic, as DualSPHysics's buffers do): the outlet's "level" where the
//   scene gives one, else half a spacing above the highest particle before its
//   line, along -g; -inf (no head) where no fluid is before it, and without
//   gravity.
void Context::outlet_lanes(const Flows::Place* place, const std::int8_t* held) {
  const Index n = size();
  const Vec2* v = ps.v.data();
  const Vec2* x = ps.x.data();
  const Real none = -std::numeric_limits<Real>::infinity();
  const std::vector<Outlet>& outlets = flows.outlets();
  const Real g = params_.gravity.norm();
  const Vec2 up = g > 0 ? Vec2(-params_.gravity / g) : Vec2::Zero();
  lane_sum_.assign(flows.lanes(), 0);
  lane_count_.assign(flows.lanes(), 0);
  surface_.assign(outlets.size(), none);
  for (Index i = 0; i < n; ++i)
    if (place[i].zone == Flows::kUpstream && !held[i]) {
      const int l = place[i].lane;
      lane_sum_[l] += v[i].dot(flows.outlet_of_lane(l).direction);
      ++lane_count_[l];
      if (g > 0) {
        Real& s = surface_[flows.outlet_index_of_lane(l)];
        s = std::max(s, x[i].dot(up));
      }
    }
  lane_v_.assign(flows.lanes(), Vec2::Zero());
  for (int l = 0; l < flows.lanes(); ++l)
    if (lane_count_[l] > 0 && lane_sum_[l] > 0)
      lane_v_[l] = lane_sum_[l] / Real(lane_count_[l]) * flows.outlet_of_lane(l).direction;
  if (!(g > 0)) return;
  for (std::size_t o = 0; o < outlets.size(); ++o) {
    if (!std::isnan(outlets[o].level)) {
      surface_[o] = outlets[o].level;
    } else if (surface_[o] > none) {
      surface_[o] += Real(0.5) * flows.spacing();
    }
  }
}

// The inlets' buffers on their lattice, at the inflow velocity of the step's end.
void Context::hold_inlets() {
  const Index n = size();
  Vec2* x = ps.x.data();
  Vec2* v = ps.v.data();
  const Real t = time_ + last_dt_;
#pragma omp parallel for schedule(static) num_threads(team())
  for (Index i = 0; i < n; ++i) flows.hold_in_inlet(t, x[i], v[i]);
  search.grid().drop_ahead();
}

void Context::wrap_positions() {
  if (!box.any()) return;
  for (Index i = 0; i < size(); ++i) ps.x[i] = box.wrap(ps.x[i]);
}

void Context::add_gravity_and_kick(Real half, const Vec2* extra) {
  const Index n = ps.size();
  const Vec2* v = ps.v.data();
  Vec2* a = ps.a.data();
  const Vec2 g = params_.gravity;
  const bool kick = half > 0;
  Vec2* v_new = kick ? ps.v.begin_write(n) : nullptr;
  bool bad = false;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(|| : bad)
  for (Index i = 0; i < n; ++i) {
    Vec2 f = a[i];
    if (extra) f += extra[i];
    a[i] = f + g;
    if (kick) {
      v_new[i] = v[i] + half * a[i];
      bad = bad || !v_new[i].allFinite();
    }
  }
  if (!kick) return;
  if (bad) {
    for (Index i = 0; i < n; ++i)
      if (!v_new[i].allFinite())
        throw InstabilityError("step " + std::to_string(step_count() + 1) + ": particle id " +
                               std::to_string(ps.id[i]) +
                               " got a non-finite velocity in the second half-kick [check: "
                               "finite] (the state kept is the half step)");
  }
  ps.v.commit_write();
}

}  // namespace sphfluid
