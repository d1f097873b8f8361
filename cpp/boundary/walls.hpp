// Static wall segments and the two wall mechanisms of the seed (section 4 of
// the paper, docs/method-seed.md "Walls"): ghost particles at the clamped foot
// of the perpendicular (4.1) and the repeated reflection of a particle's path
// within one step (4.2). Pure geometry: no SPH here.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "core/time_table.hpp"
#include "core/types.hpp"
#include "simd/ints.hpp"

namespace sphfluid {

struct Segment {
  Vec2 a, b;      // end points, m
  Vec2 t;         // unit tangent a -> b
  Vec2 n;         // unit normal (t rotated +90 degrees)
  Real len;       // length, m
  Index shared_a = -1;  // another segment that has end point a too, or -1
  Index shared_b = -1;  // likewise for b
  // The velocity of the wall's surface along t (m/s; the wall itself stays
  // where it is: a lid that slides). Only its tangential part is used.
  Vec2 velocity = Vec2::Zero();
};

// A rigid motion of a group of walls: a translation (x(t), y(t)) of their
// drawn position and a rotation by angle(t) (radians, counterclockwise)
// about the point `about`, which moves with the translation: a drawn point
// p is at about + (x, y) + R(angle) (p - about).
struct WallMotion {
  TimeTable x, y, angle;
  Vec2 about = Vec2::Zero();
};

// A WallMotion at one time: where drawn points are and how fast they move.
struct WallPose {
  Vec2 centre = Vec2::Zero();  // where `about` is, m
  Vec2 about = Vec2::Zero();
  Real cos = 1, sin = 0;
  Vec2 velocity = Vec2::Zero();  // of the centre, m/s
  Real omega = 0;                // rad/s
  static WallPose of(const WallMotion& m, Real time);
  Vec2 rotate(const Vec2& u) const { return Vec2(cos * u.x() - sin * u.y(), sin * u.x() + cos * u.y()); }
  Vec2 unrotate(const Vec2& u) const { return Vec2(cos * u.x() + sin * u.y(), -sin * u.x() + cos * u.y()); }
  // A drawn point's place, and back.
  Vec2 place(const Vec2& drawn) const { return centre + rotate(drawn - about); }
  Vec2 drawn(const Vec2& placed) const { return about + unrotate(placed - centre); }
  // The velocity of the wall's material at a placed point.
  Vec2 velocity_at(const Vec2& p) const {
    const Vec2 r = p - centre;
    return velocity + omega * Vec2(-r.y(), r.x());
  }
};

// Throws std::invalid_argument for a zero-length or non-finite segment.
Segment make_segment(const Vec2& a, const Vec2& b);

// Closest point of the segment to p; `t` receives the unclamped projection
// parameter (0 at a, 1 at b).
Vec2 closest_point(const Segment& s, const Vec2& p, Real& t);

// Where the path p0 -> p1 meets the segment: the path parameter in [0, 1],
// or a negative value if it does not (parallel paths never meet).
Real path_hit(const Segment& s, const Vec2& p0, const Vec2& p1);

class WallSet;

// A particle's velocity relative to a moving wall's material at the ghost
// at r (from the ghost to the particle): what the wall terms take beside
// moving walls (the rows and ghosts move with their wall).
struct VelocityToWall {
  const WallSet& walls;
  Vec2 x, v;
  Vec2 operator()(const Vec2& r) const;
};
// A particle's velocity relative to the surface of the wall at the ghost at
// r: a sliding lid's tangential velocity, or a moving wall's material
// velocity (what the no-slip friction takes).
struct VelocityToSurface {
  const WallSet& walls;
  Vec2 x, v;
  Vec2 operator()(const Vec2& r) const;
};
// The same beside fixed walls: the particle's own velocity at every ghost.
struct VelocityAsIs {
  Vec2 v;
  const Vec2& operator()(const Vec2&) const { return v; }
};

class WallSet {
 public:
  WallSet() = default;
  // Builds the lookup grid for ghosts of support h; finds shared end points.
  WallSet(std::vector<Segment> segments, Real h);

  bool empty() const { return segments_.empty(); }
  const std::vector<Segment>& segments() const { return segments_; }
  // The walls' surface velocities (one per segment; their tangential parts).
  void set_velocities(const std::vector<Vec2>& velocities);
  // Whether any wall's surface moves (slides, or the wall itself moves).
  bool moving() const { return moving_; }
  // The surface velocity of the wall through `foot` (a ghost's foot of the
  // perpendicular; the nearest segment of its lookup cell), zero off the grid:
  // a sliding surface's, or a moving wall's material velocity there.
  Vec2 velocity_at(const Vec2& foot) const;
  // A moving wall's material velocity at `foot` (zero for a fixed or a
  // sliding one): what the boundary terms take relative velocities to.
  Vec2 motion_velocity_at(const Vec2& foot) const;

  // Moving walls: motion_of[k] is segment k's motion (an index into motions)
  // or -1 for a fixed wall; the segments as given are the drawn positions.
  // Places the walls at `time`. Throws std::invalid_argument for a table out of
  // order or a motion index out of range.
  void set_motions(std::vector<WallMotion> motions, const std::vector<Index>& motion_of,
                   Real time);
  // Whether any wall moves (its geometry, not only its surface).
  bool moves() const { return !motions_.empty(); }
  // The walls at `time` (their segments and lookup grid); nothing without motion.
  void move_to(Real time);
  // The poses at the end of the coming step, for collide().
  void aim(Real time_next);
  // The largest speed of a moving wall's material, now or at the end of the
  // coming step (at its segments' ends), m/s; 0 without motion.
  Real max_speed() const;
  // The largest it can be over the whole motion (from the tables), m/s.
  Real top_speed() const;

  // Calls f(r_ig, nearest) for every ghost of a fluid particle at p, where
  // r_ig = p - ghost and |r_ig| < h. A ghost sits at the foot of the perpendicular on each segment
  // within h (seed 4.1). Where segments share an end point the particle gets one
  // ghost there, not one per segment, so polylines have no doubled joints.
  // nearest: the ghost is the walls' nearest point there (on a segment's
  // interior, a convex corner's vertex seen from outside, or a free end);
  // false at a joint of two segments the other comes nearer than, and at
  // any point where three or more segments meet.
  // Returns the squared distance from p to the nearest segment of its lookup
  // cell, at most h^2 (h^2 off the grid): no other segment comes within h of p.
  template <class F>
  Real for_each_ghost(const Vec2& p, F&& f) const {
    const Index c = cell_of(p);
    Real nearest2 = h2_;
    if (c < 0) return nearest2;
    for (Index q = cell_start_[c]; q < cell_start_[c + 1]; ++q) {
      const Index si = cell_items_[q];
      const Segment& s = segments_[si];
      Real t;
      const Vec2 foot = closest_point(s, p, t);
      const Vec2 r = p - foot;
      nearest2 = std::min(nearest2, r.squaredNorm());
      if (r.squaredNorm() >= h2_) continue;
      EndPoint e = EndPoint::kVertex;
      if (t <= 0) e = end_point(si, s.shared_a, junction_[2 * si] != 0, s.a, p);
      if (t >= 1) e = end_point(si, s.shared_b, junction_[2 * si + 1] != 0, s.b, p);
      if (e == EndPoint::kNone) continue;
      f(r, e == EndPoint::kVertex);
    }
    return nearest2;
  }

  // From for_each_ghost's squared distance d2 of a point: a squared length
  // below which a path from the point meets no wall. At most (h/2)^2, and
  // 2e-6 h^2 less than d2: a margin of 1e-6 h on the distance for its rounding
  // (absolute, near 1e-16 of the coordinates: a point on a wall measures
  // about 1e-17 m from it), for the collision test's, and for a float copy.
  Real safe_path2(Real d2) const {
    return std::max(std::min(d2, Real(0.25) * h2_) - Real(2e-6) * h2_, Real(0));
  }

  // Moves a particle from x_old towards x_new (its velocity v already updated)
  // and reflects it off every wall on its path, each wall at most once per step
  // (seed 4.2); the normal velocity is scaled by -restitution at each bounce.
  // If the path meets a wall a second time, the particle stops just in front
  // of it instead, so no path ever crosses a wall. Returns the crossings it
  // stopped: the bounces, and the stop if there was one.
  // With moving walls, each moving group is met in its own frame: the path's
  // end mapped to where it is relative to the group at the step's start (the
  // poses of aim()), the velocity taken relative to the wall's.
  int collide(const Vec2& x_old, Vec2& x_new, Vec2& v, Real restitution) const;

  // False when the path p0 -> p1 cannot meet a wall: it lies in one lookup
  // cell that no wall comes near (most particles, most steps). Inline, so
  // that those particles skip collide() without a call.
  bool may_hit(const Vec2& p0, const Vec2& p1) const {
    const Index c = cell_of(p0);
    return c < 0 || c != cell_of(p1) || cell_start_[c] != cell_start_[c + 1];
  }
  // Whether the path p0 -> p1 meets a wall as the walls stand.
  bool meets(const Vec2& p0, const Vec2& p1) const {
    Real s_hit;
    return may_hit(p0, p1) && first_hit(p0, p1, s_hit) >= 0;
  }
#if SPHFLUID_AVX512
  // may_hit for eight paths at once: from (x0[k], y0[k]) to (x1[k], y1[k]) on
  // the lanes of `lanes`; the lanes whose path may meet a wall.
  simd::Mask8 may_hit8(simd::Mask8 lanes, simd::D8 x0, simd::D8 y0, simd::D8 x1,
                       simd::D8 y1) const {
    simd::Mask8 on0, on1;
    const simd::I8 c0 = cells8(lanes, x0, y0, on0), c1 = cells8(lanes, x1, y1, on1);
    const simd::Mask8 same = on0 & on1 & eq(c0, c1);
    const simd::I8 count = simd::gather(same, c0, cell_count_.data());
    return lanes & ~(same & ~nonzero(count));
  }
  // The lanes of `lanes` whose point (x[k], y[k]) lies in a lookup cell that
  // some wall comes near: the only points for_each_ghost may give ghosts.
  simd::Mask8 near8(simd::Mask8 lanes, simd::D8 x, simd::D8 y) const {
    simd::Mask8 on;
    const simd::I8 c = cells8(lanes, x, y, on);
    return nonzero(simd::gather(on, c, cell_count_.data()));
  }
#endif

 private:
#if SPHFLUID_AVX512
  // The lookup cells of eight points, on the lanes of `on` (those of `lanes`
  // on the grid; cell_of's -1 elsewhere).
  simd::I8 cells8(simd::Mask8 lanes, simd::D8 x, simd::D8 y, simd::Mask8& on) const {
    using simd::D8;
    const D8 zero = simd::zero<D8>(), inv = D8::splat(inv_cell_);
    const D8 fx = (x - D8::splat(origin_.x())) * inv;
    const D8 fy = (y - D8::splat(origin_.y())) * inv;
    on = ge(lanes, fx, zero) & ge(0xFF, fy, zero) & lt(0xFF, fx, D8::splat(nx_)) &
         lt(0xFF, fy, D8::splat(ny_));
    const simd::I8 ix = simd::truncate(on, fx), iy = simd::truncate(on, fy);
    return iy * simd::I8::splat(nx_) + ix;
  }
#endif
  // The lookup cell of p, or -1 off the grid.
  Index cell_of(const Vec2& p) const {
    const Real fx = (p.x() - origin_.x()) * inv_cell_, fy = (p.y() - origin_.y()) * inv_cell_;
    if (!(fx >= 0 && fy >= 0 && fx < nx_ && fy < ny_)) return -1;
    return static_cast<Index>(fy) * nx_ + static_cast<Index>(fx);
  }
  enum class EndPoint { kNone, kVertex, kJoint };
  EndPoint end_point(Index si, Index other, bool junction, const Vec2& v, const Vec2& p) const;
  // The shared end points and the lookup grid of segments_.
  void build();
  // collide() among these segments as they stand.
  int collide_fixed(const Vec2& x_old, Vec2& x_new, Vec2& v, Real restitution) const;
  // The wall that the path p0 -> p1 meets first (and where, in s_hit); -1 if none.
  Index first_hit(const Vec2& p0, const Vec2& p1, Real& s_hit) const;

  std::vector<Segment> segments_;
  // Per end point (2 si for a, 2 si + 1 for b): whether three or more
  // segments meet there.
  std::vector<char> junction_;
  bool moving_ = false;
  Real h_ = 0;
  Real h2_ = 0;
  // Moving walls: the drawn segments, each one's motion (-1: fixed), the
  // motions, their poses now and at the end of the coming step, and the
  // segments split into the fixed ones (parts_[0]) and one set per motion.
  std::vector<Segment> drawn_;
  std::vector<Index> motion_of_;
  std::vector<WallMotion> motions_;
  std::vector<WallPose> pose_, next_;
  std::vector<WallSet> parts_;
  Real eps_ = 0;  // stand-off from a wall after a bounce, m
  // Lookup grid: each cell lists the segments that come within h of it.
  Vec2 origin_{0, 0};
  Real inv_cell_ = 1;
  Index nx_ = 0, ny_ = 0;
  std::vector<Index> cell_start_;
  std::vector<Index> cell_items_;
  std::vector<Index> cell_count_;  // segments in each cell: one gather for the 8-lane tests
};

inline Vec2 VelocityToWall::operator()(const Vec2& r) const {
  return v - walls.motion_velocity_at(x - r);
}

inline Vec2 VelocityToSurface::operator()(const Vec2& r) const {
  return v - walls.velocity_at(x - r);
}

}  // namespace sphfluid
