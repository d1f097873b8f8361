// Where fluid enters and leaves a run besides its start and the domain's
// edge: emitters, nozzles that emit a jet on the lattice of the scene's
// spacing; inlets, emitters whose rows start in a buffer behind the inlet's
// line and are held there on the lattice at the inflow velocity, so that the
// fluid beyond the line has its full kernel support; outlets, lines beyond
// which particles move straight out at their lane's mean speed before the
// line (at rest where that fluid is at rest or flows back), at the reference
// pressure (under gravity with the hydrostatic head), through a buffer as
// deep as an inlet's until they leave its far side; and sinks, regions that
// remove whatever enters them. The Context applies them once a step, after
// the drift (Context::exchange), so every method has them and pays nothing
// without them.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "core/time_table.hpp"
#include "core/types.hpp"

namespace sphfluid {

// A nozzle centred at `at`, `width` across, emitting along `direction` (a
// unit vector) from `start` to `stop` at `speed`: rows of round(width / dx)
// particles (at least one), dx apart across the jet at (k + 1/2) dx from its
// edge, a new row whenever the last one has travelled dx from the nozzle.
struct Emitter {
  Vec2 at = Vec2::Zero();
  Vec2 direction = Vec2(0, -1);
  Real width = 0;
  TimeTable speed;
  Real start = 0;
  Real stop = std::numeric_limits<Real>::infinity();
  // > 0: an inlet whose rows start this far (m) behind `at` and are held on
  // the lattice, moving at the speed along `direction`, until they cross
  // the line through `at`; the buffer starts full.
  Real buffer = 0;
};

// A line centred at `at`, `width` across, that particles cross along
// `direction` (a unit vector, out of the fluid) into a buffer `depth` deep:
// there they move along `direction` at the speed the fluid has just before
// the line in their lane (a zero gradient; at rest where that fluid is at rest
// or flows back), and leave the run past the buffer's far side.
struct Outlet {
  Vec2 at = Vec2::Zero();
  Vec2 direction = Vec2(1, 0);
  Real width = 0;
  Real depth = 0;
  // Under gravity, the height (along -g, m) of the free surface its held
  // particles' hydrostatic pressure is measured from; NaN: the fluid's before
  // the line (Context::outlet_lanes).
  Real level = std::numeric_limits<Real>::quiet_NaN();
};

// A region that removes the particles inside it: a polygon (a rectangle is
// one; vertices in order) or a circle (radius > 0, about `centre`).
struct Sink {
  std::vector<Vec2> polygon;
  Vec2 centre = Vec2::Zero();
  Real radius = 0;
  bool contains(const Vec2& p) const;
  // The bounding box, set by Flows.
  Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();
};

class Flows {
 public:
  // The most rows an emitter may lay in one step (std::length_error beyond).
  static constexpr int kMaxRows = 1000;
  // Throws std::invalid_argument for an emitter or sink that cannot work (a
  // zero direction, a table out of order, a polygon of fewer than 3 points).
  void set(std::vector<Emitter> emitters, std::vector<Sink> sinks, std::vector<Outlet> outlets,
           Real spacing);
  bool any() const { return !emitters_.empty() || !sinks_.empty() || !outlets_.empty(); }
  bool has_sinks() const { return !sinks_.empty(); }
  bool has_inlets() const { return inlets_ > 0; }
  bool has_outlets() const { return !outlets_.empty(); }
  const std::vector<Emitter>& emitters() const { return emitters_; }
  const std::vector<Sink>& sinks() const { return sinks_; }
  const std::vector<Outlet>& outlets() const { return outlets_; }
  // The fastest any inlet's table runs, m/s (0 without inlets).
  Real top_inflow_speed() const;
  // Whether p is in any sink.
  bool sunk(const Vec2& p) const;
  // The full buffers of the inlets not yet filled (new since the last set()
  // or restore: one set() again unchanged keeps its buffer and travel) at
  // time t, appended to x and v (their rows a spacing apart, the front one
  // half a spacing behind the line); each inlet's travel set to match.
  void fill_inlets(Real t, std::vector<Vec2>& x, std::vector<Vec2>& v);
  // The buffers of the outlets not yet filled (likewise): fluid at rest on
  // the lattice (rows a spacing apart from half a spacing past the line: the
  // fluid runs on past it at the start) in the lanes that have fluid within
  // `reach` before the line (among the n positions `fluid`; the reach the
  // lanes' speeds are averaged over: a free surface crossing the outlet is
  // not filled above); appended to x.
  void fill_outlets(std::vector<Vec2>& x, const Vec2* fluid, Index n, Real reach);
  // After the particles were replaced (Solver::set_state): an inlet's or
  // outlet's buffer that holds none of the n positions x is to be filled
  // again (fill_inlets, fill_outlets); one that holds some keeps them.
  void unfill_empty_buffers(const Vec2* x, Index n);
  // A particle in an inlet's buffer (after this step's rows, at time t):
  // its position snapped to the buffer's lattice and its velocity the
  // inflow's; false (nothing changed) elsewhere.
  bool hold_in_inlet(Real t, Vec2& x, Vec2& v) const;
  // Whether x is in an inlet's buffer (where hold_in_inlet holds it).
  bool in_inlet(const Vec2& x) const { return inlet_holding(x) >= 0; }
  // Where p is about the outlets: kUpstream within `reach` before a line,
  // kHeld in its buffer, kPast beyond the buffer's far side (to leave), with
  // the outlet's lane (lanes a spacing wide across it, numbered over all
  // outlets; lanes() in all); kNone elsewhere.
  enum Zone : std::int8_t { kNone, kUpstream, kHeld, kPast };
  struct Place {
    Zone zone = kNone;
    int lane = -1;
  };
  Place outlet_place(const Vec2& p, Real reach) const;
  int lanes() const { return lanes_; }
  // The outlet that lane l crosses.
  const Outlet& outlet_of_lane(int l) const { return outlets_[outlet_of_lane_[l]]; }
  int outlet_index_of_lane(int l) const { return outlet_of_lane_[l]; }
  // The lattice spacing of the buffers' rows, m.
  Real spacing() const { return dx_; }
  // The rows the emitters give over the step (t, t + dt], appended to x and v:
  // each row where it has travelled since it left the nozzle, at the
  // emitter's speed at t + dt.
  void emit(Real t, Real dt, std::vector<Vec2>& x, std::vector<Vec2>& v);
  // How far each emitter's last row has travelled from the nozzle, m (what a
  // checkpoint carries; a full spacing before the first row).
  const std::vector<Real>& travelled() const { return travelled_; }
  void set_travelled(const std::vector<Real>& travelled);

 private:
  void keep_inlets(const std::vector<Emitter>& emitters, std::vector<Real>& travelled,
                   std::vector<char>& filled);
  void keep_outlets(const std::vector<Outlet>& outlets, std::vector<char>& filled);
  std::int64_t row_count(const Emitter& e) const;
  int inlet_holding(const Vec2& x) const;  // the inlet whose buffer holds x, or -1
  // The lane (numbered over all outlets) at `off` across outlet k's centre.
  int lane_at(std::size_t k, Real off) const;
  void row(const Emitter& e, Real along, const Vec2& u, std::vector<Vec2>& x,
           std::vector<Vec2>& v) const;
  Vec2 inflow(const Emitter& e, Real t) const;

  std::vector<Emitter> emitters_;
  std::vector<Sink> sinks_;
  std::vector<Outlet> outlets_;
  std::vector<Real> travelled_;
  std::vector<char> filled_;  // per emitter: an inlet whose buffer is in the run
  std::vector<char> outlet_filled_;  // per outlet: likewise
  std::vector<int> first_lane_;  // per outlet
  std::vector<int> outlet_of_lane_;  // per lane
  int lanes_ = 0;
  int inlets_ = 0;
  Vec2 lo_ = Vec2::Zero(), hi_ = Vec2::Zero();  // the sinks' bounding box
  Real dx_ = 0;
};

}  // namespace sphfluid
