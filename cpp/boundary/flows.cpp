// Emitters and sinks (flows.hpp).
#include "boundary/flows.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <stdexcept>
#include <string>

namespace sphfluid {

namespace {

void check(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

}  // namespace

bool Sink::contains(const Vec2& p) const {
  if (!(p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y())) return false;
  if (radius > 0) return (p - centre).squaredNorm() <= radius * radius;
  bool inside = false;  // even-odd rule
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2 &a = polygon[i], &b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

namespace {

// The emitter's direction made a unit vector, and its numbers checked.
void prepare(Emitter& e, const std::string& name) {
  const Real len = e.direction.norm();
  check(e.at.allFinite() && std::isfinite(len) && len > 0,
        name + ": needs a finite position and a non-zero direction");
  e.direction /= len;
  check(std::isfinite(e.width) && e.width >= 0, name + ": width must be >= 0");
  const TimeTable& s = e.speed;
  check(!s.t.empty() && s.t.size() == s.value.size(),
        name + ": speed needs one value per time, at least one");
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    check(std::isfinite(s.t[i]) && std::isfinite(s.value[i]) && s.value[i] >= 0,
          name + ": speeds must be finite and >= 0");
    check(i == 0 || s.t[i] > s.t[i - 1], name + ": the speed table's times must increase");
  }
  check(std::isfinite(e.start) && !(e.stop < e.start), name + ": stop must not be before start");
}

// The sink's bounding box, and its numbers checked.
void prepare(Sink& s, const std::string& name) {
  if (s.radius > 0) {
    check(s.centre.allFinite() && std::isfinite(s.radius), name + ": needs a finite circle");
    s.lo = s.centre - Vec2::Constant(s.radius);
    s.hi = s.centre + Vec2::Constant(s.radius);
    return;
  }
  check(s.polygon.size() >= 3, name + ": a polygon needs at least 3 points");
  s.lo = s.hi = s.polygon.front();
  for (const Vec2& p : s.polygon) {
    check(p.allFinite(), name + ": points must be finite");
    s.lo = s.lo.cwiseMin(p);
    s.hi = s.hi.cwiseMax(p);
  }
}

}  // namespace

void Flows::set(std::vector<Emitter> emitters, std::vector<Sink> sinks, Real spacing) {
  check(std::isfinite(spacing) && spacing > 0, "flows: the spacing must be > 0");
  for (std::size_t k = 0; k < emitters.size(); ++k)
    prepare(emitters[k], "emitters[" + std::to_string(k) + "]");
  Vec2 lo = Vec2::Constant(std::numeric_limits<Real>::infinity()), hi = -lo;
  for (std::size_t k = 0; k < sinks.size(); ++k) {
    prepare(sinks[k], "sinks[" + std::to_string(k) + "]");
    lo = lo.cwiseMin(sinks[k].lo);
    hi = hi.cwiseMax(sinks[k].hi);
  }
  emitters_ = std::move(emitters);
  sinks_ = std::move(sinks);
  travelled_.assign(emitters_.size(), spacing);
  lo_ = lo;
  hi_ = hi;
  dx_ = spacing;
}

bool Flows::sunk(const Vec2& p) const {
  if (!(p.x() >= lo_.x() && p.x() <= hi_.x() && p.y() >= lo_.y() && p.y() <= hi_.y()))
    return false;
  for (const Sink& s : sinks_)
    if (s.contains(p)) return true;
  return false;
}

void Flows::emit(Real t, Real dt, std::vector<Vec2>& x, std::vector<Vec2>& v) {
  for (std::size_t k = 0; k < emitters_.size(); ++k) {
    const Emitter& e = emitters_[k];
    const Real from = std::max(t, e.start), to = std::min(t + dt, e.stop);
    if (!(to > from)) continue;
    Real& s = travelled_[k];
    s += e.speed.integral(from, to);
    if (s < dx_) continue;
    // A step this long for a jet this fast is an input error, not a flow.
    if (!(s <= kMaxRows * dx_))
      throw std::length_error("emitters[" + std::to_string(k) + "] would lay " +
                              std::to_string(s / dx_) + " rows in one step of " +
                              std::to_string(dt) + " s (more than " +
                              std::to_string(kMaxRows) +
                              "): lower the time step or the emitter's speed");
    const Vec2 across(-e.direction.y(), e.direction.x());
    const auto count = std::max<std::int64_t>(1, std::llround(e.width / dx_));
    const Vec2 u = e.speed.at(t + dt) * e.direction;
    for (; s >= dx_; s -= dx_) {
      const Real along = s - dx_;  // the new row is a spacing behind the last one
      for (std::int64_t j = 0; j < count; ++j) {
        const Real off = (Real(j) + Real(0.5) - Real(0.5) * Real(count)) * dx_;
        x.push_back(e.at + along * e.direction + off * across);
        v.push_back(u);
      }
    }
  }
}

void Flows::set_travelled(const std::vector<Real>& travelled) {
  check(travelled.size() == emitters_.size(),
        "checkpoint: it carries " + std::to_string(travelled.size()) +
            " emitters, this run has " + std::to_string(emitters_.size()));
  for (Real s : travelled) check(std::isfinite(s) && s >= 0, "checkpoint: an emitter's travel");
  travelled_ = travelled;
}

}  // namespace sphfluid
