// Integer lanes (eight or sixteen 32-bit indices) for the neighbour search and
// the walls' lookup grids: cell indices computed from coordinates, lists of
// hits compressed from a mask, lookups by gather, and whole runs of indices
// compared at once. Only on AVX-512 builds; the callers keep a scalar loop.
#pragma once

#include <cstdint>

#include "simd/lanes.hpp"

namespace sphfluid::simd {

#if SPHFLUID_AVX512
using Mask16 = __mmask16;

// Eight 32-bit integers.
struct I8 {
  __m256i v;
  I8() = default;
  SPHFLUID_INLINE explicit I8(__m256i x) : v(x) {}
  SPHFLUID_INLINE static I8 splat(std::int32_t x) { return I8(_mm256_set1_epi32(x)); }
  SPHFLUID_INLINE static I8 iota() { return I8(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)); }
  SPHFLUID_INLINE static I8 load(const std::int32_t* p, Mask8 m) {
    asan_touch(p, m);
    return I8(_mm256_maskz_loadu_epi32(m, p));
  }
  SPHFLUID_INLINE void store(std::int32_t* p) const {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v);
  }
  SPHFLUID_INLINE void store(std::int32_t* p, Mask8 m) const {
    asan_touch(p, m);
    _mm256_mask_storeu_epi32(p, m, v);
  }
  SPHFLUID_INLINE friend I8 operator+(I8 a, I8 b) { return I8(_mm256_add_epi32(a.v, b.v)); }
  SPHFLUID_INLINE friend I8 operator*(I8 a, I8 b) { return I8(_mm256_mullo_epi32(a.v, b.v)); }
  SPHFLUID_INLINE friend I8 max(I8 a, I8 b) { return I8(_mm256_max_epi32(a.v, b.v)); }
  SPHFLUID_INLINE friend I8 min(I8 a, I8 b) { return I8(_mm256_min_epi32(a.v, b.v)); }
  // The lanes of m packed to the front, in order (the rest zero).
  SPHFLUID_INLINE friend I8 compress(Mask8 m, I8 a) {
    return I8(_mm256_maskz_compress_epi32(m, a.v));
  }
  SPHFLUID_INLINE friend Mask8 neq(Mask8 m, I8 a, I8 b) {
    return _mm256_mask_cmpneq_epi32_mask(m, a.v, b.v);
  }
  SPHFLUID_INLINE friend Mask8 eq(I8 a, I8 b) { return _mm256_cmpeq_epi32_mask(a.v, b.v); }
  SPHFLUID_INLINE friend Mask8 lt(I8 a, I8 b) { return _mm256_cmplt_epi32_mask(a.v, b.v); }
  SPHFLUID_INLINE friend Mask8 ge(I8 a, I8 b) { return _mm256_cmpge_epi32_mask(a.v, b.v); }
  SPHFLUID_INLINE friend Mask8 nonzero(I8 a) { return _mm256_test_epi32_mask(a.v, a.v); }
};

// Doubles truncated towards zero (on the lanes of m; zero elsewhere).
SPHFLUID_INLINE I8 truncate(D8 a) { return I8(_mm512_cvttpd_epi32(a.v)); }
SPHFLUID_INLINE I8 truncate(Mask8 m, D8 a) { return I8(_mm512_maskz_cvttpd_epi32(m, a.v)); }
SPHFLUID_INLINE D8 to_double(I8 a) { return D8(_mm512_cvtepi32_pd(a.v)); }
// base[index] on the lanes of m (zero elsewhere).
SPHFLUID_INLINE I8 gather(Mask8 m, I8 index, const std::int32_t* base) {
#if defined(__SANITIZE_ADDRESS__)
  alignas(32) std::int32_t at[8];
  index.store(at);
  for (int k = 0; k < 8; ++k)
    if ((m >> k) & 1u) asan_touch(base + at[k], 1u);
#endif
  return I8(_mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), m, index.v, base, 4));
}

// The lanes where a[k] != b[k], for sixteen consecutive entries of each.
// (lane_bits: a loop over its set bits must never see bits above the sixteen)
SPHFLUID_INLINE unsigned differ16(const std::int32_t* a, const std::int32_t* b) {
  return lane_bits<16>(
      _cvtmask16_u32(_mm512_cmpneq_epi32_mask(_mm512_loadu_si512(a), _mm512_loadu_si512(b))));
}

// Eight floats all set to x, stored at p.
SPHFLUID_INLINE void fill8(float* p, float x) { _mm256_storeu_ps(p, _mm256_set1_ps(x)); }
#endif  // SPHFLUID_AVX512

}  // namespace sphfluid::simd
