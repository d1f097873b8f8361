// Emitters and sinks (flows.hpp).
#include "boundary/flows.hpp"

#include <algorithm>
#include <cmath>
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
  check(std::isfinite(e.buffer) && e.buffer >= 0, name + ": the buffer's depth must be >= 0");
}

void prepare(Outlet& o, const std::string& name) {
  const Real len = o.direction.norm();
  check(o.at.allFinite() && std::isfinite(len) && len > 0,
        name + ": needs a finite position and a non-zero direction");
  o.direction /= len;
  check(std::isfinite(o.width) && o.width > 0, name + ": width must be > 0");
  check(std::isfinite(o.depth) && o.depth > 0, name + ": the buffer's depth must be > 0");
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

// An inlet set again as it was keeps its travel (its buffer's rows are in the
// run); a new one is filled by fill_inlets.
void Flows::keep_inlets(const std::vector<Emitter>& emitters, std::vector<Real>& travelled,
                        std::vector<char>& filled) {
  for (std::size_t k = 0; k < emitters.size(); ++k) {
    const Emitter& e = emitters[k];
    if (!(e.buffer > 0)) continue;
    for (std::size_t j = 0; j < emitters_.size(); ++j) {
      const Emitter& old = emitters_[j];
      if (filled_[j] && old.buffer == e.buffer && old.at == e.at &&
          old.direction == e.direction && old.width == e.width) {
        travelled[k] = travelled_[j];
        filled[k] = 1;
        filled_[j] = 0;  // each old buffer serves one new inlet
        break;
      }
    }
  }
}

// Likewise an outlet set again as it was keeps its buffer.
void Flows::keep_outlets(const std::vector<Outlet>& outlets, std::vector<char>& filled) {
  for (std::size_t k = 0; k < outlets.size(); ++k)
    for (std::size_t j = 0; j < outlets_.size(); ++j) {
      const Outlet &o = outlets[k], &old = outlets_[j];
      if (outlet_filled_[j] && old.at == o.at && old.direction == o.direction &&
          old.width == o.width && old.depth == o.depth) {
        filled[k] = 1;
        outlet_filled_[j] = 0;  // each old buffer serves one new outlet
        break;
      }
    }
}

void Flows::set(std::vector<Emitter> emitters, std::vector<Sink> sinks,
                std::vector<Outlet> outlets, Real spacing) {
  check(std::isfinite(spacing) && spacing > 0, "flows: the spacing must be > 0");
  inlets_ = 0;
  for (std::size_t k = 0; k < emitters.size(); ++k) {
    prepare(emitters[k], "emitters[" + std::to_string(k) + "]");
    inlets_ += emitters[k].buffer > 0;
  }
  for (std::size_t k = 0; k < outlets.size(); ++k)
    prepare(outlets[k], "outlets[" + std::to_string(k) + "]");
  Vec2 lo = Vec2::Constant(std::numeric_limits<Real>::infinity()), hi = -lo;
  for (std::size_t k = 0; k < sinks.size(); ++k) {
    prepare(sinks[k], "sinks[" + std::to_string(k) + "]");
    lo = lo.cwiseMin(sinks[k].lo);
    hi = hi.cwiseMax(sinks[k].hi);
  }
  std::vector<Real> travelled(emitters.size(), spacing);
  std::vector<char> filled(emitters.size(), 0);
  if (spacing == dx_) keep_inlets(emitters, travelled, filled);
  std::vector<char> outlet_filled(outlets.size(), 0);
  if (spacing == dx_) keep_outlets(outlets, outlet_filled);
  emitters_ = std::move(emitters);
  sinks_ = std::move(sinks);
  outlets_ = std::move(outlets);
  first_lane_.assign(1, 0);
  outlet_of_lane_.clear();
  for (std::size_t k = 0; k < outlets_.size(); ++k) {
    const auto lanes = std::max<std::int64_t>(1, std::llround(outlets_[k].width / spacing));
    first_lane_.push_back(first_lane_.back() + static_cast<int>(lanes));
    outlet_of_lane_.resize(first_lane_.back(), static_cast<int>(k));
  }
  lanes_ = first_lane_.back();
  travelled_ = std::move(travelled);
  filled_ = std::move(filled);
  outlet_filled_ = std::move(outlet_filled);
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
    const Vec2 u = e.speed.at(t + dt) * e.direction;
    for (; s >= dx_; s -= dx_) row(e, s - dx_, u, x, v);  // a spacing behind the last row
  }
}

std::int64_t Flows::row_count(const Emitter& e) const {
  return std::max<std::int64_t>(1, std::llround(e.width / dx_));
}

// A row `along` (m) ahead of where the emitter's rows start: its nozzle, or
// an inlet's buffer's back.
void Flows::row(const Emitter& e, Real along, const Vec2& u, std::vector<Vec2>& x,
                std::vector<Vec2>& v) const {
  const Vec2 across(-e.direction.y(), e.direction.x());
  const Vec2 base = e.at + (along - e.buffer) * e.direction;
  const std::int64_t count = row_count(e);
  for (std::int64_t j = 0; j < count; ++j) {
    x.push_back(base + (Real(j) + Real(0.5) - Real(0.5) * Real(count)) * dx_ * across);
    v.push_back(u);
  }
}

// The inflow's velocity at t: the speed table's within [start, stop), else 0.
Vec2 Flows::inflow(const Emitter& e, Real t) const {
  return t >= e.start && t < e.stop ? Vec2(e.speed.at(t) * e.direction) : Vec2(Vec2::Zero());
}

void Flows::fill_inlets(Real t, std::vector<Vec2>& x, std::vector<Vec2>& v) {
  for (std::size_t k = 0; k < emitters_.size(); ++k) {
    const Emitter& e = emitters_[k];
    if (!(e.buffer > 0) || filled_[k]) continue;
    filled_[k] = 1;
    const auto rows = std::max<std::int64_t>(1, std::llround(e.buffer / dx_));
    for (std::int64_t r = 0; r < rows; ++r) row(e, (Real(r) + Real(0.5)) * dx_, inflow(e, t), x, v);
    travelled_[k] = Real(0.5) * dx_;  // the back row's travel from the back
  }
}

void Flows::fill_outlets(std::vector<Vec2>& x, const Vec2* fluid, Index n, Real reach) {
  std::vector<char> wet(lanes_, 0);
  for (Index i = 0; i < n; ++i) {
    const Place p = outlet_place(fluid[i], reach);
    if (p.zone == kUpstream) wet[p.lane] = 1;
  }
  for (std::size_t k = 0; k < outlets_.size(); ++k) {
    if (outlet_filled_[k]) continue;
    outlet_filled_[k] = 1;
    const Outlet& o = outlets_[k];
    const Vec2 across(-o.direction.y(), o.direction.x());
    const auto rows = std::max<std::int64_t>(1, std::llround(o.depth / dx_));
    const auto count = std::max<std::int64_t>(1, std::llround(o.width / dx_));
    for (std::int64_t r = 0; r < rows; ++r)
      for (std::int64_t j = 0; j < count; ++j) {
        const Real off = (Real(j) + Real(0.5) - Real(0.5) * Real(count)) * dx_;
        if (wet[lane_at(k, off)])
          x.push_back(o.at + (Real(r) + Real(0.5)) * dx_ * o.direction + off * across);
      }
  }
}

void Flows::unfill_empty_buffers(const Vec2* x, Index n) {
  auto holds = [&](const Vec2& at, const Vec2& dir, Real from, Real to, Real half) {
    const Vec2 across(-dir.y(), dir.x());
    for (Index i = 0; i < n; ++i) {
      const Vec2 rel = x[i] - at;
      const Real along = rel.dot(dir);
      if (along >= from && along < to && std::abs(rel.dot(across)) <= half) return true;
    }
    return false;
  };
  for (std::size_t k = 0; k < emitters_.size(); ++k) {
    const Emitter& e = emitters_[k];
    if (e.buffer > 0 && filled_[k] &&
        !holds(e.at, e.direction, -e.buffer, 0, Real(0.5) * Real(row_count(e)) * dx_))
      filled_[k] = 0;
  }
  for (std::size_t k = 0; k < outlets_.size(); ++k) {
    const Outlet& o = outlets_[k];
    if (outlet_filled_[k] && !holds(o.at, o.direction, 0, o.depth, Real(0.5) * o.width))
      outlet_filled_[k] = 0;
  }
}

int Flows::inlet_holding(const Vec2& x) const {
  for (std::size_t k = 0; k < emitters_.size(); ++k) {
    const Emitter& e = emitters_[k];
    if (!(e.buffer > 0)) continue;
    const Vec2 rel = x - e.at;
    const Real along = rel.dot(e.direction);
    if (!(along < 0 && along >= -e.buffer)) continue;
    const Vec2 across(-e.direction.y(), e.direction.x());
    if (!(std::abs(rel.dot(across)) <= Real(0.5) * Real(row_count(e)) * dx_)) continue;
    return static_cast<int>(k);
  }
  return -1;
}

bool Flows::hold_in_inlet(Real t, Vec2& x, Vec2& v) const {
  const int k = inlet_holding(x);
  if (k < 0) return false;
  const Emitter& e = emitters_[k];
  const Vec2 rel = x - e.at;
  const Real along = rel.dot(e.direction);
  const Vec2 across(-e.direction.y(), e.direction.x());
  const std::int64_t count = row_count(e);
  const Real half = Real(0.5) * Real(count) * dx_;
  const Real off = rel.dot(across);
  // The rows stand at travel + m dx from the back, the columns at
  // (j + 1/2) dx from the edge.
  const Real s = travelled_[k];
  const Real m = std::round((along + e.buffer - s) / dx_);
  const Real j = std::clamp(std::floor((off + half) / dx_), Real(0), Real(count - 1));
  x = e.at + (s + m * dx_ - e.buffer) * e.direction + ((j + Real(0.5)) * dx_ - half) * across;
  v = inflow(e, t);
  return true;
}

Real Flows::top_inflow_speed() const {
  Real top = 0;
  for (const Emitter& e : emitters_)
    if (e.buffer > 0)
      for (Real u : e.speed.value) top = std::max(top, u);
  return top;
}

Flows::Place Flows::outlet_place(const Vec2& p, Real reach) const {
  for (std::size_t k = 0; k < outlets_.size(); ++k) {
    const Outlet& o = outlets_[k];
    const Vec2 rel = p - o.at;
    const Real along = rel.dot(o.direction);
    if (!(along >= -reach && along < 2 * o.depth)) continue;
    const Real off = rel.x() * -o.direction.y() + rel.y() * o.direction.x();
    if (!(std::abs(off) <= Real(0.5) * o.width)) continue;
    return {along < 0 ? kUpstream : along < o.depth ? kHeld : kPast, lane_at(k, off)};
  }
  return {};
}

int Flows::lane_at(std::size_t k, Real off) const {
  const int lanes = first_lane_[k + 1] - first_lane_[k];
  return first_lane_[k] +
         std::clamp(static_cast<int>((off / outlets_[k].width + Real(0.5)) * lanes), 0, lanes - 1);
}

void Flows::set_travelled(const std::vector<Real>& travelled) {
  check(travelled.size() == emitters_.size(),
        "checkpoint: it carries " + std::to_string(travelled.size()) +
            " emitters, this run has " + std::to_string(emitters_.size()));
  for (Real s : travelled) check(std::isfinite(s) && s >= 0, "checkpoint: an emitter's travel");
  travelled_ = travelled;
  filled_.assign(emitters_.size(), 1);  // the checkpoint holds the buffers
  outlet_filled_.assign(outlets_.size(), 1);
}

}  // namespace sphfluid
