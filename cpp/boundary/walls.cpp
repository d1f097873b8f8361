// Wall geometry: segment construction, projection, path intersection, the
// segment lookup grid, ghost ownership at shared end points, and reflection.
#include "boundary/walls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace sphfluid {

namespace {
Real cross(const Vec2& u, const Vec2& w) { return u.x() * w.y() - u.y() * w.x(); }
constexpr int kMaxBounces = 8;
}  // namespace

Segment make_segment(const Vec2& a, const Vec2& b) {
  if (!a.allFinite() || !b.allFinite()) throw std::invalid_argument("wall end point is not finite");
  const Vec2 d = b - a;
  const Real len = std::hypot(d.x(), d.y());  // no overflow of the square
  if (!d.allFinite() || !std::isfinite(len))
    throw std::invalid_argument("wall segment is longer than a double can hold");
  if (!(len > 0)) throw std::invalid_argument("wall segment has zero length");
  Segment s;
  s.a = a;
  s.b = b;
  s.len = len;
  s.t = d / len;
  s.n = Vec2(-s.t.y(), s.t.x());
  return s;
}

Vec2 closest_point(const Segment& s, const Vec2& p, Real& t) {
  t = (p - s.a).dot(s.t) / s.len;
  if (t <= 0) return s.a;
  if (t >= 1) return s.b;
  return s.a + (t * s.len) * s.t;
}

Real path_hit(const Segment& s, const Vec2& p0, const Vec2& p1) {
  const Vec2 d = p1 - p0;
  const Vec2 e = s.b - s.a;
  const Real denom = cross(d, e);
  if (denom == 0) return -1;
  const Vec2 w = s.a - p0;
  const Real sp = cross(w, e) / denom;  // along the path
  const Real u = cross(w, d) / denom;   // along the segment
  if (sp < 0 || sp > 1 || u < 0 || u > 1) return -1;
  return sp;
}

WallSet::WallSet(std::vector<Segment> segments, Real h) : segments_(std::move(segments)) {
  h_ = h;
  h2_ = h * h;
  eps_ = 1e-6 * h;
  build();
}

void WallSet::build() {
  const Real h = h_;
  const Index ns = static_cast<Index>(segments_.size());
  cell_start_.clear();
  cell_items_.clear();
  cell_count_.clear();
  nx_ = ny_ = 0;
  for (Segment& s : segments_) s.shared_a = s.shared_b = -1;
  junction_.assign(2 * static_cast<std::size_t>(ns), 0);
  if (ns == 0) return;

  // Shared end points: each end's partner is the lowest-numbered other segment
  // with an end within 1e-9 h of it. The ends sorted by x, each compared with
  // those that follow within the tolerance in x: O(n log n) for any drawing.
  const Real tol = 1e-9 * h;
  struct End {
    Real x, y;
    Index seg;
    bool b;
  };
  std::vector<End> ends;
  ends.reserve(2 * static_cast<std::size_t>(ns));
  for (Index i = 0; i < ns; ++i) {
    ends.push_back({segments_[i].a.x(), segments_[i].a.y(), i, false});
    ends.push_back({segments_[i].b.x(), segments_[i].b.y(), i, true});
  }
  std::sort(ends.begin(), ends.end(), [](const End& p, const End& q) { return p.x < q.x; });
  auto partner = [&](const End& e, Index other) {
    Index& slot = e.b ? segments_[e.seg].shared_b : segments_[e.seg].shared_a;
    if (slot >= 0 && slot != other) junction_[2 * e.seg + e.b] = 1;  // a third segment
    if (slot < 0 || other < slot) slot = other;
  };
  for (std::size_t k = 0; k < ends.size(); ++k)
    for (std::size_t m = k + 1; m < ends.size() && ends[m].x - ends[k].x <= tol; ++m) {
      const End &p = ends[k], &q = ends[m];
      if (p.seg == q.seg || Vec2(p.x - q.x, p.y - q.y).squaredNorm() > tol * tol) continue;
      partner(p, q.seg);
      partner(q, p.seg);
    }

  Vec2 lo = segments_[0].a, hi = lo;
  for (const Segment& s : segments_) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
  }
  lo.array() -= h;
  hi.array() += h;
  const Vec2 extent = hi - lo;
  if (!extent.allFinite()) throw std::invalid_argument("walls span more than a double can hold");
  // Cells of size h, coarsened (by area, then doubled) until there are at most
  // kMaxCells: the grid's memory is bounded whatever the walls' extent, also
  // for a long thin one whose area is small.
  constexpr Real kMaxCells = 4.0e6;
  auto cells = [&](Real c) {
    return (std::floor(extent.x() / c) + 1) * (std::floor(extent.y() / c) + 1);
  };
  Real cell = h;  // the area's cells, as a product of roots: no overflow
  const Real root_cells = std::sqrt(extent.x()) * std::sqrt(extent.y()) / cell;
  if (root_cells * root_cells > kMaxCells) cell *= root_cells / std::sqrt(kMaxCells);
  while (cells(cell) > kMaxCells) cell *= 2;
  inv_cell_ = 1 / cell;
  origin_ = lo;
  nx_ = static_cast<Index>(std::floor(extent.x() * inv_cell_)) + 1;
  ny_ = static_cast<Index>(std::floor(extent.y() * inv_cell_)) + 1;

  // A segment goes into every cell whose centre lies within h + half a cell
  // diagonal of it: then any point of the cell within h of it finds it.
  const Real reach = h + 0.5 * std::sqrt(2.0) * cell;
  std::vector<std::vector<Index>> lists(static_cast<std::size_t>(nx_) * ny_);
  for (Index si = 0; si < ns; ++si) {
    const Segment& s = segments_[si];
    const Vec2 slo = s.a.cwiseMin(s.b).array() - reach;
    const Vec2 shi = s.a.cwiseMax(s.b).array() + reach;
    const Index x0 = std::max<Index>(0, static_cast<Index>((slo.x() - lo.x()) * inv_cell_));
    const Index y0 = std::max<Index>(0, static_cast<Index>((slo.y() - lo.y()) * inv_cell_));
    const Index x1 = std::min<Index>(nx_ - 1, static_cast<Index>((shi.x() - lo.x()) * inv_cell_));
    const Index y1 = std::min<Index>(ny_ - 1, static_cast<Index>((shi.y() - lo.y()) * inv_cell_));
    for (Index iy = y0; iy <= y1; ++iy)
      for (Index ix = x0; ix <= x1; ++ix) {
        const Vec2 centre = lo + Vec2((ix + 0.5) * cell, (iy + 0.5) * cell);
        Real t;
        if ((centre - closest_point(s, centre, t)).norm() <= reach)
          lists[static_cast<std::size_t>(iy) * nx_ + ix].push_back(si);
      }
  }
  cell_start_.assign(lists.size() + 1, 0);
  cell_count_.resize(lists.size());
  for (std::size_t c = 0; c < lists.size(); ++c) {
    cell_count_[c] = static_cast<Index>(lists[c].size());
    cell_start_[c + 1] = cell_start_[c] + cell_count_[c];
  }
  cell_items_.reserve(cell_start_.back());
  for (const auto& l : lists) cell_items_.insert(cell_items_.end(), l.begin(), l.end());
}

// A ghost clamped to end point v of segment si, shared with segment `other`
// (or -1), is counted once: not at all if p projects into the interior of
// `other` (that segment supplies the ghost), otherwise by the lower-numbered
// of the two segments. It is the walls' nearest point there (kVertex) if v
// is also the point of `other` nearest p, or v is a free end: a convex
// corner seen from outside; a joint (kJoint) if `other` comes nearer
// elsewhere: beside a polyline whose pieces are shorter than the support.
// Where three or more segments meet (`junction`), only the lowest-numbered
// partner is known: a joint wherever the particle is (the same for every
// order the segments are given in).
WallSet::EndPoint WallSet::end_point(Index si, Index other, bool junction, const Vec2& v,
                                     const Vec2& p) const {
  if (other < 0) return EndPoint::kVertex;
  const Segment& o = segments_[other];
  Real t;
  closest_point(o, p, t);
  if ((t > 0 && t < 1) || si > other) return EndPoint::kNone;
  if (junction) return EndPoint::kJoint;
  const bool at_a = (o.a - v).squaredNorm() <= (o.b - v).squaredNorm();
  return (at_a ? t <= 0 : t >= 1) ? EndPoint::kVertex : EndPoint::kJoint;
}

Index WallSet::first_hit(const Vec2& p0, const Vec2& p1, Real& s_hit) const {
  Index best = -1;
  s_hit = 2;
  auto consider = [&](Index si) {
    const Real s = path_hit(segments_[si], p0, p1);
    if (s >= 0 && s < s_hit) {
      s_hit = s;
      best = si;
    }
  };
  // Cells along the path's bounding box; a long path scans every segment.
  const Vec2 lo = p0.cwiseMin(p1), hi = p0.cwiseMax(p1);
  const Real fx0 = (lo.x() - origin_.x()) * inv_cell_, fy0 = (lo.y() - origin_.y()) * inv_cell_;
  const Real fx1 = (hi.x() - origin_.x()) * inv_cell_, fy1 = (hi.y() - origin_.y()) * inv_cell_;
  // Far from every wall (or not finite: then no comparison holds).
  if (!(fx1 >= 0 && fy1 >= 0 && fx0 < nx_ && fy0 < ny_)) return -1;
  // Clamped before the conversion: a path of 1e300 m has no Index of its own.
  const Index x0 = static_cast<Index>(std::max<Real>(0, fx0));
  const Index y0 = static_cast<Index>(std::max<Real>(0, fy0));
  const Index x1 = static_cast<Index>(std::min<Real>(nx_ - 1, fx1));
  const Index y1 = static_cast<Index>(std::min<Real>(ny_ - 1, fy1));
  if (x0 == x1 && y0 == y1) {  // the common case: a short path inside one cell
    const Index c = y0 * nx_ + x0;
    for (Index q = cell_start_[c]; q < cell_start_[c + 1]; ++q) consider(cell_items_[q]);
    return best;
  }
  if (std::int64_t(x1 - x0 + 1) * (y1 - y0 + 1) > 16) {
    for (Index si = 0; si < static_cast<Index>(segments_.size()); ++si) consider(si);
    return best;
  }
  for (Index iy = y0; iy <= y1; ++iy)
    for (Index ix = x0; ix <= x1; ++ix) {
      const Index c = iy * nx_ + ix;
      for (Index q = cell_start_[c]; q < cell_start_[c + 1]; ++q) consider(cell_items_[q]);
    }
  return best;
}

int WallSet::collide(const Vec2& x_old, Vec2& x_new, Vec2& v, Real restitution) const {
  if (motions_.empty()) return collide_fixed(x_old, x_new, v, restitution);
  int hits = parts_[0].collide_fixed(x_old, x_new, v, restitution);
  bool pushed = false;
  for (std::size_t k = 0; k < motions_.size(); ++k) {
    const WallSet& part = parts_[k + 1];
    const WallPose &now = pose_[k], &next = next_[k];
    // The end relative to the group: where it would be with the group back at
    // its pose now; the velocity relative to the wall's, in the same frame.
    Vec2 q1 = now.place(next.drawn(x_new));
    if (!part.may_hit(x_old, q1)) continue;
    Vec2 vr = now.rotate(next.unrotate(v - next.velocity_at(x_new)));
    const int k_hits = part.collide_fixed(x_old, q1, vr, restitution);
    if (k_hits == 0) continue;
    x_new = next.place(now.drawn(q1));
    v = next.rotate(now.unrotate(vr)) + next.velocity_at(x_new);
    hits += k_hits;
    pushed = true;
  }
  // A moving wall's push may lead across a fixed wall: met again from x_old.
  if (pushed) hits += parts_[0].collide_fixed(x_old, x_new, v, restitution);
  return hits;
}

int WallSet::collide_fixed(const Vec2& x_old, Vec2& x_new, Vec2& v, Real restitution) const {
  Vec2 p0 = x_old, p1 = x_new;
  Index bounced[kMaxBounces];
  int n_bounced = 0;
  Real s;
  Index si;
  while ((si = first_hit(p0, p1, s)) >= 0) {
    const Segment& w = segments_[si];
    const Vec2 d = p1 - p0;
    const Vec2 hit = p0 + s * d;
    // Restart a little short of the hit point along the incoming path, which
    // is free of walls up to the hit: a point offset along the normal could
    // land across another wall where two walls meet.
    const Vec2 safe = p0 + std::max(Real(0), s - eps_ / d.norm()) * d;
    // Normal pointing back to the side the particle came from.
    const Real side = (p0 - w.a).dot(w.n);
    const Vec2 n = side > 0 ? w.n : side < 0 ? Vec2(-w.n) : (d.dot(w.n) > 0 ? Vec2(-w.n) : w.n);
    const bool again = std::find(bounced, bounced + n_bounced, si) != bounced + n_bounced;
    if (again || n_bounced == kMaxBounces) {
      // Each wall bounces a particle at most once per step (seed 4.2). If the
      // rest of the path still meets one, the particle stops just in front of
      // it, keeping only its tangential velocity: no path ever crosses a wall.
      const Real vn = v.dot(n);
      if (vn < 0) v -= vn * n;
      x_new = safe;
      return n_bounced + 1;
    }
    // Reflect the velocity and the rest of the path like a rubber ball.
    const Real vn = v.dot(n);
    if (vn < 0) v -= (1 + restitution) * vn * n;
    Vec2 rest = p1 - hit;
    const Real rn = rest.dot(n);
    if (rn < 0) rest -= (1 + restitution) * rn * n;
    p0 = safe;
    p1 = p0 + rest;
    bounced[n_bounced++] = si;
  }
  x_new = p1;
  return n_bounced;
}

void WallSet::set_velocities(const std::vector<Vec2>& velocities) {
  if (velocities.size() != segments_.size())
    throw std::invalid_argument("one wall velocity per segment");
  moving_ = !motions_.empty();
  for (std::size_t k = 0; k < segments_.size(); ++k) {
    if (!velocities[k].allFinite()) throw std::invalid_argument("wall velocity is not finite");
    Segment& s = segments_[k];
    s.velocity = velocities[k].dot(s.t) * s.t;
    moving_ = moving_ || s.velocity.squaredNorm() > 0;
  }
}

namespace {

// The segment of the lookup cell's list [first, last) nearest to p, or -1.
template <class Items>
Index nearest_of(const std::vector<Segment>& segments, const Items& items, Index first,
                 Index last, const Vec2& p) {
  Real best = std::numeric_limits<Real>::infinity();
  Index nearest = -1;
  for (Index q = first; q < last; ++q) {
    Real t;
    const Segment& s = segments[items[q]];
    const Real d2 = (closest_point(s, p, t) - p).squaredNorm();
    if (d2 < best) {
      best = d2;
      nearest = items[q];
    }
  }
  return nearest;
}

}  // namespace

Vec2 WallSet::velocity_at(const Vec2& foot) const {
  const Index c = cell_of(foot);
  if (c < 0) return Vec2::Zero();
  const Index si = nearest_of(segments_, cell_items_, cell_start_[c], cell_start_[c + 1], foot);
  if (si < 0) return Vec2::Zero();
  if (!motion_of_.empty() && motion_of_[si] >= 0) return pose_[motion_of_[si]].velocity_at(foot);
  return segments_[si].velocity;
}

Vec2 WallSet::motion_velocity_at(const Vec2& foot) const {
  if (motions_.empty()) return Vec2::Zero();
  const Index c = cell_of(foot);
  if (c < 0) return Vec2::Zero();
  const Index si = nearest_of(segments_, cell_items_, cell_start_[c], cell_start_[c + 1], foot);
  if (si < 0 || motion_of_[si] < 0) return Vec2::Zero();
  return pose_[motion_of_[si]].velocity_at(foot);
}

WallPose WallPose::of(const WallMotion& m, Real time) {
  WallPose p;
  p.about = m.about;
  const Vec2 shift(m.x.at(time), m.y.at(time));
  p.centre = m.about + shift;
  const Real angle = m.angle.at(time);
  p.cos = std::cos(angle);
  p.sin = std::sin(angle);
  p.velocity = Vec2(m.x.slope(time), m.y.slope(time));
  p.omega = m.angle.slope(time);
  return p;
}

namespace {

// Throws std::invalid_argument for a motion that cannot be followed.
void check_motions(const std::vector<WallMotion>& motions, const std::vector<Index>& motion_of,
                   std::size_t segments) {
  if (motion_of.size() != segments) throw std::invalid_argument("one motion index per wall segment");
  for (Index k : motion_of)
    if (k < -1 || k >= static_cast<Index>(motions.size()))
      throw std::invalid_argument("a wall's motion index is out of range");
  for (const WallMotion& m : motions) {
    if (!m.about.allFinite()) throw std::invalid_argument("a wall motion's centre is not finite");
    for (const TimeTable* tab : {&m.x, &m.y, &m.angle}) {
      if (tab->t.empty() || tab->t.size() != tab->value.size())
        throw std::invalid_argument("a wall motion's table needs one value per time");
      for (std::size_t i = 0; i < tab->t.size(); ++i)
        if (!std::isfinite(tab->t[i]) || !std::isfinite(tab->value[i]) ||
            (i > 0 && !(tab->t[i] > tab->t[i - 1])))
          throw std::invalid_argument("a wall motion's table: finite values, times increasing");
    }
  }
}

}  // namespace

void WallSet::set_motions(std::vector<WallMotion> motions, const std::vector<Index>& motion_of,
                          Real time) {
  check_motions(motions, motion_of, drawn_.empty() ? segments_.size() : drawn_.size());
  if (!drawn_.empty()) segments_ = drawn_;  // (motions set before: back to the drawing)
  drawn_.clear();
  motion_of_.clear();
  motions_.clear();
  parts_.clear();
  pose_.clear();
  next_.clear();
  bool any = false;
  for (Index k : motion_of) any = any || k >= 0;
  moving_ = false;
  for (const Segment& s : segments_) moving_ = moving_ || s.velocity.squaredNorm() > 0;
  if (!any) {
    build();
    return;
  }
  drawn_ = segments_;
  motion_of_ = motion_of;
  motions_ = std::move(motions);
  pose_.resize(motions_.size());
  next_.resize(motions_.size());
  std::vector<Segment> fixed;
  for (std::size_t i = 0; i < drawn_.size(); ++i)
    if (motion_of_[i] < 0) fixed.push_back(drawn_[i]);
  parts_.assign(motions_.size() + 1, WallSet());
  parts_[0] = WallSet(std::move(fixed), h_);
  move_to(time);
  aim(time);
}

void WallSet::move_to(Real time) {
  if (motions_.empty()) return;
  for (std::size_t k = 0; k < motions_.size(); ++k) pose_[k] = WallPose::of(motions_[k], time);
  std::vector<std::vector<Segment>> groups(motions_.size());
  for (std::size_t i = 0; i < drawn_.size(); ++i) {
    const Index k = motion_of_[i];
    if (k < 0) {
      segments_[i] = drawn_[i];
      continue;
    }
    Segment s = make_segment(pose_[k].place(drawn_[i].a), pose_[k].place(drawn_[i].b));
    segments_[i] = s;
    groups[k].push_back(s);
  }
  build();
  for (std::size_t k = 0; k < groups.size(); ++k) parts_[k + 1] = WallSet(groups[k], h_);
  moving_ = true;
}

void WallSet::aim(Real time_next) {
  for (std::size_t k = 0; k < motions_.size(); ++k) next_[k] = WallPose::of(motions_[k], time_next);
}

Real WallSet::max_speed() const {
  Real fastest = 0;
  for (std::size_t i = 0; i < segments_.size() && !motion_of_.empty(); ++i) {
    const Index k = motion_of_[i];
    if (k < 0) continue;
    for (const Vec2& p : {segments_[i].a, segments_[i].b})
      fastest = std::max({fastest, pose_[k].velocity_at(p).norm(), next_[k].velocity_at(p).norm()});
  }
  return fastest;
}

}  // namespace sphfluid

namespace sphfluid {

Real WallSet::top_speed() const {
  Real fastest = 0;
  for (std::size_t i = 0; i < drawn_.size(); ++i) {
    const Index k = motion_of_[i];
    if (k < 0) continue;
    const WallMotion& m = motions_[k];
    const Real reach = std::max((drawn_[i].a - m.about).norm(), (drawn_[i].b - m.about).norm());
    auto steepest = [](const TimeTable& tab) {
      Real most = 0;
      for (std::size_t j = 1; j < tab.t.size(); ++j)
        most = std::max(most, std::abs(tab.value[j] - tab.value[j - 1]) / (tab.t[j] - tab.t[j - 1]));
      return most;
    };
    fastest = std::max(fastest, std::hypot(steepest(m.x), steepest(m.y)) + steepest(m.angle) * reach);
  }
  return fastest;
}

}  // namespace sphfluid
