// Solver: a run of one method on a set of particles and walls. Checks the
// parameters, owns the Context (the particles and the shared services,
// context.hpp) and the method (methods/), picks the method's step for the
// scene's optional terms, sets the guard's energy budget, and retries a step
// that tripped the guard with smaller steps where asked. The API the bindings
// expose.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "context.hpp"
#include "core/features.hpp"
#include "core/params.hpp"
#include "methods/method.hpp"

namespace sphfluid {

// Everything the next step depends on: each particle field by name, in
// storage order, as its numbers (FieldBase); the clock and the counts; the
// guard's budget; the method's own numbers (SphMethod::carried). Restoring
// one into a solver of the same parameters continues the run bit for bit.
struct Snapshot {
  struct FieldData {
    std::string name;
    int components = 1;
    std::size_t scalar_bytes = 0;
    bool integral = false;
    std::vector<unsigned char> bytes;
  };
  std::vector<FieldData> fields;
  Real time = 0, last_dt = 0;
  std::int64_t step_count = 0, removed = 0, retried_steps = 0, wall_crossings = 0;
  TimeStepLimit last_limit = TimeStepLimit::kFixed;
  Real energy_budget = 0, energy_removed = 0;
  Context::Balance balance;
  std::vector<Real> emitter_travel;  // Flows::travelled
  std::vector<Real> method;
};

class Solver {
 public:
  // positions, velocities: n entries each; ids: n entries or empty (0..n-1).
  Solver(const SimParams& params, std::vector<Vec2> positions, std::vector<Vec2> velocities,
         std::vector<Id> ids, std::vector<Segment> walls);

  // Advance n steps of size dt.
  void step(Real dt, int n = 1);
  // Advance n steps, each with the largest stable dt (SimParams: cfl, ...).
  void step_adaptive(int n = 1);
  // Adaptive steps until time() reaches t_end (the last step is shortened to
  // land on it) or max_steps were taken; returns the number of steps.
  std::int64_t advance_adaptive(Real t_end, std::int64_t max_steps);
  // Density, pressure and acceleration for the current state; nothing moves
  // (storage may be re-ordered, as in every step).
  void compute_forces() {
    ctx_.ps.own_fields();
    method_->evaluate();
  }
  // Replace all particles; ids empty gives 0..n-1. An inlet's or outlet's
  // buffer that the new particles leave empty is filled again (as at the start).
  void set_state(std::vector<Vec2> positions, std::vector<Vec2> velocities, std::vector<Id> ids);
  // The particles are the scene's fluid as its regions filled the lattice: a
  // method may settle them (wcsph's continuity density compresses them to its
  // hydrostatic start, W23b); where one did, the forces are evaluated again.
  void settle_fluid();
  // Append particles with fresh ids (one above the largest in use).
  void add_particles(const std::vector<Vec2>& positions, const std::vector<Vec2>& velocities);
  // A checkpoint of the state, and continuing from one (std::invalid_argument
  // when its fields are not this run's: another method or other options).
  Snapshot snapshot() const;
  void restore(const Snapshot& s);
  // Replace the walls; the step is re-specialised if walls appear or vanish.
  void set_walls(std::vector<Segment> walls);
  // The walls' surface velocities, one per segment (their tangential parts).
  void set_wall_velocities(const std::vector<Vec2>& velocities);
  // Moving walls (WallSet::set_motions): motion_of[k] is segment k's motion
  // or -1; the walls as they are now are their drawn positions.
  void set_wall_motions(std::vector<WallMotion> motions, const std::vector<Index>& motion_of);
  // Replace the emitters, inlets, sinks and outlets (boundary/flows.hpp);
  // they act from the next step, the emitters' rows on the lattice of this
  // spacing (m); the inlets' buffers are placed now. Throws
  // std::invalid_argument for one that cannot work.
  void set_flows(std::vector<Emitter> emitters, std::vector<Sink> sinks,
                 std::vector<Outlet> outlets, Real spacing);
  // Replace the damping zones (boundary/damping.hpp); they act from the next
  // step. Throws std::invalid_argument for one that cannot work.
  void set_damping(std::vector<DampingZone> zones) { ctx_.damping.set(std::move(zones)); }
  const Damping& damping() const { return ctx_.damping; }
  const Flows& flows() const { return ctx_.flows; }
  const Context::Balance& balance() const { return ctx_.balance; }
  void set_threads(int threads);

  const SimParams& params() const { return params_; }
  const ParticleSet& particles() const { return ctx_.ps; }
  const WallSet& walls() const { return ctx_.walls; }
  unsigned features() const { return features_; }
  Index size() const { return ctx_.size(); }
  Real time() const { return ctx_.time(); }
  std::int64_t step_count() const { return ctx_.step_count(); }
  std::int64_t removed() const { return ctx_.removed(); }
  std::int64_t wall_crossings() const { return ctx_.wall_crossings(); }
  Real last_dt() const { return ctx_.last_dt(); }
  TimeStepLimit last_limit() const { return ctx_.last_limit(); }
  int threads() const { return ctx_.threads(); }
  // The threads of the step's loops: threads(), or one below kParallelMin
  // particles (parallel.hpp).
  int team() const { return ctx_.team(); }
  // The energy the scene can supply (J per m of depth): kinetic + the most
  // gravity can release within the domain + the state equation's elastic
  // energy + a surface-energy bound; set when the particles are set.
  Real energy_budget() const { return ctx_.energy_budget; }
  // Kinetic energy (J per m of depth) carried out of the domain by the particles
  // removed since the budget was set: the guard's energy check counts it, so a
  // blow-up that throws particles out of the domain still trips it.
  Real energy_removed() const { return ctx_.energy_removed; }
  // The method's surface energy at the last evaluation (wcsph with tension), J
  // per m of depth; 0 otherwise.
  Real surface_energy() const { return method_->surface_energy(); }
  SolveStats solve_stats() const { return method_->solve_stats(); }
  // Whether the seed's pair forces run in float (asked for, and the step runs
  // them by cell clusters), and whether its double ones take 1/r from Newton
  // steps (by CPU).
  bool float_pairs() const { return method_->float_pairs(); }
  bool recip_root() const { return method_->recip_root(); }
  bool quintic_pressure() const { return method_->quintic_pressure(); }
  std::int64_t retried_steps() const { return retried_steps_; }
  // Messages of the most recent retries (at most kRetryLog), oldest first.
  const std::vector<std::string>& retry_log() const { return retry_log_; }
  const std::array<double, kNumPhases>& phase_seconds() const { return ctx_.timer.seconds(); }
  void reset_phase_seconds() { ctx_.timer.reset(); }
  // Sorts since the solver was made, by what they did (NeighbourSearch).
  const std::array<std::int64_t, 4>& sort_counts() const { return ctx_.search.sort_counts(); }
  // Total number of neighbour pairs (i, j), j != i, of the last evaluation.
  std::int64_t neighbour_pairs() const { return ctx_.search.pairs(); }
  // Heap bytes held by the solver's arrays (capacity included), by part.
  std::vector<std::pair<std::string, std::size_t>> memory_bytes() const;

 private:
  // One step (fixed dt > 0, or adaptive), retried with halved dt on a trip.
  void guarded_step(Real dt, Real dt_cap);
  void compute_energy_budget();
  void select_step();
  void check_state(const std::vector<Vec2>& x, const std::vector<Vec2>& v,
                   const std::vector<Id>& ids) const;
  // After the particles were replaced or added: into the domain, evaluated,
  // and the guard's budget set.
  void particles_set();

  static constexpr std::size_t kRetryLog = 100;

  SimParams params_;
  Context ctx_;
  std::unique_ptr<SphMethod> method_;
  unsigned features_ = 0;
  std::int64_t retried_steps_ = 0;
  std::vector<std::string> retry_log_;
};

}  // namespace sphfluid
