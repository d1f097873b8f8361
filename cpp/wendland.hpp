// The Wendland C2 kernel in 2D with support h (the wcsph method's kernel):
// W = 7/(pi h^2) (1 - q)^4 (1 + 4q), q = r/h < 1, with its gradient and Laplacian.
#pragma once

#include <cmath>
#include <vector>

#include "types.hpp"

namespace sphfluid {

struct Wendland {
  Real h, h2, inv_h;
  Real w, grad, lap;  // 7/(pi h^2), -140/(pi h^4), -140/(pi h^4)
  // Wall integrals of W at distance d from a straight wall, tabulated on
  // kTable + 1 points of d in [0, h]: line(d) = int W(sqrt(x^2 + d^2)) dx along
  // the wall, half(d) = int over the half-plane beyond the wall of W dA.
  static constexpr int kTable = 256;
  std::vector<Real> line_, half_;

  explicit Wendland(Real h_)
      : h(h_), h2(h_ * h_), inv_h(1 / h_), w(7 / (kPi * h_ * h_)),
        grad(-140 / (kPi * h_ * h_ * h_ * h_)), lap(-140 / (kPi * h_ * h_ * h_ * h_)) {}

  void build_wall_tables() {
    line_.assign(kTable + 1, 0);
    half_.assign(kTable + 1, 0);
    const int nx = 400;
    for (int k = 0; k <= kTable; ++k) {
      const Real d = h * k / kTable, reach = std::sqrt(std::max(h2 - d * d, Real(0)));
      Real sum = 0;  // midpoint rule along the wall
      for (int i = 0; i < nx; ++i) {
        const Real x = -reach + (i + Real(0.5)) * 2 * reach / nx;
        sum += value(std::sqrt(x * x + d * d));
      }
      line_[k] = sum * 2 * reach / nx;
    }
    // half(d) = int_d^h line(y) dy, by the trapezoid rule from the far end.
    for (int k = kTable - 1; k >= 0; --k)
      half_[k] = half_[k + 1] + Real(0.5) * (line_[k] + line_[k + 1]) * h / kTable;
  }
  Real table(const std::vector<Real>& t, Real d) const {
    const Real f = d * inv_h * kTable;
    if (f >= kTable) return 0;
    const int k = static_cast<int>(f);
    return t[k] + (f - k) * (t[k + 1] - t[k]);
  }
  Real wall_line(Real d) const { return table(line_, d); }

  // W as a function of r^2, for the shared density pass.
  struct OfR2 {
    const Wendland* k;
    Real operator()(Real r2) const { return k->value(std::sqrt(r2)); }
  };
  Real wall_half(Real d) const { return table(half_, d); }

  Real value(Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return 0;
    const Real a = 1 - q, a2 = a * a;
    return w * a2 * a2 * (1 + 4 * q);
  }
  // grad W = -140/(pi h^4) (1 - q)^3 r_ij: no division by r, finite at r = 0.
  Vec2 gradient(const Vec2& r_ij, Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return Vec2::Zero();
    const Real a = 1 - q;
    return (grad * a * a * a) * r_ij;
  }
  // lap W = W'' + W'/r = -140/(pi h^4) (1 - q)^2 (2 - 5q)
  Real laplacian(Real r) const {
    const Real q = r * inv_h;
    if (q >= 1) return 0;
    const Real a = 1 - q;
    return lap * a * a * (2 - 5 * q);
  }
};

}  // namespace sphfluid
