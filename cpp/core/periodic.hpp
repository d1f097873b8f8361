// Periodic boundaries: the domain box wraps along the axes marked periodic.
// Pair separations take the minimum image; positions are wrapped back into
// [min, max) after each move. Used only by steps specialised on kPeriodic.
#pragma once

#include <cmath>

#include "core/types.hpp"

namespace sphfluid {

struct PeriodicBox {
  Vec2 lo{0, 0};
  Vec2 length{1, 1};
  bool x = false, y = false;

  PeriodicBox() = default;
  PeriodicBox(const Vec2& min, const Vec2& max, bool px, bool py)
      : lo(min), length(max - min), x(px), y(py) {}

  bool any() const { return x || y; }

  // a - b, shortened by one box length along a periodic axis where that is
  // nearer. Both points lie in the box, so one correction is enough.
  // On scalars: writing one component of a Vec2 and reading the pair back
  // stalled every candidate on a failed store-to-load forwarding (65 % of the
  // Poiseuille case's step).
  Vec2 delta(const Vec2& a, const Vec2& b) const {
    Real dx = a.x() - b.x(), dy = a.y() - b.y();
    if (x) dx -= length.x() * image(dx, length.x());
    if (y) dy -= length.y() * image(dy, length.y());
    return Vec2(dx, dy);
  }

  // p moved back into [lo, lo + length) along the periodic axes.
  Vec2 wrap(Vec2 p) const {
    if (x) p.x() -= length.x() * std::floor((p.x() - lo.x()) / length.x());
    if (y) p.y() -= length.y() * std::floor((p.y() - lo.y()) / length.y());
    return p;
  }

 private:
  // +1, 0 or -1: which neighbouring image of b is nearest to a.
  static Real image(Real d, Real len) {
    const Real half = Real(0.5) * len;
    return static_cast<Real>(d > half) - static_cast<Real>(d < -half);
  }
};

}  // namespace sphfluid
