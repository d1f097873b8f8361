// Bindings of SimParams and Solver: construction from numpy arrays, stepping
// with the GIL released, read-only views of the particle fields.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bind/arrays.hpp"
#include "solver.hpp"

namespace py = pybind11;
using namespace sphfluid;
using bind::InArray;

namespace {

Vec2 pair_to_vec(const std::array<double, 2>& a) { return Vec2(a[0], a[1]); }
std::array<double, 2> vec_to_pair(const Vec2& v) { return {v.x(), v.y()}; }

std::vector<Id> to_ids(const py::object& ids) {
  if (ids.is_none()) return {};
  auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(ids);
  if (!a || a.ndim() != 1) throw std::invalid_argument("ids: expected a 1-D integer array");
  return std::vector<Id>(a.data(), a.data() + a.size());
}

}  // namespace

void bind_solver(py::module_& m) {
  py::register_exception<InstabilityError>(m, "InstabilityError", PyExc_RuntimeError);

  py::enum_<Method>(m, "Method", "The SPH method of a run")
      .value("seed", Method::kSeed)
      .value("wcsph", Method::kWcsph);

  py::class_<SimParams>(m, "SimParams", "Physical and numerical constants of a run (SI units).")
      .def(py::init<>())
      .def_readwrite("method", &SimParams::method, "seed (SPEC.md) or wcsph")
      .def_readwrite("c0", &SimParams::c0, "wcsph: speed of sound, m/s")
      .def_readwrite("alpha", &SimParams::alpha, "wcsph: artificial viscosity coefficient")
      .def_readwrite("background_pressure", &SimParams::background_pressure,
                     "wcsph: pressure added to the Tait EOS (sum clamped at 0), Pa")
      .def_readwrite("spacing", &SimParams::spacing,
                     "wcsph: lattice spacing the walls mirror, m (0: a continuum)")
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

  py::class_<Solver>(m, "Solver", "The seed SPH method on a set of particles and walls.")
      .def(py::init([](const SimParams& p, const InArray& x, const InArray& v, const InArray& walls,
                       const py::object& ids) {
             return new Solver(p, bind::to_vec2(x, "positions"), bind::to_vec2(v, "velocities"),
                               to_ids(ids), bind::to_segments(walls));
           }),
           py::arg("params"), py::arg("positions"), py::arg("velocities"), py::arg("walls"),
           py::arg("ids") = py::none(),
           "Solver(params, positions (n, 2), velocities (n, 2), walls (s, 2, 2), ids=None).\n"
           "Particles outside the domain are removed (and counted) at once.")
      .def("step", &Solver::step, py::arg("dt"), py::arg("n") = 1,
           py::call_guard<py::gil_scoped_release>(),
           "Advance n steps of size dt (GIL released). Raises InstabilityError on blow-up.")
      .def("step_adaptive", &Solver::step_adaptive, py::arg("n") = 1,
           py::call_guard<py::gil_scoped_release>(),
           "Advance n steps, each with the largest stable dt (GIL released).")
      .def("advance_adaptive", &Solver::advance_adaptive, py::arg("t_end"),
           py::arg("max_steps"), py::call_guard<py::gil_scoped_release>(),
           "Adaptive steps until time reaches t_end (landing on it) or max_steps; "
           "returns the number of steps taken.")
      .def_property_readonly("last_dt", &Solver::last_dt, "time step of the last step, s")
      .def_property_readonly("energy_budget", &Solver::energy_budget,
                             "energy the scene can supply, J per m of depth (guard)")
      .def_property_readonly("energy_removed", &Solver::energy_removed,
                             "kinetic energy carried out of the domain by removed particles, "
                             "J per m of depth (counted by the guard)")
      .def_property_readonly("surface_energy", &Solver::surface_energy,
                             "wcsph with surface tension: the surface energy sigma x length "
                             "at the last evaluation, J per m of depth (the tension is minus "
                             "its gradient); 0 otherwise")
      .def_property_readonly("retried_steps", &Solver::retried_steps,
                             "steps retried with a halved time step")
      .def_property_readonly("retry_log", &Solver::retry_log,
                             "messages of the most recent retries, oldest first")
      .def_property_readonly(
          "last_dt_limit", [](const Solver& s) { return std::string(limit_name(s.last_limit())); },
          "what limited the last step: fixed, cfl, force, viscous or dt_max (a step shortened "
          "to land on an end time keeps that label)")
      .def("compute_forces", &Solver::compute_forces, py::call_guard<py::gil_scoped_release>(),
           "Density, pressure and acceleration for the current state; nothing moves.")
      .def(
          "set_state",
          [](Solver& s, const InArray& x, const InArray& v, const py::object& ids) {
            auto xs = bind::to_vec2(x, "positions");
            auto vs = bind::to_vec2(v, "velocities");
            auto is = to_ids(ids);
            py::gil_scoped_release release;
            s.set_state(std::move(xs), std::move(vs), std::move(is));
          },
          py::arg("positions"), py::arg("velocities"), py::arg("ids") = py::none(),
          "Replace all particles (n may change); ids default to 0..n-1.")
      .def(
          "add_particles",
          [](Solver& s, const InArray& x, const InArray& v) {
            auto xs = bind::to_vec2(x, "positions");
            auto vs = bind::to_vec2(v, "velocities");
            py::gil_scoped_release release;
            s.add_particles(xs, vs);
          },
          py::arg("positions"), py::arg("velocities"),
          "Append particles (n, 2) with fresh ids; those outside the domain are removed.")
      .def(
          "set_walls", [](Solver& s, const InArray& walls) { s.set_walls(bind::to_segments(walls)); },
          py::arg("walls"), "Replace the wall segments (s, 2, 2); takes effect at once.")
      .def_property("threads", &Solver::threads, &Solver::set_threads,
                    "OpenMP threads the step may use (0: OpenMP default)")
      .def_property_readonly("float_pairs", &Solver::float_pairs,
                             "whether the pair forces run in single precision: asked for "
                             "(SimParams.float_pairs), seed, and the step runs them by cell "
                             "clusters (no surface tension, no periodic axis, an AVX-512 build)")
      .def_property_readonly("recip_root", &Solver::recip_root,
                             "whether the seed's double pair forces by cell clusters take 1/r "
                             "from rsqrt14 and two Newton steps instead of a square root and a "
                             "division (chosen by CPU: Intel's 512-bit root and division are slow)")
      .def_property_readonly("threads_in_use", &Solver::team,
                             "threads the step's loops use now: `threads`, or 1 below 1,000 "
                             "particles, where a second thread costs more than it gains")
      .def(
          "phase_seconds",
          [](const Solver& s) {
            py::dict d;
            for (int p = 0; p < kNumPhases; ++p) d[phase_name(p)] = s.phase_seconds()[p];
            return d;
          },
          "Wall-clock seconds spent in each phase of the step since the last reset")
      .def("reset_phase_seconds", &Solver::reset_phase_seconds)
      .def_property_readonly("params", &Solver::params)
      .def_property_readonly("n_particles", &Solver::size)
      .def_property_readonly("time", &Solver::time, "simulated time, s")
      .def_property_readonly("step_count", &Solver::step_count)
      .def_property_readonly("removed_particles", &Solver::removed,
                             "particles removed for leaving the domain")
      .def_property_readonly("features", &Solver::features,
                             "bit set of active optional terms: 1 viscosity, 2 surface "
                             "tension, 4 walls")
      .def_property_readonly(
          "memory_bytes",
          [](const Solver& s) {
            py::dict d;
            for (const auto& [name, bytes] : s.memory_bytes()) d[py::str(name)] = bytes;
            return d;
          },
          "heap bytes held by the solver's arrays, by part (capacity included)")
      .def_property_readonly(
          "sort_counts",
          [](const Solver& s) {
            py::dict d;
            d["unchanged"] = s.sort_counts()[0];
            d["moved"] = s.sort_counts()[1];
            d["permuted"] = s.sort_counts()[2];
            d["moved_in_parts"] = s.sort_counts()[3];
            return d;
          },
          "sorts by cell so far, by what they did: no particle changed cell (unchanged), "
          "the few that did were moved into place (moved; moved_in_parts of them by the "
          "threads, each its own range), or all were permuted")
      .def_property_readonly("neighbour_pairs", &Solver::neighbour_pairs,
                             "stored neighbour pairs (i, j != i) of the last evaluation")
      .def_property_readonly(
          "positions", [](const Solver& s) { return bind::view<Vec2, 2>(s.particles().x); },
          "(n, 2) read-only view, m")
      .def_property_readonly(
          "velocities", [](const Solver& s) { return bind::view<Vec2, 2>(s.particles().v); },
          "(n, 2) read-only view, m/s")
      .def_property_readonly(
          "accelerations", [](const Solver& s) { return bind::view<Vec2, 2>(s.particles().a); },
          "(n, 2) read-only view of the last force evaluation, m/s^2")
      .def_property_readonly(
          "densities", [](const Solver& s) { return bind::view<Real, 1>(s.particles().rho); },
          "(n,) read-only view of the last evaluation, kg/m^3")
      .def_property_readonly(
          "pressures", [](const Solver& s) { return bind::view<Real, 1>(s.particles().p); },
          "(n,) read-only view of the last evaluation, Pa")
      .def_property_readonly(
          "ids", [](const Solver& s) { return bind::view<Id, 1>(s.particles().id); },
          "(n,) read-only view of the stable particle ids")
      .def_property_readonly(
          "walls",
          [](const Solver& s) {
            const auto& segs = s.walls().segments();
            py::array_t<double> out({py::ssize_t(segs.size()), py::ssize_t(2), py::ssize_t(2)});
            auto w = out.mutable_unchecked<3>();
            for (std::size_t i = 0; i < segs.size(); ++i) {
              w(i, 0, 0) = segs[i].a.x();
              w(i, 0, 1) = segs[i].a.y();
              w(i, 1, 0) = segs[i].b.x();
              w(i, 1, 1) = segs[i].b.y();
            }
            return out;
          },
          "(s, 2, 2) copy of the wall segments, m");
}
