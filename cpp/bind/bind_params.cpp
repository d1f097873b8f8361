// Bindings of the parameters of a run (SimParams) and the method's choice.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>

#include "core/params.hpp"
#include "methods/method.hpp"

namespace py = pybind11;
using namespace sphfluid;

namespace {

Vec2 pair_to_vec(const std::array<double, 2>& a) { return Vec2(a[0], a[1]); }
std::array<double, 2> vec_to_pair(const Vec2& v) { return {v.x(), v.y()}; }

}  // namespace

void bind_params(py::module_& m) {
  py::enum_<Method> method(m, "Method", "The SPH method of a run");
  for (const MethodEntry& e : method_entries()) method.value(e.name, e.id);

  py::class_<SimParams>(m, "SimParams", "Physical and numerical constants of a run (SI units).")
      .def(py::init<>())
      .def_readwrite("method", &SimParams::method, "seed (docs/method-seed.md), wcsph (docs/method-wcsph.md) or dfsph "
                     "(docs/method-dfsph.md)")
      .def_readwrite("c0", &SimParams::c0, "wcsph: speed of sound, m/s")
      .def_readwrite("alpha", &SimParams::alpha, "wcsph: artificial viscosity coefficient")
      .def_readwrite("background_pressure", &SimParams::background_pressure,
                     "wcsph: pressure added to the Tait EOS (sum clamped at 0), Pa")
      .def_readwrite("spacing", &SimParams::spacing,
                     "wcsph: lattice spacing the walls mirror, m (0: a continuum)")
      .def_readwrite("continuity", &SimParams::continuity,
                     "wcsph: density from the continuity equation (else the summation)")
      .def_readwrite("delta", &SimParams::delta,
                     "wcsph with continuity: density diffusion coefficient (0: none)")
      .def_readwrite("shifting", &SimParams::shifting,
                     "wcsph with continuity: particle shifting coefficient (0: none)")
      .def_readwrite("shift_confined", &SimParams::shift_confined,
                     "wcsph with continuity: shift only a flow with no free surface at "
                     "its start")
      .def_readwrite("surface_pressure", &SimParams::surface_pressure,
                     "wcsph with continuity: at a free surface floor the pressure at 0 "
                     "and keep the carried density (W26b), instead of flooring the density "
                     "at rho0 (W26)")
      .def_readwrite("reconstruct_viscosity", &SimParams::reconstruct_viscosity,
                     "wcsph with continuity: the artificial viscosity on the velocity "
                     "difference left after a limited linear reconstruction (W30)")
      .def_readwrite("quintic_pressure", &SimParams::quintic_pressure,
                     "wcsph with continuity: the pressure force on the quintic spline of "
                     "support 2.8 spacings where nothing shifts (W31)")
      .def_readwrite("density_tolerance", &SimParams::density_tolerance,
                     "dfsph: the constant-density solve's tolerance, mean density error / rho0")
      .def_readwrite("divergence_tolerance", &SimParams::divergence_tolerance,
                     "dfsph: the divergence-free solve's tolerance, mean density change over "
                     "a step / rho0")
      .def_readwrite("min_iterations", &SimParams::min_iterations,
                     "dfsph: each solve's least iterations")
      .def_readwrite("max_iterations", &SimParams::max_iterations,
                     "dfsph: each solve's most iterations (then the step goes on; counted)")
      .def_readwrite("h", &SimParams::h, "smoothing length (kernel support), m")
      .def_readwrite("mass", &SimParams::mass, "particle mass, kg per metre of depth")
      .def_readwrite("rho0", &SimParams::rho0, "rest density, kg/m^3")
      .def_readwrite("k", &SimParams::k, "gas constant of p = k (rho - rho0), m^2/s^2")
      .def_readwrite("eta", &SimParams::eta, "dynamic viscosity, Pa s")
      .def_readwrite("sigma", &SimParams::sigma, "surface tension coefficient, N")
      .def_property(
          "gravity", [](const SimParams& p) { return vec_to_pair(p.gravity); },
          [](SimParams& p, const std::array<double, 2>& g) { p.gravity = pair_to_vec(g); },
          "body acceleration [gx, gy], m/s^2")
      .def_property(
          "domain_min", [](const SimParams& p) { return vec_to_pair(p.domain_min); },
          [](SimParams& p, const std::array<double, 2>& g) { p.domain_min = pair_to_vec(g); },
          "lower corner of the domain, m")
      .def_property(
          "domain_max", [](const SimParams& p) { return vec_to_pair(p.domain_max); },
          [](SimParams& p, const std::array<double, 2>& g) { p.domain_max = pair_to_vec(g); },
          "upper corner of the domain, m")
      .def_property(
          "periodic",
          [](const SimParams& p) { return std::array<bool, 2>{p.periodic_x, p.periodic_y}; },
          [](SimParams& p, const std::array<bool, 2>& a) {
            p.periodic_x = a[0];
            p.periodic_y = a[1];
          },
          "periodic axes [x, y]: the domain wraps along them")
      .def_readwrite("surface_threshold", &SimParams::surface_threshold,
                     "|grad c| above which surface tension acts, 1/m (< 0: 0.323 / h)")
      .def_property_readonly("effective_surface_threshold",
                             &SimParams::effective_surface_threshold,
                             "the threshold in use, 1/m")
      .def_readwrite("ghost_mass_ratio", &SimParams::ghost_mass_ratio,
                     "wall ghost mass / particle mass")
      .def_readwrite("ghost_density_ratio", &SimParams::ghost_density_ratio,
                     "wall ghost density / rest density")
      .def_readwrite("restitution", &SimParams::restitution,
                     "normal restitution of the wall reflection, in [0, 1]")
      .def_readwrite("threads", &SimParams::threads, "OpenMP threads (0: OpenMP default)")
      .def_readwrite("float_pairs", &SimParams::float_pairs,
                     "the seed's pair forces in single precision where the cell clusters run")
      .def_readwrite("cfl", &SimParams::cfl, "CFL factor of the adaptive time step")
      .def_readwrite("dt_max", &SimParams::dt_max, "cap on the adaptive time step, s (0: none)")
      .def_readwrite("surface_length", &SimParams::surface_length,
                     "initial free-surface length, m, for the guard's surface-energy bound")
      .def_readwrite("guard", &SimParams::guard,
                     "check density, speed and energy after every step (non-finite values "
                     "are always caught)")
      .def_readwrite("guard_density_ratio", &SimParams::guard_density_ratio,
                     "guard: trip when rho > ratio * rho0")
      .def_readwrite("guard_speed_factor", &SimParams::guard_speed_factor,
                     "guard: trip when |v| > factor * speed of sound")
      .def_readwrite("guard_energy_factor", &SimParams::guard_energy_factor,
                     "guard: trip when kinetic energy > factor * energy budget")
      .def_readwrite("max_retries", &SimParams::max_retries,
                     "on a trip, retry the step with dt/2, dt/4, ... this many times")
      .def_property_readonly("sound_speed", &SimParams::sound_speed,
                             "speed of sound of the method's EOS, m/s");
}
