// What every SPH method gives the solver, and how a method is registered. A
// method owns its per-particle data and a step specialised on the scene's
// optional terms; the shared services of the Context (cpp/context.hpp) do the
// rest. Adding a method: its folder under methods/, one entry in
// methods/registry.cpp, one value of `Method` (core/params.hpp) and the scene
// schema's choice.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/params.hpp"
#include "core/types.hpp"

namespace sphfluid {

class Context;

// An implicit method's pressure solves: the last step's iterations and final
// mean errors (over rho0; the divergence's as a density change over the
// step), and over the run the solves that stopped at the maximum iterations
// and the iterations taken.
struct SolveStats {
  int density_iterations = 0, divergence_iterations = 0;
  Real density_error = 0, divergence_error = 0;
  std::int64_t unconverged = 0, iterations = 0;
};

class SphMethod {
 public:
  virtual ~SphMethod() = default;
  // Specialise the step on the scene's optional terms (core/features.hpp),
  // once, and again when they change (walls appear or vanish).
  virtual void select(unsigned features) = 0;
  // One step: of size dt > 0, or the adaptive one (at most dt_cap when > 0).
  virtual void step(Real dt, Real dt_cap) = 0;
  // Density, pressure and acceleration of the current state; nothing moves
  // (storage may be re-ordered, as in every step).
  virtual void evaluate() = 0;
  // The elastic energy the state holds in the method's state equation, J per
  // m of depth (the guard's budget).
  virtual Real elastic_energy() const = 0;
  // The surface energy of the last evaluation where the method's tension is
  // one (J per m of depth), else 0.
  virtual Real surface_energy() const { return 0; }
  // The seed's pair forces: whether they run in float, and whether 1/r comes
  // from Newton steps (other methods: false).
  virtual bool float_pairs() const { return false; }
  virtual bool recip_root() const { return false; }
  // wcsph's continuity density: whether the last evaluation's pressure force
  // ran on W31's quintic spline (asked for, and the flow not shifted).
  virtual bool quintic_pressure() const { return false; }
  // Particles [first, size) were just set or added: a method that carries
  // state of its own (a density) gives them their initial values.
  virtual void particles_added(Index first) { (void)first; }
  // The particles are the scene's fluid as its regions filled the lattice
  // (Solver::settle_fluid, after particles_added(0)): a method may settle them.
  // Returns whether it moved any.
  virtual bool fluid_filled() { return false; }
  // The inlets or outlets changed and no particle was added (Solver::
  // set_flows removed one, or moved a line): a method that keeps which
  // particles are in their buffers finds them again.
  virtual void flows_changed() {}
  // The numbers of the method's own that the next step reads besides the
  // particle fields (a checkpoint's), and setting them back; restore_carried
  // makes the fields those numbers imply (a lazily made one), before the
  // fields are filled. Its per-particle data the next step reads are fields.
  virtual std::vector<Real> carried() const { return {}; }
  virtual void restore_carried(const std::vector<Real>& values) { (void)values; }
  // The pressure solves of an implicit method (else all zero).
  virtual SolveStats solve_stats() const { return {}; }
  // Heap bytes of the method's own arrays, capacity included.
  virtual std::size_t bytes() const = 0;
};

// A method's registration: what the shared services need to know of it before
// it runs, and how to make one.
struct MethodEntry {
  Method id;
  const char* name;
  // The speed of sound of its state equation, m/s, and the length in the
  // time-step conditions, m.
  Real (*sound_speed)(const SimParams&);
  Real (*step_length)(const SimParams&);
  // Whether the speed of sound limits the time step (false: an implicit
  // pressure, whose steps follow the flow; the speed of sound then bounds the
  // guard's speeds only).
  bool sound_limits_step;
  // Throws std::invalid_argument for a parameter the method cannot run with.
  void (*check)(const SimParams&);
  std::unique_ptr<SphMethod> (*make)(Context&);
};

const MethodEntry& method_entry(Method id);

// Every registration, in order (the bindings name the methods from these).
struct MethodEntries {
  const MethodEntry* first;
  const MethodEntry* last;
  const MethodEntry* begin() const { return first; }
  const MethodEntry* end() const { return last; }
};
MethodEntries method_entries();

}  // namespace sphfluid
