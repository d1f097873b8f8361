// A value that changes in time, given as a table: the emitters' speeds
// (boundary/flows.hpp) and the walls' motions (boundary/walls.hpp).
#pragma once

#include <algorithm>
#include <vector>

#include "core/types.hpp"

namespace sphfluid {

// (time, value) pairs in increasing time, linear between them, their end
// values beyond them (one pair: a constant).
struct TimeTable {
  std::vector<Real> t, value;

  // The piece [t[k-1], t[k]] that holds `time` (k in 1..size-1); 0 before the
  // first time or with one pair, size() at or after the last.
  std::size_t piece(Real time) const {
    if (t.size() < 2 || time < t.front()) return 0;
    if (time >= t.back()) return t.size();
    return static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin());
  }
  Real at(Real time) const {
    const std::size_t k = piece(time);
    if (k == 0) return value.front();
    if (k == t.size()) return value.back();
    const Real s = (time - t[k - 1]) / (t[k] - t[k - 1]);
    return value[k - 1] + s * (value[k] - value[k - 1]);
  }
  // The rate of change at `time`: the slope of the piece that holds it (the
  // later one at a break), 0 beyond the table's ends.
  Real slope(Real time) const {
    const std::size_t k = piece(time);
    if (k == 0 || k == t.size()) return 0;
    return (value[k] - value[k - 1]) / (t[k] - t[k - 1]);
  }
  // The integral of the value over [a, b] (the trapezoid of each piece: exact
  // for the piecewise-linear value).
  Real integral(Real a, Real b) const {
    if (!(b > a)) return 0;
    Real sum = 0, from = a;
    auto piece_to = [&](Real to) {
      sum += Real(0.5) * (at(from) + at(to)) * (to - from);
      from = to;
    };
    for (Real tk : t)
      if (tk > a && tk < b) piece_to(tk);
    piece_to(b);
    return sum;
  }
};

}  // namespace sphfluid
