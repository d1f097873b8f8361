// Static wall segments and the two wall mechanisms of the seed (section 4):
// ghost particles at the clamped foot of the perpendicular (4.1) and the repeated
// reflection of a particle's path within one step (4.2). Pure geometry: no SPH here.
#pragma once

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <utility>
#include <vector>

#include "core/types.hpp"

namespace sphfluid {

struct Segment {
  Vec2 a, b;      // end points, m
  Vec2 t;         // unit tangent a -> b
  Vec2 n;         // unit normal (t rotated +90 degrees)
  Real len;       // length, m
  Index shared_a = -1;  // another segment that has end point a too, or -1
  Index shared_b = -1;  // likewise for b
};

// Throws std::invalid_argument for a zero-length or non-finite segment.
Segment make_segment(const Vec2& a, const Vec2& b);

// Closest point of the segment to p; `t` receives the unclamped projection
// parameter (0 at a, 1 at b).
Vec2 closest_point(const Segment& s, const Vec2& p, Real& t);

// Where the path p0 -> p1 meets the segment: the path parameter in [0, 1],
// or a negative value if it does not (parallel paths never meet).
Real path_hit(const Segment& s, const Vec2& p0, const Vec2& p1);

class WallSet {
 public:
  WallSet() = default;
  // Builds the lookup grid for ghosts of support h; finds shared end points.
  WallSet(std::vector<Segment> segments, Real h);

  bool empty() const { return segments_.empty(); }
  const std::vector<Segment>& segments() const { return segments_; }

  // Calls f(r_ig, interior) for every ghost of a fluid particle at p, where
  // r_ig = p - ghost, |r_ig| < h, and interior is false for a ghost clamped to an
  // end point of its segment. A ghost sits at the foot of the perpendicular on each segment
  // within h (seed 4.1). Where segments share an end point the particle gets one
  // ghost there, not one per segment, so polylines have no doubled joints.
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
      if (t <= 0 && !owns_end_point(si, s.shared_a, p)) continue;
      if (t >= 1 && !owns_end_point(si, s.shared_b, p)) continue;
      f(r, t > 0 && t < 1);
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
  // of it instead, so no path ever crosses a wall.
  void collide(const Vec2& x_old, Vec2& x_new, Vec2& v, Real restitution) const;

  // False when the path p0 -> p1 cannot meet a wall: it lies in one lookup
  // cell that no wall comes near (most particles, most steps). Inline, so
  // that those particles skip collide() without a call.
  bool may_hit(const Vec2& p0, const Vec2& p1) const {
    const Index c = cell_of(p0);
    return c < 0 || c != cell_of(p1) || cell_start_[c] != cell_start_[c + 1];
  }
#if defined(__AVX512F__) && defined(__AVX512VL__)
  // may_hit for eight paths at once: from (x0[k], y0[k]) to (x1[k], y1[k]) on
  // the lanes of `lanes`; the lanes whose path may meet a wall.
  __mmask8 may_hit8(__mmask8 lanes, __m512d x0, __m512d y0, __m512d x1, __m512d y1) const {
    __mmask8 on0, on1;
    const __m256i c0 = cells8(lanes, x0, y0, on0), c1 = cells8(lanes, x1, y1, on1);
    const __mmask8 same = on0 & on1 & _mm256_cmpeq_epi32_mask(c0, c1);
    const __m256i count =
        _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), same, c0, cell_count_.data(), 4);
    return lanes & ~(same & ~_mm256_test_epi32_mask(count, count));
  }
  // The lanes of `lanes` whose point (x[k], y[k]) lies in a lookup cell that
  // some wall comes near: the only points for_each_ghost may give ghosts.
  __mmask8 near8(__mmask8 lanes, __m512d x, __m512d y) const {
    __mmask8 on;
    const __m256i c = cells8(lanes, x, y, on);
    const __m256i count =
        _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), on, c, cell_count_.data(), 4);
    return _mm256_test_epi32_mask(count, count);
  }
#endif

 private:
#if defined(__AVX512F__) && defined(__AVX512VL__)
  // The lookup cells of eight points, on the lanes of `on` (those of `lanes`
  // on the grid; cell_of's -1 elsewhere).
  __m256i cells8(__mmask8 lanes, __m512d x, __m512d y, __mmask8& on) const {
    const __m512d zero = _mm512_setzero_pd();
    const __m512d inv = _mm512_set1_pd(inv_cell_);
    const __m512d fx = _mm512_mul_pd(_mm512_sub_pd(x, _mm512_set1_pd(origin_.x())), inv);
    const __m512d fy = _mm512_mul_pd(_mm512_sub_pd(y, _mm512_set1_pd(origin_.y())), inv);
    on = _mm512_mask_cmp_pd_mask(lanes, fx, zero, _CMP_GE_OQ) &
         _mm512_cmp_pd_mask(fy, zero, _CMP_GE_OQ) &
         _mm512_cmp_pd_mask(fx, _mm512_set1_pd(nx_), _CMP_LT_OQ) &
         _mm512_cmp_pd_mask(fy, _mm512_set1_pd(ny_), _CMP_LT_OQ);
    const __m256i ix = _mm512_maskz_cvttpd_epi32(on, fx), iy = _mm512_maskz_cvttpd_epi32(on, fy);
    return _mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32(nx_)), ix);
  }
#endif
  // The lookup cell of p, or -1 off the grid.
  Index cell_of(const Vec2& p) const {
    const Real fx = (p.x() - origin_.x()) * inv_cell_, fy = (p.y() - origin_.y()) * inv_cell_;
    if (!(fx >= 0 && fy >= 0 && fx < nx_ && fy < ny_)) return -1;
    return static_cast<Index>(fy) * nx_ + static_cast<Index>(fx);
  }
  bool owns_end_point(Index si, Index other, const Vec2& p) const;
  // The wall that the path p0 -> p1 meets first (and where, in s_hit); -1 if none.
  Index first_hit(const Vec2& p0, const Vec2& p1, Real& s_hit) const;

  std::vector<Segment> segments_;
  Real h2_ = 0;
  Real eps_ = 0;  // stand-off from a wall after a bounce, m
  // Lookup grid: each cell lists the segments that come within h of it.
  Vec2 origin_{0, 0};
  Real inv_cell_ = 1;
  Index nx_ = 0, ny_ = 0;
  std::vector<Index> cell_start_;
  std::vector<Index> cell_items_;
  std::vector<Index> cell_count_;  // segments in each cell: one gather for the 8-lane tests
};

}  // namespace sphfluid
