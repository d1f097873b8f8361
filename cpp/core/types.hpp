// Scalar, vector and index aliases shared by the whole core.
// Real is the one switch between float and double; Vec2 is an Eigen 2-vector.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>

#include "simd/lanes.hpp"

namespace sphfluid {

using Real = double;
using Vec2 = Eigen::Matrix<Real, 2, 1>;
using Index = std::int32_t;  // particle and cell indices (storage order)
using Id = std::int64_t;     // stable particle identity

// A cell index from a coordinate measured in cells: clamped to [0, last]
// while still a Real (a NaN goes to 0), so the conversion to an integer is
// defined for any coordinate; within range it truncates as a cast does.
inline Index clamp_cell(Real t, Index last) {
  return static_cast<Index>(std::fmin(std::fmax(t, Real(0)), static_cast<Real>(last)));
}

constexpr Real kPi = Real(3.14159265358979323846);

// Whether the eight-lane loops run (simd/: AVX-512F and VL): built for a CPU
// that has them, with Real = double and Vec2 two packed doubles (the lanes
// read the particle arrays as interleaved doubles).
constexpr bool kVector8 = SPHFLUID_AVX512 && sizeof(Real) == sizeof(double) &&
                          sizeof(Vec2) == 2 * sizeof(double);

}  // namespace sphfluid
