// The Wendland C2 kernel in 2D with support h (the wcsph method's kernel):
// W = 7/(pi h^2) (1 - q)^4 (1 + 4q), q = r/h < 1, with its gradient and Laplacian.
#pragma once

#include <cmath>
#include <vector>

#include "core/types.hpp"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace sphfluid {

struct Wendland {
  Real h, h2, inv_h;
  Real w, grad, lap;  // 7/(pi h^2), -140/(pi h^4), -140/(pi h^4)
  // A straight wall's share of a particle at distance d, tabulated on kTable + 1
  // points of d in [0, h]: half(d), the density share over rho0, and line(d),
  // the normal pressure push per unit 2 p rho0 / rho^2 (continuum: the
  // integral of W along the wall line; half is then its integral beyond d).
  static constexpr int kTable = 256;
  std::vector<Real> line_, half_;
  // Where two perpendicular walls meet, each wall's share covers the quadrant
  // beyond both, so a particle near the corner counts it twice; corner_half
  // and corner_line (as half and line, for the distances d1, d2 to the two
  // walls, on kCorner + 1 points of each in [0, h]) are what to take away.
  static constexpr int kCorner = 96;
  std::vector<Real> corner_half_, corner_line_;

  explicit Wendland(Real h_)
      : h(h_), h2(h_ * h_), inv_h(1 / h_), w(7 / (kPi * h_ * h_)),
        grad(-140 / (kPi * h_ * h_ * h_ * h_)), lap(-140 / (kPi * h_ * h_ * h_ * h_)) {}

  // Continuum tables by default; with a lattice spacing dx > 0 the wall's fluid
  // is instead the mirror image of the square lattice of particles of mass m,
  // so that a lattice resting against a wall has exactly its interior density.
  // Both tables are divided by rho0 (the caller multiplies by it).
  void build_wall_tables(Real dx = 0, Real m_over_rho0 = 0) {
    build_corner_tables(dx, m_over_rho0);
    if (dx > 0) {
      build_lattice_tables(dx, m_over_rho0);
      return;
    }
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

  // A particle at distance d from the wall sees the mirrored lattice at normal
  // distances 2d + k dx (k >= 0) and tangential offsets i dx: half(d) sums W
  // there and line(d) the normal part of -grad W, each times m / rho0.
  void build_lattice_tables(Real dx, Real m_over_rho0) {
    line_.assign(kTable + 1, 0);
    half_.assign(kTable + 1, 0);
    const int reach = static_cast<int>(std::ceil(h / dx)) + 1;
    for (int t = 0; t <= kTable; ++t) {
      const Real d = h * t / kTable;
      Real sw = 0, sg = 0;
      for (int k = 0; 2 * d + k * dx < h; ++k) {
        const Real dn = 2 * d + k * dx;
        for (int i = -reach; i <= reach; ++i) {
          const Real r = std::sqrt(dn * dn + (i * dx) * (i * dx));
          if (r >= h) continue;
          const Real a = 1 - r * inv_h;
          sw += value(r);
          sg += -grad * a * a * a * dn;
        }
      }
      half_[t] = sw * m_over_rho0;
      line_[t] = sg * m_over_rho0;
    }
  }

  // The quadrant beyond two perpendicular walls at distances d1 and d2: with a
  // lattice spacing dx > 0, the particle's lattice mirrored through the corner
  // (points at 2 d1 + k dx and 2 d2 + l dx along the two wall normals, k, l >= 0,
  // each of mass m), else the continuum (midpoint rule). corner_half_ holds the
  // density share over rho0; corner_line_ the push along wall 1's normal.
  void build_corner_tables(Real dx, Real m_over_rho0) {
    const int side = kCorner + 1;
    corner_half_.assign(static_cast<std::size_t>(side) * side, 0);
    corner_line_.assign(static_cast<std::size_t>(side) * side, 0);
    const int quad = 32;         // continuum: midpoints per axis
    const Real cell = h / quad;  // over [0, h]^2 beyond the corner
    for (int a = 0; a <= kCorner; ++a)
      for (int b = 0; b <= kCorner; ++b) {
        const Real d1 = h * a / kCorner, d2 = h * b / kCorner;
        Real sw = 0, sg = 0;
        auto add = [&](Real u, Real v, Real weight) {  // u, v: along normals 1, 2
          const Real r = std::sqrt(u * u + v * v);
          if (r >= h) return;
          const Real c = 1 - r * inv_h;
          sw += weight * value(r);
          sg += weight * -grad * c * c * c * u;
        };
        if (dx > 0) {
          for (int k = 0; 2 * d1 + k * dx < h; ++k)
            for (int l = 0; 2 * d2 + l * dx < h; ++l)
              add(2 * d1 + k * dx, 2 * d2 + l * dx, m_over_rho0);
        } else {
          for (int k = 0; k < quad; ++k)
            for (int l = 0; l < quad; ++l)
              add(d1 + (k + Real(0.5)) * cell, d2 + (l + Real(0.5)) * cell, cell * cell);
        }
        corner_half_[static_cast<std::size_t>(a) * side + b] = sw;
        corner_line_[static_cast<std::size_t>(a) * side + b] = sg;
      }
  }
  // Bilinear in the corner tables; 0 once either distance reaches h.
  Real corner(const std::vector<Real>& t, Real d1, Real d2) const {
    const Real f1 = d1 * inv_h * kCorner, f2 = d2 * inv_h * kCorner;
    if (!(f1 < kCorner && f2 < kCorner)) return 0;
    const int a = static_cast<int>(f1), b = static_cast<int>(f2), side = kCorner + 1;
    const Real s = f1 - a, u = f2 - b;
    const Real* row = t.data() + static_cast<std::size_t>(a) * side + b;
    return (1 - s) * ((1 - u) * row[0] + u * row[1]) + s * ((1 - u) * row[side] + u * row[side + 1]);
  }
  Real corner_half(Real d1, Real d2) const { return corner(corner_half_, d1, d2); }
  Real corner_line(Real d1, Real d2) const { return corner(corner_line_, d1, d2); }

  Real table(const std::vector<Real>& t, Real d) const {
    const Real f = d * inv_h * kTable;
    if (f >= kTable) return 0;
    const int k = static_cast<int>(f);
    return t[k] + (f - k) * (t[k + 1] - t[k]);
  }
  Real wall_line(Real d) const { return table(line_, d); }
  Real wall_half(Real d) const { return table(half_, d); }

  // W as a function of r^2, for the shared density pass.
  struct OfR2 {
    const Wendland* k;
    Real operator()(Real r2) const { return k->value(std::sqrt(r2)); }
#if defined(__AVX512F__)
    // Eight at once, for lanes with r < h (the caller drops the others).
    __m512d operator()(__m512d r2) const {
      const __m512d q = _mm512_mul_pd(_mm512_sqrt_pd(r2), _mm512_set1_pd(k->inv_h));
      const __m512d a = _mm512_sub_pd(_mm512_set1_pd(1), q), a2 = _mm512_mul_pd(a, a);
      const __m512d tail = _mm512_fmadd_pd(_mm512_set1_pd(4), q, _mm512_set1_pd(1));
      return _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(_mm512_set1_pd(k->w), a2), a2), tail);
    }
#endif
  };

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
