// Scalar, vector and index aliases shared by the whole core.
// Real is the one switch between float and double; Vec2 is an Eigen 2-vector.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace sphfluid {

using Real = double;
using Vec2 = Eigen::Matrix<Real, 2, 1>;
using Index = std::int32_t;  // particle and cell indices (storage order)
using Id = std::int64_t;     // stable particle identity

constexpr Real kPi = Real(3.14159265358979323846);

// Whether the hand-written AVX-512 loops run (the neighbour filter; the cell
// clusters, which need VL too): built for a CPU that has it, with Real =
// double and Vec2 two packed doubles.
#if defined(__AVX512F__)
constexpr bool kVector8 = sizeof(Real) == sizeof(double) && sizeof(Vec2) == 2 * sizeof(double);

// The x and the y of eight interleaved points (x0, y0, x1, y1, ...): lo holds
// points 0-3, hi points 4-7.
inline __m512d x_of8(__m512d lo, __m512d hi) {
  return _mm512_permutex2var_pd(lo, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), hi);
}
inline __m512d y_of8(__m512d lo, __m512d hi) {
  return _mm512_permutex2var_pd(lo, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), hi);
}
#else
constexpr bool kVector8 = false;
#endif

}  // namespace sphfluid
