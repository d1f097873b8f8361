// Damping zones: where waves are to end without reflecting (a numerical
// beach), each step multiplies the velocity of every particle beyond a line
// by 1 - dt s^2 strength (at least 0), s the distance past the line through
// `from` (across from -> to) over |to - from|, 1 beyond `to`: a quadratic
// ramp from nothing at the line to `strength` (1/s) at `to`. This is the
// damping zone of Altomare et al. (Coastal Engineering 127, 2017) that
// DualSPHysics uses (its default strength 10/s). Applied by the Context once
// a step after the drift, so every method has it and pays nothing without.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/types.hpp"

namespace sphfluid {

struct DampingZone {
  Vec2 from = Vec2::Zero();
  Vec2 to = Vec2(1, 0);
  Real strength = 10;  // 1/s at `to` and beyond
};

class Damping {
 public:
  // Throws std::invalid_argument for a zone that cannot work (to = from, a
  // strength not > 0 or not finite).
  void set(std::vector<DampingZone> zones) {
    for (const DampingZone& z : zones) {
      const Real length = (z.to - z.from).norm();
      if (!(length > 0) || !std::isfinite(length))
        throw std::invalid_argument("a damping zone's 'to' must differ from its 'from'");
      if (!(z.strength > 0) || !std::isfinite(z.strength))
        throw std::invalid_argument("a damping zone's strength must be > 0 and finite");
    }
    zones_ = std::move(zones);
  }
  bool any() const { return !zones_.empty(); }
  const std::vector<DampingZone>& zones() const { return zones_; }
  // The factor a particle at p keeps of its velocity over a step dt: the
  // smallest of its zones' (1 where none reaches it).
  Real factor(const Vec2& p, Real dt) const {
    Real keep = 1;
    for (const DampingZone& z : zones_) {
      const Vec2 axis = z.to - z.from;
      const Real s = std::min((p - z.from).dot(axis) / axis.squaredNorm(), Real(1));
      if (s > 0) keep = std::min(keep, std::max(1 - dt * s * s * z.strength, Real(0)));
    }
    return keep;
  }
  // v *= factor(x) for the n particles.
  void apply(const Vec2* x, Vec2* v, Index n, Real dt, int threads) const {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Index i = 0; i < n; ++i) v[i] *= factor(x[i], dt);
  }

 private:
  std::vector<DampingZone> zones_;
};

}  // namespace sphfluid
