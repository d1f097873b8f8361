// SimParams: every physical and numerical constant of a run, in SI units, and
// the method that runs it. TimeStepLimit names the condition that chose an
// adaptive step. Filled by the Python scene loader (or by hand in tests);
// read by the Solver and the methods.
#pragma once

#include <cmath>

#include "core/types.hpp"

namespace sphfluid {

// The methods (methods/registry.cpp registers each).
enum class Method : int { kSeed = 0, kWcsph = 1, kDfsph = 2 };

enum class TimeStepLimit : int { kFixed, kCfl, kForce, kViscous, kMax };

inline const char* limit_name(TimeStepLimit l) {
  switch (l) {
    case TimeStepLimit::kFixed: return "fixed";
    case TimeStepLimit::kCfl: return "cfl";
    case TimeStepLimit::kForce: return "force";
    case TimeStepLimit::kViscous: return "viscous";
    case TimeStepLimit::kMax: return "dt_max";
  }
  return "?";
}

struct SimParams {
  Method method = Method::kSeed;
  Real h = 0.04;         // smoothing length (kernel support), m
  Real mass = 0.4;       // particle mass, kg per metre of depth
  Real rho0 = 1000.0;    // rest density, kg/m^3
  Real k = 250.0;        // gas constant of p = k (rho - rho0), m^2/s^2
  Real eta = 0.0;        // dynamic viscosity, Pa s
  Real sigma = 0.0;      // surface tension coefficient, N (2D)
  Vec2 gravity{0.0, -9.81};  // m/s^2
  Vec2 domain_min{-1.0, -1.0};  // particles leaving this box are removed, m
  Vec2 domain_max{1.0, 1.0};
  // Periodic axes: a particle leaving the domain's side re-enters at the
  // opposite one, and neighbours are found across the seam.
  bool periodic_x = false;
  bool periodic_y = false;

  // Threshold on |grad c| above which surface tension acts (Mueller 2003).
  // A negative value selects the default kSurfaceThresholdTimesH / h.
  Real surface_threshold = -1.0;  // 1/m

  // Wall ghost particle (seed 4.1): mass and density relative to the fluid's
  // particle mass and rest density. See docs/method-seed.md, "Choices the paper leaves open".
  Real ghost_mass_ratio = 1.0;
  Real ghost_density_ratio = 1.0;

  // Normal restitution of the reflection collision (seed 4.2); 1 = mirror.
  Real restitution = 1.0;

  int threads = 0;  // OpenMP threads; 0 = the OpenMP default

  // The seed's pair forces (pressure, viscosity) summed in single precision
  // where the cell clusters run (CellFloatFrame and SeedFloats); everything else
  // stays in double. docs/method-seed.md, "Pair forces in single precision".
  bool float_pairs = false;

  // Adaptive time step: each step takes the largest dt that satisfies
  //   dt <= cfl l / (c + |v|max)            (sound speed and flow speed)
  //   dt <= kForceFactor sqrt(l / |a|max)   (force)
  //   dt <= kViscousFactor l^2 rho0 / eta   (viscous diffusion)
  // with l = step_length().
  // (Monaghan 1992; Morris, Fox & Zhu 1997), capped by dt_max when > 0.
  Real cfl = 0.4;
  Real dt_max = 0;  // s; 0 = no cap
  static constexpr Real kForceFactor = 0.25;
  static constexpr Real kViscousFactor = 0.125;

  // Blow-up guard, checked after every step; a trip raises InstabilityError
  // and leaves the state of the step before.
  bool guard = true;  // false: only non-finite values are caught (for measuring its cost)
  // Total length of the fluid's initial free surface, m, for the guard's bound on
  // the surface energy sigma x length; 0: bound it by sigma x (particles x h).
  Real surface_length = 0;
  Real guard_density_ratio = 3.0;  // rho > ratio * rho0
  Real guard_speed_factor = 10.0;  // |v| > factor * sound speed
  Real guard_energy_factor = 2.0;  // kinetic energy > factor * what the scene can supply
  int max_retries = 0;  // on a trip: retry with dt / 2, dt / 4, ... this many times

  // wcsph: Tait EOS p = B ((rho/rho0)^7 - 1), B = rho0 c0^2 / 7, and Monaghan's
  // artificial viscosity with coefficient alpha.
  Real c0 = 0;       // speed of sound, m/s (> 0 for wcsph)
  Real alpha = 0.1;  // artificial viscosity
  // Background pressure p_b added to the Tait pressure (the sum is clamped at 0):
  // for flows with no free surface, where pressures below the reference are real.
  Real background_pressure = 0;  // Pa
  Real spacing = 0;  // lattice spacing, m: wcsph's walls mirror that lattice (0: a continuum)
  // wcsph with the density from the continuity equation (docs/method-wcsph.md,
  // W17-W26) instead of the summation: its diffusion coefficient delta (0:
  // none) and the coefficient of particle shifting (0: none), which with
  // shift_confined shifts only a flow with no free surface at its start
  // (W21). The pressure is then not clamped at 0.
  bool continuity = false;
  Real delta = 0.1;
  Real shifting = 0;
  bool shift_confined = false;
  // At a free surface (W26): false floors the density at rho0; true keeps the
  // carried density and floors the pressure at 0 instead (W26b).
  bool surface_pressure = false;
  // The artificial viscosity on the velocity difference left after each
  // side's limited linear reconstruction to the pair's midpoint, scaled by how
  // much of its velocity gradient is strain rather than rotation (W30).
  bool reconstruct_viscosity = false;
  // The pressure force on the quintic spline of support 2.8 dx where the flow
  // is not shifted (W31; needs h >= 2.8 dx), else on the Wendland kernel.
  bool quintic_pressure = false;

  // dfsph (docs/method-dfsph.md): the solves' tolerances, the mean density
  // error over rho0 of the constant-density solve and the mean density change
  // over a step over rho0 of the divergence-free solve (SPlisHSPlasH's 0.01 %
  // and 0.1 %), and each solve's least and most iterations. c0 then bounds
  // the guard's speeds only.
  Real density_tolerance = 1e-4;
  Real divergence_tolerance = 1e-3;
  int min_iterations = 2;
  int max_iterations = 1000;

  // Speed of sound of the method's state equation, and the length in the
  // time-step conditions (the method's registration says: methods/registry.cpp).
  Real sound_speed() const;
  Real step_length() const;

  // Mueller et al. (2003) use l = 7.065 /m with h = 0.0457 m, i.e. l h = 0.323.
  static constexpr Real kSurfaceThresholdTimesH = 0.323;

  Real effective_surface_threshold() const {
    return surface_threshold >= 0 ? surface_threshold : kSurfaceThresholdTimesH / h;
  }
};

}  // namespace sphfluid
