// Where fluid enters and leaves a run besides its start and the domain's
// edge: emitters, nozzles that emit a jet on the lattice of the scene's
// spacing, and sinks, regions that remove whatever enters them. The Context
// applies both once a step, after the drift (Context::exchange), so every
// method has them and pays nothing without them.
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
  void set(std::vector<Emitter> emitters, std::vector<Sink> sinks, Real spacing);
  bool any() const { return !emitters_.empty() || !sinks_.empty(); }
  bool has_sinks() const { return !sinks_.empty(); }
  const std::vector<Emitter>& emitters() const { return emitters_; }
  const std::vector<Sink>& sinks() const { return sinks_; }
  // Whether p is in any sink.
  bool sunk(const Vec2& p) const;
  // The rows the emitters give over the step (t, t + dt], appended to x and v:
  // each row where it has travelled since it left the nozzle, at the
  // emitter's speed at t + dt.
  void emit(Real t, Real dt, std::vector<Vec2>& x, std::vector<Vec2>& v);
  // How far each emitter's last row has travelled from the nozzle, m (what a
  // checkpoint carries; a full spacing before the first row).
  const std::vector<Real>& travelled() const { return travelled_; }
  void set_travelled(const std::vector<Real>& travelled);

 private:
  std::vector<Emitter> emitters_;
  std::vector<Sink> sinks_;
  std::vector<Real> travelled_;
  Vec2 lo_ = Vec2::Zero(), hi_ = Vec2::Zero();  // the sinks' bounding box
  Real dx_ = 0;
};

}  // namespace sphfluid
