// Bindings of the Solver: construction from numpy arrays, stepping with the
// GIL released, editing, diagnostics, and read-only views of the particle
// fields. Each group of methods is a function; bind_solver() calls them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstring>
#include <string>
#include <vector>

#include "bind/arrays.hpp"
#include "solver.hpp"

namespace py = pybind11;
using namespace sphfluid;
using bind::InArray;

namespace {

using SolverClass = py::class_<Solver>;

std::vector<Id> to_ids(const py::object& ids) {
  if (ids.is_none()) return {};
  auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(ids);
  if (!a || a.ndim() != 1) throw std::invalid_argument("ids: expected a 1-D integer array");
  return std::vector<Id>(a.data(), a.data() + a.size());
}

Vec2 to_point(const py::handle& p) {
  const auto xy = p.cast<std::array<Real, 2>>();
  return Vec2(xy[0], xy[1]);
}

Emitter to_emitter(const py::dict& d) {
  Emitter e;
  e.at = to_point(d["at"]);
  e.direction = to_point(d["direction"]);
  e.width = d["width"].cast<Real>();
  e.speed.t = d["times"].cast<std::vector<Real>>();
  e.speed.value = d["speeds"].cast<std::vector<Real>>();
  e.start = d["start"].cast<Real>();
  e.stop = d["stop"].cast<Real>();
  if (d.contains("buffer")) e.buffer = d["buffer"].cast<Real>();
  return e;
}

Outlet to_outlet(const py::dict& d) {
  Outlet o;
  o.at = to_point(d["at"]);
  o.direction = to_point(d["direction"]);
  o.width = d["width"].cast<Real>();
  o.depth = d["depth"].cast<Real>();
  if (d.contains("level")) o.level = d["level"].cast<Real>();
  return o;
}

Sink to_sink(const py::dict& d) {
  Sink s;
  if (d.contains("radius")) {
    s.centre = to_point(d["centre"]);
    s.radius = d["radius"].cast<Real>();
    if (!(s.radius > 0)) throw std::invalid_argument("a circular sink's radius must be > 0");
  } else {
    for (const py::handle& p : d["polygon"].cast<py::list>()) s.polygon.push_back(to_point(p));
  }
  return s;
}

TimeTable to_table(const py::handle& pairs) {
  TimeTable tab;
  for (const py::handle& p : pairs.cast<py::list>()) {
    const auto tv = p.cast<std::array<Real, 2>>();
    tab.t.push_back(tv[0]);
    tab.value.push_back(tv[1]);
  }
  return tab;
}

WallMotion to_motion(const py::dict& d) {
  WallMotion m;
  m.x = to_table(d["x"]);
  m.y = to_table(d["y"]);
  m.angle = to_table(d["angle"]);
  m.about = to_point(d["about"]);
  return m;
}

// Making a solver.
void def_construction(SolverClass& c) {
  c.def(py::init([](const SimParams& p, const InArray& x, const InArray& v, const InArray& walls,
                       const py::object& ids) {
             return new Solver(p, bind::to_vec2(x, "positions"), bind::to_vec2(v, "velocities"),
                               to_ids(ids), bind::to_segments(walls));
           }),
           py::arg("params"), py::arg("positions"), py::arg("velocities"), py::arg("walls"),
           py::arg("ids") = py::none(),
           "Solver(params, positions (n, 2), velocities (n, 2), walls (s, 2, 2), ids=None).\n"
           "Particles outside the domain are removed (and counted) at once.");
}

// Advancing, and what the steps did.
void def_stepping(SolverClass& c) {
  c.def("step", &Solver::step, py::arg("dt"), py::arg("n") = 1,
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
      .def_property_readonly(
          "solve_stats",
          [](const Solver& s) {
            const SolveStats st = s.solve_stats();
            py::dict d;
            d["density_iterations"] = st.density_iterations;
            d["divergence_iterations"] = st.divergence_iterations;
            d["density_error"] = st.density_error;
            d["divergence_error"] = st.divergence_error;
            d["unconverged"] = st.unconverged;
            d["iterations"] = st.iterations;
            return d;
          },
          "dfsph: the last step's iterations and mean errors of both pressure solves "
          "(over rho0), and over the run the solves stopped at the most iterations and "
          "the iterations taken; zeros for the other methods")
      .def_property_readonly("retried_steps", &Solver::retried_steps,
                             "steps retried with a halved time step")
      .def_property_readonly("retry_log", &Solver::retry_log,
                             "messages of the most recent retries, oldest first")
      .def_property_readonly(
          "last_dt_limit", [](const Solver& s) { return std::string(limit_name(s.last_limit())); },
          "what limited the last step: fixed, cfl, force, viscous or dt_max (a step shortened "
          "to land on an end time keeps that label)");
}

// Evaluating and editing the state.
void def_editing(SolverClass& c) {
  c.def("compute_forces", &Solver::compute_forces, py::call_guard<py::gil_scoped_release>(),
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
      .def("settle_fluid", &Solver::settle_fluid, py::call_guard<py::gil_scoped_release>(),
           "The particles are the scene's fluid as its regions filled the lattice: "
           "wcsph's continuity density compresses them along gravity to its "
           "hydrostatic start (docs/method-wcsph.md, W23b); other methods leave them.")
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
      .def(
          "set_wall_velocities",
          [](Solver& s, const InArray& v) { s.set_wall_velocities(bind::to_vec2(v, "velocities")); },
          py::arg("velocities"),
          "The walls' surface velocities (s, 2), along each wall (a sliding lid); zero by "
          "default and after set_walls.")
      .def(
          "set_wall_motions",
          [](Solver& s, const py::list& motions, const std::vector<Index>& motion_of) {
            std::vector<WallMotion> ms;
            for (const py::handle& item : motions) ms.push_back(to_motion(item.cast<py::dict>()));
            s.set_wall_motions(std::move(ms), motion_of);
          },
          py::arg("motions"), py::arg("motion_of"),
          "Moving walls: each motion a dict of tables 'x', 'y' (the drawn position's "
          "translation, m) and 'angle' (radians, counterclockwise about 'about' [x, y], "
          "which moves with it), each [[t, value], ...]; motion_of[k] is segment k's "
          "motion or -1. The walls as they are now are the drawn ones.")
      .def(
          "set_damping",
          [](Solver& s, const py::list& zones) {
            std::vector<DampingZone> zs;
            for (const py::handle& item : zones) {
              const py::dict d = item.cast<py::dict>();
              DampingZone z;
              z.from = to_point(d["from"]);
              z.to = to_point(d["to"]);
              z.strength = d["strength"].cast<Real>();
              zs.push_back(z);
            }
            s.set_damping(std::move(zs));
          },
          py::arg("zones"),
          "Replace the damping zones, each a dict with 'from' and 'to' [x, y] (m) and "
          "'strength' (1/s): every step a particle past the line through 'from' (across "
          "from -> to) keeps 1 - dt s^2 strength of its velocity (at least 0), s its "
          "distance past the line over |to - from|, 1 beyond 'to'.")
      .def(
          "set_flows",
          [](Solver& s, const py::list& emitters, const py::list& sinks, Real spacing,
             const py::list& outlets) {
            std::vector<Emitter> es;
            std::vector<Sink> ks;
            std::vector<Outlet> os;
            for (const py::handle& item : emitters) es.push_back(to_emitter(item.cast<py::dict>()));
            for (const py::handle& item : sinks) ks.push_back(to_sink(item.cast<py::dict>()));
            for (const py::handle& item : outlets) os.push_back(to_outlet(item.cast<py::dict>()));
            s.set_flows(std::move(es), std::move(ks), std::move(os), spacing);
          },
          py::arg("emitters"), py::arg("sinks"), py::arg("spacing"),
          py::arg("outlets") = py::list(),
          "Replace the emitters (and inlets), sinks and outlets; they act from the next "
          "step, the emitters' rows on the lattice of `spacing` (m); the inlets' buffers are "
          "placed now. An emitter is a dict with 'at' [x, y], 'direction' [dx, dy], 'width' "
          "(m), 'times' and 'speeds' (a table, linear between its times), 'start' and 'stop' "
          "(s), and for an inlet 'buffer' (its depth behind 'at', m); a sink one with "
          "'polygon' [[x, y], ...] or 'centre' [x, y] and 'radius'; an outlet one with 'at', "
          "'direction' (out of the fluid), 'width' and 'depth' (m).");
}

// A checkpoint as a dict: "fields" (name -> an array of the field's numbers,
// (n,) or (n, components)), the clock and counts, the guard's budget, and
// "method" (the method's own numbers).
py::dict snapshot_to_dict(const Snapshot& s) {
  py::dict fields;
  for (const Snapshot::FieldData& f : s.fields) {
    const std::string format = std::string(f.integral ? "i" : "f") + std::to_string(f.scalar_bytes);
    const py::ssize_t n = static_cast<py::ssize_t>(f.bytes.size() / (f.components * f.scalar_bytes));
    std::vector<py::ssize_t> shape{n};
    if (f.components > 1) shape.push_back(f.components);
    py::array a(py::dtype(format), shape);
    if (!f.bytes.empty()) std::memcpy(a.mutable_data(), f.bytes.data(), f.bytes.size());
    fields[py::str(f.name)] = a;
  }
  py::dict d;
  d["fields"] = fields;
  d["time"] = s.time;
  d["step_count"] = s.step_count;
  d["last_dt"] = s.last_dt;
  d["last_dt_limit"] = static_cast<int>(s.last_limit);
  d["removed_particles"] = s.removed;
  d["wall_crossings"] = s.wall_crossings;
  d["retried_steps"] = s.retried_steps;
  d["energy_budget"] = s.energy_budget;
  d["energy_removed"] = s.energy_removed;
  d["particles_placed"] = s.balance.placed;
  d["particles_in"] = s.balance.entered;
  d["particles_out"] = s.balance.out;
  d["particles_sunk"] = s.balance.sunk;
  d["emitter_travel"] = s.emitter_travel;
  d["method"] = s.method;
  return d;
}

Snapshot snapshot_from_dict(const py::dict& d) {
  Snapshot s;
  for (const auto& [key, value] : d["fields"].cast<py::dict>()) {
    const py::array a = py::array::ensure(value, py::array::c_style);
    if (!a || a.ndim() < 1 || a.ndim() > 2)
      throw std::invalid_argument("checkpoint: field '" + key.cast<std::string>() +
                                  "' is not a 1-D or 2-D array");
    Snapshot::FieldData f;
    f.name = key.cast<std::string>();
    f.components = a.ndim() == 2 ? static_cast<int>(a.shape(1)) : 1;
    f.scalar_bytes = static_cast<std::size_t>(a.itemsize());
    const char kind = a.dtype().kind();
    if (kind != 'i' && kind != 'f')
      throw std::invalid_argument("checkpoint: field '" + f.name + "' is not numbers");
    f.integral = kind == 'i';
    const auto* first = static_cast<const unsigned char*>(a.data());
    f.bytes.assign(first, first + a.nbytes());
    s.fields.push_back(std::move(f));
  }
  s.time = d["time"].cast<Real>();
  s.step_count = d["step_count"].cast<std::int64_t>();
  s.last_dt = d["last_dt"].cast<Real>();
  const int limit = d["last_dt_limit"].cast<int>();
  if (limit < 0 || limit > static_cast<int>(TimeStepLimit::kMax))
    throw std::invalid_argument("checkpoint: last_dt_limit out of range");
  s.last_limit = static_cast<TimeStepLimit>(limit);
  s.removed = d["removed_particles"].cast<std::int64_t>();
  s.wall_crossings = d.contains("wall_crossings") ? d["wall_crossings"].cast<std::int64_t>() : 0;
  s.retried_steps = d["retried_steps"].cast<std::int64_t>();
  s.energy_budget = d["energy_budget"].cast<Real>();
  s.energy_removed = d["energy_removed"].cast<Real>();
  s.balance.placed = d["particles_placed"].cast<std::int64_t>();
  s.balance.entered = d["particles_in"].cast<std::int64_t>();
  s.balance.out = d.contains("particles_out") ? d["particles_out"].cast<std::int64_t>() : 0;
  s.balance.sunk = d["particles_sunk"].cast<std::int64_t>();
  s.emitter_travel = d["emitter_travel"].cast<std::vector<Real>>();
  s.method = d["method"].cast<std::vector<Real>>();
  return s;
}

void def_checkpoint(SolverClass& c) {
  c.def(
       "snapshot", [](const Solver& s) { return snapshot_to_dict(s.snapshot()); },
       "Everything the next step depends on, as a dict: 'fields' (each particle field's "
       "numbers in storage order), the clock and counts, the guard's budget, 'method' "
       "(the method's own numbers). restore() continues from it bit for bit.")
      .def(
          "restore", [](Solver& s, const py::dict& d) { s.restore(snapshot_from_dict(d)); },
          py::arg("snapshot"),
          "Continue from a snapshot() of a solver with the same parameters (ValueError when "
          "its fields are not this run's).");
}

// Threads and the code paths that run.
void def_threads(SolverClass& c) {
  c.def_property("threads", &Solver::threads, &Solver::set_threads,
                    "OpenMP threads the step may use (0: OpenMP default)")
      .def_property_readonly("float_pairs", &Solver::float_pairs,
                             "whether the pair forces run in single precision: asked for "
                             "(SimParams.float_pairs), seed, and the step runs them by cell "
                             "clusters (no surface tension, no periodic axis, an AVX-512 build)")
      .def_property_readonly("quintic_pressure", &Solver::quintic_pressure,
                             "wcsph's continuity density: whether the last evaluation's pressure "
                             "force ran on W31's quintic spline (asked for, and the flow not "
                             "shifted)")
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
      .def("reset_phase_seconds", &Solver::reset_phase_seconds);
}

// The run's counts and measurements.
void def_diagnostics(SolverClass& c) {
  c.def_property_readonly(
       "params", [](const Solver& s) { return s.params(); },
       "a copy of the run's parameters (changing it changes nothing in the run)")
      .def_property_readonly("n_particles", &Solver::size)
      .def_property_readonly("time", &Solver::time, "simulated time, s")
      .def_property_readonly("step_count", &Solver::step_count)
      .def_property_readonly("removed_particles", &Solver::removed,
                             "particles removed for leaving the domain")
      .def_property_readonly(
          "balance",
          [](const Solver& s) {
            py::dict d;
            d["placed"] = s.balance().placed;
            d["in"] = s.balance().entered;
            d["out"] = s.balance().out;
            d["sunk"] = s.balance().sunk;
            d["lost"] = s.removed();
            return d;
          },
          "the particle count's balance: 'placed' (set and added through the API, less "
          "those replaced) + 'in' (emitters, inlets) - 'out' (outlets) - 'sunk' - 'lost' (left "
          "the domain) = n_particles")
      .def_property_readonly("wall_crossings", &Solver::wall_crossings,
                             "wall crossings the wall collisions stopped (each bounce, and "
                             "each stop in front of a wall), over the run")
      .def_property_readonly("features", &Solver::features,
                             "bit set of active optional terms: 1 viscosity, 2 surface "
                             "tension, 4 walls, 8 periodic axes")
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
                             "stored neighbour pairs (i, j != i) of the last evaluation");
}

// Read-only views of the particle fields, and the walls.
void def_arrays(SolverClass& c) {
  c.def_property_readonly(
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

}  // namespace

void bind_solver(py::module_& m) {
  py::register_exception<InstabilityError>(m, "InstabilityError", PyExc_RuntimeError);
  SolverClass c(m, "Solver", "A run of the SPH method of `params` on a set of particles and walls.");
  def_construction(c);
  def_stepping(c);
  def_editing(c);
  def_checkpoint(c);
  def_threads(c);
  def_diagnostics(c);
  def_arrays(c);
}
