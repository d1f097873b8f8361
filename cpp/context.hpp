// What a method's step works on, and the services every method shares: the
// particles, the parameters, the walls and their ghosts, the neighbour search,
// the integrator with the blow-up guard, the time-step control, the domain's
// edge and the clock. Knows no particular method: what it needs of one (its
// speed of sound, the length in its time-step conditions) comes from the
// method's registration (methods/method.hpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "boundary/damping.hpp"
#include "boundary/flows.hpp"
#include "boundary/ghosts.hpp"
#include "boundary/walls.hpp"
#include "core/periodic.hpp"
#include "core/params.hpp"
#include "core/particles.hpp"
#include "core/timer.hpp"
#include "core/types.hpp"
#include "neighbours/search.hpp"

namespace sphfluid {

// Numerical blow-up detected during a step (arrives in Python as
// sphfluid.InstabilityError, a RuntimeError).
class InstabilityError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A number as the guard's messages print it ("nan", not "-nan").
std::string fmt(Real x);
std::string fmt(const Vec2& u);

class Context {
 public:
  Context(const SimParams& params, std::vector<Segment> walls);

  const SimParams& params() const { return params_; }
  ParticleSet ps;
  PeriodicBox box;
  WallSet walls;
  Flows flows;
  Damping damping;  // the damping zones (boundary/damping.hpp)
  NeighbourSearch search;
  Ghosts ghosts;
  PhaseTimer timer;

  Index size() const { return ps.size(); }
  int threads() const { return threads_; }
  void set_threads(int threads) { threads_ = resolve_threads(threads); }
  // The threads of the step's loops: threads(), or one below kParallelMin
  // particles (parallel.hpp).
  int team() const { return threads_for(size(), threads_); }

  // The clock and the counts.
  Real time() const { return time_; }
  std::int64_t step_count() const { return step_count_; }
  Real last_dt() const { return last_dt_; }
  TimeStepLimit last_limit() const { return last_limit_; }
  std::int64_t removed() const { return removed_; }
  // Wall crossings the collisions stopped (bounces and stops), over the run.
  std::int64_t wall_crossings() const { return wall_crossings_; }
  // The particle count's balance: placed (set and added through the API,
  // less those replaced) + entered (emitters and inlets) - out (outlets) -
  // sunk - removed = size().
  struct Balance {
    std::int64_t placed = 0, entered = 0, out = 0, sunk = 0;
  };
  Balance balance;
  // The clock and the counts as a checkpoint holds them.
  void restore_clock(Real time, std::int64_t steps, Real last_dt, TimeStepLimit limit,
                     std::int64_t removed, std::int64_t wall_crossings) {
    time_ = time;
    step_count_ = steps;
    last_dt_ = last_dt;
    last_limit_ = limit;
    removed_ = removed;
    wall_crossings_ = wall_crossings;
  }
  // A step of dt is done.
  void advance(Real dt) {
    time_ += dt;
    ++step_count_;
  }

  // This step's dt: the fixed one (dt > 0) or the largest the sound-speed and
  // flow CFL, force and viscous conditions allow from the accelerations just
  // computed (at most dt_cap when > 0); recorded as last_dt().
  Real step_size(Real dt, Real dt_cap);
  // The last step's size before a cap shortened it to land on an end time
  // (the fixed dt, or the conditions' step).
  Real free_dt() const { return free_dt_; }

  // v += kick a; x += dt v (semi-implicit Euler for kick = dt; the first half
  // of kick-drift-kick for kick = dt/2), then the wall collision of the same
  // particle (seed 4.2), written into fresh buffers; the guard then checks
  // the new state (non-finite values, density, speed, kinetic energy), and
  // only a good one replaces the old (else InstabilityError).
  // With `shift` (per particle, m), the drift is x += dt v + shift[i] (a
  // method's particle shifting), the wall collision on that whole path.
  template <bool Walls, bool Periodic>
  void integrate(Real dt, Real kick, const Vec2* shift = nullptr);
  // a += extra (when given) + g; with half > 0 also the second half-kick of
  // kick-drift-kick, v += half a, each particle's as soon as its acceleration
  // is known, into a fresh buffer: a non-finite result keeps the half-step
  // velocities (InstabilityError).
  void add_gravity_and_kick(Real half, const Vec2* extra);
  // After the drift: moving walls move to the step's end; the damping zones
  // slow what is in them; the outlets act;
  // particles that left the domain are removed (and counted), unless the
  // integration saw every particle inside; then the sinks, emitters and
  // inlets act (exchange).
  void leave_domain() {
    if (walls.moves()) {  // the walls where the step ends, for its evaluation
      walls.move_to(time_ + last_dt_);
      ghosts.stale();
    }
    if (damping.any()) damping.apply(ps.x.data(), ps.v.data(), size(), last_dt_, team());
    // (what passed an outlet's buffer leaves as out, even across the domain's edge)
    if (flows.has_outlets()) hold_outlets();
    if (!all_inside_) remove_outside_domain();
    if (flows.any()) exchange();
  }
  void remove_outside_domain();
  // The sinks remove what is inside them, the emitters add this step's rows
  // (with the step's end time, time() + last_dt()), each counted, and the
  // inlets hold their buffers on their lattice.
  void exchange();
  // With outlets, per particle: 1 when held in an outlet's buffer, where a
  // method whose density is summed sets the reference pressure (a carried
  // density is held at rho0 there); null without outlets.
  const std::int8_t* outlet_held() const { return held_ ? held_->data() : nullptr; }
  // With outlets, per particle: the pressure over the reference pressure a
  // held particle holds, rho0 |g| times its depth below the surface of the
  // fluid before its outlet (hydrostatic; 0 without gravity and where not
  // held); null without outlets.
  const Real* outlet_pressure() const { return head_ ? head_->data() : nullptr; }
  // The particles were replaced (Solver::set_state): none is held yet.
  void release_outlets() {
    if (held_) std::fill(held_->data(), held_->data() + size(), std::int8_t(0));
    if (head_) std::fill(head_->data(), head_->data() + size(), Real(0));
  }
  // The flows changed: the outlets' per-particle fields made (or dropped),
  // the inlets' buffers added at time() (counted as entered) and the
  // outlets' (fluid at rest, counted as placed).
  void flows_set();
  // Called with the first index of particles just appended (the method gives
  // them its initial values; set by the Solver).
  std::function<void(Index)> on_added;
  // The guard's budget is set anew from the state (by `rebudget`, set by the
  // Solver) before the next integration's check: emitted particles bring
  // energy (kinetic, gravitational, the state equation's) that is known once
  // they are evaluated. Pouring is an energy input, as add_particles is.
  bool budget_stale = false;
  std::function<void()> rebudget;
  // Positions moved into the box along its periodic axes.
  void wrap_positions();
  // The particles were replaced, added or removed: the sort starts afresh and
  // the walls' clearances are stale.
  void particles_changed() {
    search.forget_order();
    ghosts.stale();
  }

  // The guard's budget: the energy the scene can supply, J per m of depth
  // (set with the particles, Solver::compute_energy_budget), and the kinetic
  // energy carried out of the domain by the particles removed since.
  Real energy_budget = 0;
  Real energy_removed = 0;
  // The method's speed of sound and the length in its time-step conditions
  // (its registration's values for these parameters).
  Real sound_speed = 0, step_length = 0;
  // Whether the speed of sound enters the CFL condition (the registration's).
  bool sound_limits_step = true;

  // Names the step, the time, the first particle that failed a check after an
  // integration to (x_new, v_new) with densities rho_new, and the check.
  [[noreturn]] void trip(Real dt, const Vec2* x_new, const Vec2* v_new, const Real* rho_new,
                         Real kinetic) const;
  std::size_t scratch_bytes() const { return keep_.capacity(); }

 private:
  Real choose_dt(Real dt_cap);
  // The guard's bounds on the density (rho_min < rho <= rho_max) and on |v|^2
  // after an integration (infinite with the guard off: only non-finite
  // values trip it then).
  struct GuardLimits {
    Real rho_min, rho_max, v2_max;
  };
  GuardLimits guard_limits() const {
    const Real inf = std::numeric_limits<Real>::infinity();
    const Real v_max = params_.guard_speed_factor * sound_speed;
    if (!params_.guard) return {-inf, inf, inf};
    return {0, params_.guard_density_ratio * params_.rho0, v_max * v_max};
  }
  // The integration into x_new and v_new, eight particles at a time where the
  // lanes run (without periodic seams), else one at a time: whether any check
  // failed, the sum of the new |v|^2, and (eight at a time) the new
  // positions' bounding box and whether their cells were looked ahead.
  struct Integration {
    bool bad = false;
    Real v2_sum = 0;
    std::int64_t crossings = 0;  // wall crossings the collisions stopped
    bool box = false, ahead = false;
    Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();
  };
  template <bool Walls>
  Integration integrate8(Real dt, Real kick, Vec2* x_new, Vec2* v_new);
  template <bool Walls, bool Periodic>
  Integration integrate1(Real dt, Real kick, Vec2* x_new, Vec2* v_new, const Vec2* shift);

  const SimParams& params_;
  int threads_ = 1;
  Real time_ = 0;
  Real last_dt_ = 0;
  Real free_dt_ = 0;
  TimeStepLimit last_limit_ = TimeStepLimit::kFixed;
  std::int64_t step_count_ = 0;
  std::int64_t removed_ = 0;
  std::int64_t wall_crossings_ = 0;
  // The last integration found every particle within the domain (its
  // vector loop checks; remove_outside_domain's pass is then skipped).
  bool all_inside_ = false;
  std::vector<char> keep_;  // scratch for domain removal
  std::vector<Vec2> new_x_, new_v_;  // scratch for the emitters' rows
  // Per particle, with outlets: whether it is held in an outlet's buffer.
  std::unique_ptr<Field<std::int8_t>> held_;
  std::unique_ptr<Field<Real>> head_;  // outlet_pressure()
  std::vector<Real> surface_;  // per outlet: outlet_lanes()
  std::vector<Flows::Place> places_;  // scratch for the outlets
  std::vector<Real> lane_sum_;
  std::vector<Index> lane_count_;
  std::vector<Vec2> lane_v_;
  // lane_v_ and surface_ (per lane, per outlet) from the fluid before the lines.
  void outlet_lanes(const Flows::Place* place, const std::int8_t* held);
  // The outlets hold their buffers' velocities and let out what passed them.
  void hold_outlets();
  void hold_inlets();
  // new_x_, new_v_ as particles from first_new on, counted as entered or placed
  void append(Index first_new, bool entered = true);
  // Remove the particles for which out(x, v) holds; returns how many.
  template <class Out>
  Index remove_where(Index first_out, Out out);
};

}  // namespace sphfluid
