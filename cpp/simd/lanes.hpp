// The lane types: the only place that names SIMD intrinsics. A term written
// once against this interface runs on one scalar (double or float), on eight
// doubles (D8), four doubles (D4) or eight floats (F8) of AVX-512 registers.
// Reads and writes nothing of the solver: values in, values out.
//
// Every lane type L has the same free functions: arithmetic operators,
// fmadd(a, b, c) = a b + c, fnmadd(a, b, c) = c - a b, sqrt, max, min,
// masked forms (maskz: zero off the mask; mask_*: the first operand off it),
// comparisons that return a Mask<L> (restricted to a `live` mask), and
// reductions. On scalars the mask is a bool and fmadd is written a * b + c
// (the compiler contracts it where the target has FMA, as for any scalar
// code).
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>

#if defined(__AVX512F__) && defined(__AVX512VL__)
#include <immintrin.h>
#define SPHFLUID_AVX512 1
#else
#define SPHFLUID_AVX512 0
#endif

#define SPHFLUID_INLINE inline __attribute__((always_inline))

namespace sphfluid::simd {

// ---------------------------------------------------------------- scalars
// A scalar is a lane type of one lane, its mask a bool.
template <class L>
struct Traits {
  using Scalar = L;
  using Mask = bool;
  static constexpr int kLanes = 1;
};

template <class L>
using Mask = typename Traits<L>::Mask;
template <class L>
using ScalarOf = typename Traits<L>::Scalar;
template <class L>
constexpr int kLanes = Traits<L>::kLanes;

template <class L>
SPHFLUID_INLINE L splat(ScalarOf<L> x) {
  if constexpr (kLanes<L> == 1) {
    return x;
  } else {
    return L::splat(x);
  }
}
template <class L>
SPHFLUID_INLINE L zero() {
  return splat<L>(ScalarOf<L>(0));
}
// The lanes of m from p on (zero elsewhere).
template <class L>
SPHFLUID_INLINE L load(const ScalarOf<L>* p, Mask<L> m) {
  if constexpr (kLanes<L> == 1) {
    return m ? *p : L(0);
  } else {
    return L::load(p, m);
  }
}

// The same operations on one scalar lane (double or float).
template <class T>
using IfScalar = std::enable_if_t<std::is_floating_point_v<T>, T>;
template <class T>
SPHFLUID_INLINE IfScalar<T> fmadd(T a, T b, T c) { return a * b + c; }
template <class T>
SPHFLUID_INLINE IfScalar<T> fnmadd(T a, T b, T c) { return c - a * b; }
template <class T>
SPHFLUID_INLINE IfScalar<T> fmsub(T a, T b, T c) { return a * b - c; }
template <class T>
SPHFLUID_INLINE IfScalar<T> sqrt(T a) { return std::sqrt(a); }
// max and min as AVX-512's: the second operand where either is NaN.
template <class T>
SPHFLUID_INLINE IfScalar<T> max(T a, T b) { return a > b ? a : b; }
template <class T>
SPHFLUID_INLINE IfScalar<T> min(T a, T b) { return a < b ? a : b; }
template <class T, class = IfScalar<T>>
SPHFLUID_INLINE bool lt(bool live, T a, T b) { return live && a < b; }
template <class T, class = IfScalar<T>>
SPHFLUID_INLINE bool gt(bool live, T a, T b) { return live && a > b; }
template <class T>
SPHFLUID_INLINE IfScalar<T> maskz(bool m, T a) { return m ? a : T(0); }
template <class T>
SPHFLUID_INLINE IfScalar<T> maskz_mul(bool m, T a, T b) { return m ? a * b : T(0); }
template <class T>
SPHFLUID_INLINE IfScalar<T> maskz_div(bool m, T a, T b) { return m ? a / b : T(0); }
template <class T>
SPHFLUID_INLINE IfScalar<T> maskz_fnmadd(bool m, T a, T b, T c) { return m ? c - a * b : T(0); }
template <class T>
SPHFLUID_INLINE IfScalar<T> mask_fmadd(T a, bool m, T b, T c) { return m ? a * b + c : a; }
template <class T>
SPHFLUID_INLINE IfScalar<T> mask3_fmadd(T a, T b, T c, bool m) { return m ? a * b + c : c; }
template <class T>
SPHFLUID_INLINE IfScalar<T> mask_add(T s, bool m, T a, T b) { return m ? a + b : s; }
template <class T>
SPHFLUID_INLINE IfScalar<T> mask_sub(T s, bool m, T a, T b) { return m ? a - b : s; }
template <class T>
SPHFLUID_INLINE IfScalar<T> reduce_add(T a) { return a; }

SPHFLUID_INLINE bool any(bool m) { return m; }

// 1/sqrt(r2) from a fast estimate and Newton steps: only eight doubles of
// AVX-512 have it (below); declared here so that terms may name it.
template <class L>
L recip_sqrt(Mask<L> m, L r2, int steps);

// A mask of up to eight lanes, one bit a lane (AVX-512's __mmask8).
using Mask8 = unsigned char;

// A mask of `Lanes` lanes as an integer whose bits above them are clear, for
// counting or looping over its set bits. GCC 12.2 (-O3 -march=native, LTO)
// has spilled a 16-lane compare's mask with `kmovw %k0, mem` and read the
// slot back as 32 bits (`mov`, `tzcnt` from memory), so bits 16-31 held stale
// stack bytes and Csr::for_each_nonempty_row met rows i + 16 .. i + 31 from
// the group at i: rows it meets again, or another thread's (a race), or
// past the last (a read out of bounds). Beside a moving wall wcsph on 2
// threads was not repeatable, the walls' terms added twice to some rows.
// The empty asm hands over the value in a register the compiler cannot see
// into, so the AND after it stays.
// tests/test_machine_code.py scans the built cores for the pattern.
template <int Lanes>
SPHFLUID_INLINE unsigned lane_bits(unsigned m) {
  static_assert(Lanes > 0 && Lanes < 32, "a shift by 32 or more is undefined");
  asm("" : "+r"(m));
  return m & ((1u << Lanes) - 1u);
}

SPHFLUID_INLINE bool any(Mask8 m) { return m != 0; }
SPHFLUID_INLINE int count(Mask8 m) { return __builtin_popcount(lane_bits<8>(m)); }
// The first `n` of eight lanes (n may be negative or over 8).
SPHFLUID_INLINE Mask8 first_lanes(std::int64_t n) {
  const unsigned k = static_cast<unsigned>(n < 0 ? 0 : n > 8 ? 8 : n);  // (no branch)
  return static_cast<Mask8>((1u << k) - 1);
}

// Under AddressSanitizer, a masked load or store (and a gather) first reads
// each element on its mask with a plain load, which ASan checks: it does not
// see into the masked instructions, and an access past an array's end would
// otherwise go unreported. Nothing in other builds.
#if defined(__SANITIZE_ADDRESS__)
template <class T>
inline void asan_touch(const T* p, unsigned mask) {
  for (int k = 0; mask != 0; ++k, mask >>= 1)
    if (mask & 1u) (void)*static_cast<const volatile T*>(p + k);
}
#else
template <class T>
SPHFLUID_INLINE void asan_touch(const T*, unsigned) {}
#endif

#if SPHFLUID_AVX512
// ------------------------------------------------------- AVX-512 registers
static_assert(std::is_same_v<Mask8, __mmask8>, "a lane mask is AVX-512's");

// The three register types share one set of operations, each a table of the
// intrinsics of its width and element type (Ops), wrapped by Pack.
struct D8Ops {
  using V = __m512d;
  using T = double;
  static V set1(T x) { return _mm512_set1_pd(x); }
  static V add(V a, V b) { return _mm512_add_pd(a, b); }
  static V sub(V a, V b) { return _mm512_sub_pd(a, b); }
  static V mul(V a, V b) { return _mm512_mul_pd(a, b); }
  static V div(V a, V b) { return _mm512_div_pd(a, b); }
  static V fmadd(V a, V b, V c) { return _mm512_fmadd_pd(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm512_fnmadd_pd(a, b, c); }
  static V fmsub(V a, V b, V c) { return _mm512_fmsub_pd(a, b, c); }
  static V sqrt(V a) { return _mm512_sqrt_pd(a); }
  static V max(V a, V b) { return _mm512_max_pd(a, b); }
  static V min(V a, V b) { return _mm512_min_pd(a, b); }
  static Mask8 lt(Mask8 m, V a, V b) { return _mm512_mask_cmp_pd_mask(m, a, b, _CMP_LT_OQ); }
  static Mask8 le(Mask8 m, V a, V b) { return _mm512_mask_cmp_pd_mask(m, a, b, _CMP_LE_OQ); }
  static Mask8 gt(Mask8 m, V a, V b) { return _mm512_mask_cmp_pd_mask(m, a, b, _CMP_GT_OQ); }
  static Mask8 ge(Mask8 m, V a, V b) { return _mm512_mask_cmp_pd_mask(m, a, b, _CMP_GE_OQ); }
  static Mask8 eq(Mask8 m, V a, V b) { return _mm512_mask_cmp_pd_mask(m, a, b, _CMP_EQ_OQ); }
  static V maskz_mov(Mask8 m, V a) { return _mm512_maskz_mov_pd(m, a); }
  static V maskz_mul(Mask8 m, V a, V b) { return _mm512_maskz_mul_pd(m, a, b); }
  static V maskz_div(Mask8 m, V a, V b) { return _mm512_maskz_div_pd(m, a, b); }
  static V maskz_fnmadd(Mask8 m, V a, V b, V c) { return _mm512_maskz_fnmadd_pd(m, a, b, c); }
  static V mask_fmadd(V a, Mask8 m, V b, V c) { return _mm512_mask_fmadd_pd(a, m, b, c); }
  static V mask3_fmadd(V a, V b, V c, Mask8 m) { return _mm512_mask3_fmadd_pd(a, b, c, m); }
  static V mask_add(V s, Mask8 m, V a, V b) { return _mm512_mask_add_pd(s, m, a, b); }
  static V mask_sub(V s, Mask8 m, V a, V b) { return _mm512_mask_sub_pd(s, m, a, b); }
  static V mask_min(V s, Mask8 m, V a, V b) { return _mm512_mask_min_pd(s, m, a, b); }
  static V mask_max(V s, Mask8 m, V a, V b) { return _mm512_mask_max_pd(s, m, a, b); }
  static V load(const T* p, Mask8 m) {
    asan_touch(p, m);
    return _mm512_maskz_loadu_pd(m, p);
  }
  static V loadu(const T* p) { return _mm512_loadu_pd(p); }
  static void store(T* p, Mask8 m, V a) {
    asan_touch(p, m);
    _mm512_mask_storeu_pd(p, m, a);
  }
  static T reduce_add(V a) { return _mm512_reduce_add_pd(a); }
  static T reduce_min(V a) { return _mm512_reduce_min_pd(a); }
  static T reduce_max(V a) { return _mm512_reduce_max_pd(a); }
};

struct D4Ops {
  using V = __m256d;
  using T = double;
  static V set1(T x) { return _mm256_set1_pd(x); }
  static V add(V a, V b) { return _mm256_add_pd(a, b); }
  static V sub(V a, V b) { return _mm256_sub_pd(a, b); }
  static V mul(V a, V b) { return _mm256_mul_pd(a, b); }
  static V div(V a, V b) { return _mm256_div_pd(a, b); }
  static V fmadd(V a, V b, V c) { return _mm256_fmadd_pd(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm256_fnmadd_pd(a, b, c); }
  static V fmsub(V a, V b, V c) { return _mm256_fmsub_pd(a, b, c); }
  static V sqrt(V a) { return _mm256_sqrt_pd(a); }
  static V max(V a, V b) { return _mm256_max_pd(a, b); }
  static V min(V a, V b) { return _mm256_min_pd(a, b); }
  static Mask8 lt(Mask8 m, V a, V b) { return _mm256_mask_cmp_pd_mask(m, a, b, _CMP_LT_OQ); }
  static Mask8 le(Mask8 m, V a, V b) { return _mm256_mask_cmp_pd_mask(m, a, b, _CMP_LE_OQ); }
  static Mask8 gt(Mask8 m, V a, V b) { return _mm256_mask_cmp_pd_mask(m, a, b, _CMP_GT_OQ); }
  static Mask8 ge(Mask8 m, V a, V b) { return _mm256_mask_cmp_pd_mask(m, a, b, _CMP_GE_OQ); }
  static Mask8 eq(Mask8 m, V a, V b) { return _mm256_mask_cmp_pd_mask(m, a, b, _CMP_EQ_OQ); }
  static V maskz_mov(Mask8 m, V a) { return _mm256_maskz_mov_pd(m, a); }
  static V maskz_mul(Mask8 m, V a, V b) { return _mm256_maskz_mul_pd(m, a, b); }
  static V maskz_div(Mask8 m, V a, V b) { return _mm256_maskz_div_pd(m, a, b); }
  static V maskz_fnmadd(Mask8 m, V a, V b, V c) { return _mm256_maskz_fnmadd_pd(m, a, b, c); }
  static V mask_fmadd(V a, Mask8 m, V b, V c) { return _mm256_mask_fmadd_pd(a, m, b, c); }
  static V mask3_fmadd(V a, V b, V c, Mask8 m) { return _mm256_mask3_fmadd_pd(a, b, c, m); }
  static V mask_add(V s, Mask8 m, V a, V b) { return _mm256_mask_add_pd(s, m, a, b); }
  static V mask_sub(V s, Mask8 m, V a, V b) { return _mm256_mask_sub_pd(s, m, a, b); }
  static V mask_min(V s, Mask8 m, V a, V b) { return _mm256_mask_min_pd(s, m, a, b); }
  static V mask_max(V s, Mask8 m, V a, V b) { return _mm256_mask_max_pd(s, m, a, b); }
  static V load(const T* p, Mask8 m) {
    asan_touch(p, m);
    return _mm256_maskz_loadu_pd(m, p);
  }
  static V loadu(const T* p) { return _mm256_loadu_pd(p); }
  static void store(T* p, Mask8 m, V a) {
    asan_touch(p, m);
    _mm256_mask_storeu_pd(p, m, a);
  }
  static T reduce_add(V a) {  // (l0 + l2) + (l1 + l3)
    const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(a), _mm256_extractf128_pd(a, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
  }
};

struct F8Ops {
  using V = __m256;
  using T = float;
  static V set1(T x) { return _mm256_set1_ps(x); }
  static V add(V a, V b) { return _mm256_add_ps(a, b); }
  static V sub(V a, V b) { return _mm256_sub_ps(a, b); }
  static V mul(V a, V b) { return _mm256_mul_ps(a, b); }
  static V div(V a, V b) { return _mm256_div_ps(a, b); }
  static V fmadd(V a, V b, V c) { return _mm256_fmadd_ps(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm256_fnmadd_ps(a, b, c); }
  static V fmsub(V a, V b, V c) { return _mm256_fmsub_ps(a, b, c); }
  static V sqrt(V a) { return _mm256_sqrt_ps(a); }
  static V max(V a, V b) { return _mm256_max_ps(a, b); }
  static V min(V a, V b) { return _mm256_min_ps(a, b); }
  static Mask8 lt(Mask8 m, V a, V b) { return _mm256_mask_cmp_ps_mask(m, a, b, _CMP_LT_OQ); }
  static Mask8 le(Mask8 m, V a, V b) { return _mm256_mask_cmp_ps_mask(m, a, b, _CMP_LE_OQ); }
  static Mask8 gt(Mask8 m, V a, V b) { return _mm256_mask_cmp_ps_mask(m, a, b, _CMP_GT_OQ); }
  static Mask8 ge(Mask8 m, V a, V b) { return _mm256_mask_cmp_ps_mask(m, a, b, _CMP_GE_OQ); }
  static Mask8 eq(Mask8 m, V a, V b) { return _mm256_mask_cmp_ps_mask(m, a, b, _CMP_EQ_OQ); }
  static V maskz_mov(Mask8 m, V a) { return _mm256_maskz_mov_ps(m, a); }
  static V maskz_mul(Mask8 m, V a, V b) { return _mm256_maskz_mul_ps(m, a, b); }
  static V maskz_div(Mask8 m, V a, V b) { return _mm256_maskz_div_ps(m, a, b); }
  static V maskz_fnmadd(Mask8 m, V a, V b, V c) { return _mm256_maskz_fnmadd_ps(m, a, b, c); }
  static V mask_fmadd(V a, Mask8 m, V b, V c) { return _mm256_mask_fmadd_ps(a, m, b, c); }
  static V mask3_fmadd(V a, V b, V c, Mask8 m) { return _mm256_mask3_fmadd_ps(a, b, c, m); }
  static V mask_add(V s, Mask8 m, V a, V b) { return _mm256_mask_add_ps(s, m, a, b); }
  static V mask_sub(V s, Mask8 m, V a, V b) { return _mm256_mask_sub_ps(s, m, a, b); }
  static V mask_min(V s, Mask8 m, V a, V b) { return _mm256_mask_min_ps(s, m, a, b); }
  static V mask_max(V s, Mask8 m, V a, V b) { return _mm256_mask_max_ps(s, m, a, b); }
  static V load(const T* p, Mask8 m) {
    asan_touch(p, m);
    return _mm256_maskz_loadu_ps(m, p);
  }
  static V loadu(const T* p) { return _mm256_loadu_ps(p); }
  static void store(T* p, Mask8 m, V a) {
    asan_touch(p, m);
    _mm256_mask_storeu_ps(p, m, a);
  }
};

template <class Ops>
struct Pack {
  using V = typename Ops::V;
  using T = typename Ops::T;
  V v;
  Pack() = default;
  SPHFLUID_INLINE explicit Pack(V x) : v(x) {}
  SPHFLUID_INLINE static Pack splat(T x) { return Pack(Ops::set1(x)); }
  SPHFLUID_INLINE static Pack load(const T* p, Mask8 m) { return Pack(Ops::load(p, m)); }
  SPHFLUID_INLINE static Pack loadu(const T* p) { return Pack(Ops::loadu(p)); }
  SPHFLUID_INLINE void store(T* p, Mask8 m) const { Ops::store(p, m, v); }
  SPHFLUID_INLINE Pack& operator+=(Pack b) { return *this = Pack(Ops::add(v, b.v)); }
  SPHFLUID_INLINE Pack& operator-=(Pack b) { return *this = Pack(Ops::sub(v, b.v)); }
  SPHFLUID_INLINE friend Pack operator+(Pack a, Pack b) { return Pack(Ops::add(a.v, b.v)); }
  SPHFLUID_INLINE friend Pack operator-(Pack a, Pack b) { return Pack(Ops::sub(a.v, b.v)); }
  SPHFLUID_INLINE friend Pack operator*(Pack a, Pack b) { return Pack(Ops::mul(a.v, b.v)); }
  SPHFLUID_INLINE friend Pack operator/(Pack a, Pack b) { return Pack(Ops::div(a.v, b.v)); }
};

template <class Ops>
SPHFLUID_INLINE Pack<Ops> fmadd(Pack<Ops> a, Pack<Ops> b, Pack<Ops> c) {
  return Pack<Ops>(Ops::fmadd(a.v, b.v, c.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> fnmadd(Pack<Ops> a, Pack<Ops> b, Pack<Ops> c) {
  return Pack<Ops>(Ops::fnmadd(a.v, b.v, c.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> fmsub(Pack<Ops> a, Pack<Ops> b, Pack<Ops> c) {
  return Pack<Ops>(Ops::fmsub(a.v, b.v, c.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> sqrt(Pack<Ops> a) { return Pack<Ops>(Ops::sqrt(a.v)); }
template <class Ops>
SPHFLUID_INLINE Pack<Ops> max(Pack<Ops> a, Pack<Ops> b) { return Pack<Ops>(Ops::max(a.v, b.v)); }
template <class Ops>
SPHFLUID_INLINE Pack<Ops> min(Pack<Ops> a, Pack<Ops> b) { return Pack<Ops>(Ops::min(a.v, b.v)); }
template <class Ops>
SPHFLUID_INLINE Mask8 lt(Mask8 m, Pack<Ops> a, Pack<Ops> b) { return Ops::lt(m, a.v, b.v); }
template <class Ops>
SPHFLUID_INLINE Mask8 le(Mask8 m, Pack<Ops> a, Pack<Ops> b) { return Ops::le(m, a.v, b.v); }
template <class Ops>
SPHFLUID_INLINE Mask8 gt(Mask8 m, Pack<Ops> a, Pack<Ops> b) { return Ops::gt(m, a.v, b.v); }
template <class Ops>
SPHFLUID_INLINE Mask8 ge(Mask8 m, Pack<Ops> a, Pack<Ops> b) { return Ops::ge(m, a.v, b.v); }
template <class Ops>
SPHFLUID_INLINE Mask8 eq(Mask8 m, Pack<Ops> a, Pack<Ops> b) { return Ops::eq(m, a.v, b.v); }
template <class Ops>
SPHFLUID_INLINE Pack<Ops> maskz(Mask8 m, Pack<Ops> a) { return Pack<Ops>(Ops::maskz_mov(m, a.v)); }
template <class Ops>
SPHFLUID_INLINE Pack<Ops> maskz_mul(Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::maskz_mul(m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> maskz_div(Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::maskz_div(m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> maskz_fnmadd(Mask8 m, Pack<Ops> a, Pack<Ops> b, Pack<Ops> c) {
  return Pack<Ops>(Ops::maskz_fnmadd(m, a.v, b.v, c.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask_fmadd(Pack<Ops> a, Mask8 m, Pack<Ops> b, Pack<Ops> c) {
  return Pack<Ops>(Ops::mask_fmadd(a.v, m, b.v, c.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask3_fmadd(Pack<Ops> a, Pack<Ops> b, Pack<Ops> c, Mask8 m) {
  return Pack<Ops>(Ops::mask3_fmadd(a.v, b.v, c.v, m));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask_add(Pack<Ops> s, Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::mask_add(s.v, m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask_sub(Pack<Ops> s, Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::mask_sub(s.v, m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask_min(Pack<Ops> s, Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::mask_min(s.v, m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE Pack<Ops> mask_max(Pack<Ops> s, Mask8 m, Pack<Ops> a, Pack<Ops> b) {
  return Pack<Ops>(Ops::mask_max(s.v, m, a.v, b.v));
}
template <class Ops>
SPHFLUID_INLINE typename Ops::T reduce_add(Pack<Ops> a) { return Ops::reduce_add(a.v); }

using D8 = Pack<D8Ops>;  // eight doubles (512 bits)
using D4 = Pack<D4Ops>;  // four doubles (256 bits, AVX-512VL masks)
using F8 = Pack<F8Ops>;  // eight floats (256 bits, AVX-512VL masks)

template <class Ops>
struct Traits<Pack<Ops>> {
  using Scalar = typename Ops::T;
  using Mask = Mask8;
  static constexpr int kLanes = static_cast<int>(sizeof(typename Ops::V) / sizeof(typename Ops::T));
};

// 0, 1, ..., 7.
SPHFLUID_INLINE D8 iota8() { return D8(_mm512_setr_pd(0, 1, 2, 3, 4, 5, 6, 7)); }
SPHFLUID_INLINE double reduce_min(D8 a) { return D8Ops::reduce_min(a.v); }
SPHFLUID_INLINE double reduce_max(D8 a) { return D8Ops::reduce_max(a.v); }

// The lanes where a is finite (a - a is 0 unless a is inf or NaN).
SPHFLUID_INLINE Mask8 finite(D8 a) {
  return _mm512_cmp_pd_mask(_mm512_sub_pd(a.v, a.v), _mm512_setzero_pd(), _CMP_EQ_OQ);
}

// 1/sqrt(r2) on the lanes of m (0 elsewhere): 14 bits from rsqrt14, then
// `steps` Newton steps y (3 - r2 y^2) / 2.
SPHFLUID_INLINE D8 recip_sqrt(Mask8 m, D8 r2, int steps) {
  const __m512d half_r2 = _mm512_mul_pd(_mm512_set1_pd(0.5), r2.v);
  const __m512d three_halves = _mm512_set1_pd(1.5);
  __m512d y = _mm512_maskz_rsqrt14_pd(m, r2.v);
  for (int step = 0; step < steps; ++step)
    y = _mm512_mul_pd(y, _mm512_fnmadd_pd(_mm512_mul_pd(half_r2, y), y, three_halves));
  return D8(y);
}

// Float lanes widened to double.
SPHFLUID_INLINE D8 widen(F8 a) { return D8(_mm512_cvtps_pd(a.v)); }
// Doubles narrowed to float (round to nearest).
SPHFLUID_INLINE F8 narrow(D8 a) { return F8(_mm512_cvtpd_ps(a.v)); }
#endif  // SPHFLUID_AVX512

}  // namespace sphfluid::simd
