// Runs of consecutive 2D points stored interleaved (x0, y0, x1, y1, ...), as
// the particle arrays hold them, moved in and out of lane registers: x and y
// de-interleaved into two lane values, and back, for up to a register's
// worth of points (fewer at the end of a run). The results come out through
// references: an aggregate of vector registers returned by value can end up
// in memory rather than in registers (measured on the pair loops).
#pragma once

#include "simd/lanes.hpp"

namespace sphfluid::simd {

#if SPHFLUID_AVX512
// The x and the y of eight interleaved points: lo holds points 0-3, hi 4-7.
SPHFLUID_INLINE __m512d x_of8(__m512d lo, __m512d hi) {
  return _mm512_permutex2var_pd(lo, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), hi);
}
SPHFLUID_INLINE __m512d y_of8(__m512d lo, __m512d hi) {
  return _mm512_permutex2var_pd(lo, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), hi);
}

// Up to eight points from some place: the mask of the points (lanes) and of
// the lo and hi halves of their 16 interleaved doubles.
struct Span8 {
  Mask8 lanes, lo, hi;
  SPHFLUID_INLINE explicit Span8(std::int64_t left) {
    const unsigned doubles = 2u * static_cast<unsigned>(left < 8 ? left : 8);
    lanes = first_lanes(left);
    lo = static_cast<Mask8>((1u << (doubles < 8 ? doubles : 8u)) - 1);
    hi = static_cast<Mask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
  }
};
// Up to four points: the mask of the points and of their 8 doubles.
struct Span4 {
  Mask8 lanes, doubles;
  SPHFLUID_INLINE explicit Span4(std::int64_t left) {
    const unsigned n = static_cast<unsigned>(left < 4 ? left : 4);
    lanes = static_cast<Mask8>((1u << n) - 1);
    doubles = static_cast<Mask8>((1u << (2 * n)) - 1);
  }
};
template <class L>
struct SpanOf;
template <>
struct SpanOf<D8> {
  using type = Span8;
};
template <>
struct SpanOf<D4> {
  using type = Span4;
};
template <class L>
using Span = typename SpanOf<L>::type;

// The span's points from p (interleaved doubles).
SPHFLUID_INLINE void load_xy(const double* p, const Span8& s, D8& x, D8& y) {
  asan_touch(p, s.lo);
  asan_touch(p + 8, s.hi);
  const __m512d a = _mm512_maskz_loadu_pd(s.lo, p), b = _mm512_maskz_loadu_pd(s.hi, p + 8);
  x = D8(x_of8(a, b));
  y = D8(y_of8(a, b));
}
// Eight points, all present.
SPHFLUID_INLINE void load_xy8(const double* p, D8& x, D8& y) {
  const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8);
  x = D8(x_of8(a, b));
  y = D8(y_of8(a, b));
}
// Up to eight points as their 16 interleaved doubles in two halves (lo:
// points 0-3, hi: 4-7), for arithmetic that treats x and y alike (the hi
// half's pointer kept inside the array when it holds no point).
SPHFLUID_INLINE void load_halves(const double* p, const Span8& s, D8& lo, D8& hi) {
  lo = D8::load(p, s.lo);
  hi = D8::load(s.hi ? p + 8 : p, s.hi);
}
SPHFLUID_INLINE void store_halves(double* p, const Span8& s, D8 lo, D8 hi) {
  lo.store(p, s.lo);
  hi.store(s.hi ? p + 8 : p, s.hi);
}
SPHFLUID_INLINE D8 x_of(D8 lo, D8 hi) { return D8(x_of8(lo.v, hi.v)); }
SPHFLUID_INLINE D8 y_of(D8 lo, D8 hi) { return D8(y_of8(lo.v, hi.v)); }
// Four interleaved points (x0, y0, ..., x3, y3) as (x0..x3, y0..y3), and back.
SPHFLUID_INLINE __m512d split4(__m512d xy) {
  return _mm512_permutexvar_pd(_mm512_setr_epi64(0, 2, 4, 6, 1, 3, 5, 7), xy);
}
SPHFLUID_INLINE __m512d join4(__m256d x, __m256d y) {
  return _mm512_permutexvar_pd(_mm512_setr_epi64(0, 4, 1, 5, 2, 6, 3, 7),
                               _mm512_insertf64x4(_mm512_castpd256_pd512(x), y, 1));
}
SPHFLUID_INLINE void load_xy(const double* p, const Span4& s, D4& x, D4& y) {
  asan_touch(p, s.doubles);
  const __m512d xy = split4(_mm512_maskz_loadu_pd(s.doubles, p));
  x = D4(_mm512_castpd512_pd256(xy));
  y = D4(_mm512_extractf64x4_pd(xy, 1));
}

// out (the span's points, interleaved) += (x, y).
SPHFLUID_INLINE void add_xy(double* out, const Span8& s, D8 x, D8 y) {
  const __m512i lo_xy = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i hi_xy = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512d lo = _mm512_permutex2var_pd(x.v, lo_xy, y.v);
  const __m512d hi = _mm512_permutex2var_pd(x.v, hi_xy, y.v);
  asan_touch(out, s.lo);
  asan_touch(out + 8, s.hi);
  _mm512_mask_storeu_pd(out, s.lo, _mm512_add_pd(_mm512_maskz_loadu_pd(s.lo, out), lo));
  _mm512_mask_storeu_pd(out + 8, s.hi, _mm512_add_pd(_mm512_maskz_loadu_pd(s.hi, out + 8), hi));
}
SPHFLUID_INLINE void add_xy(double* out, const Span4& s, D4 x, D4 y) {
  asan_touch(out, s.doubles);
  _mm512_mask_storeu_pd(out, s.doubles,
                        _mm512_add_pd(_mm512_maskz_loadu_pd(s.doubles, out), join4(x.v, y.v)));
}

// The lane sums of eight vectors a..h at once, as (a, e, b, f, c, g, d, h):
// each vector's lanes paired as _mm512_reduce_add_pd pairs them (l + (l + 4),
// then those two apart, then the last two), so each sum has the same bits.
SPHFLUID_INLINE __m512d sum8(__m512d a, __m512d b, __m512d c, __m512d d, __m512d e, __m512d f,
                             __m512d g, __m512d h) {
  auto halves = [](__m512d u, __m512d v) {  // (u0 + u4, .., u3 + u7, v0 + v4, ..)
    return _mm512_add_pd(_mm512_shuffle_f64x2(u, v, 0x44), _mm512_shuffle_f64x2(u, v, 0xEE));
  };
  auto quarters = [](__m512d u, __m512d v) {  // (u0 + u2, u1 + u3, u4 + u6, u5 + u7, v..)
    return _mm512_add_pd(_mm512_shuffle_f64x2(u, v, 0x88), _mm512_shuffle_f64x2(u, v, 0xDD));
  };
  const __m512d abcd = quarters(halves(a, b), halves(c, d));
  const __m512d efgh = quarters(halves(e, f), halves(g, h));
  return _mm512_add_pd(_mm512_unpacklo_pd(abcd, efgh), _mm512_unpackhi_pd(abcd, efgh));
}
// k (at most 4) points from out (interleaved) get scale times the lane sums
// of sx[q], sy[q], in one vector.
SPHFLUID_INLINE void add_lane_sums4(double* out, int k, const D8 (&sx)[4], const D8 (&sy)[4],
                                    D8 scale) {
  const __m512d sums =
      sum8(sx[0].v, sx[1].v, sx[2].v, sx[3].v, sy[0].v, sy[1].v, sy[2].v, sy[3].v);
  const __mmask8 mine = static_cast<__mmask8>((1u << (2 * k)) - 1);
  asan_touch(out, mine);
  _mm512_mask_storeu_pd(out, mine, _mm512_fmadd_pd(scale.v, sums, _mm512_maskz_loadu_pd(mine, out)));
}
#endif  // SPHFLUID_AVX512

}  // namespace sphfluid::simd
