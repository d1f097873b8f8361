// Scalar, vector and index aliases shared by the whole core.
// Real is the one switch between float and double; Vec2 is an Eigen 2-vector.
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace sphfluid {

using Real = double;
using Vec2 = Eigen::Matrix<Real, 2, 1>;
using Index = std::int32_t;  // particle and cell indices (storage order)
using Id = std::int64_t;     // stable particle identity

constexpr Real kPi = Real(3.14159265358979323846);

}  // namespace sphfluid
