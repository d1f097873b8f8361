// wcsph's wall model (docs/method-wcsph.md, eqs. W7-W8): each wall ghost
// stands for the wall's half-plane filled with fluid at rest, and its share of
// a particle's density and pressure push are tabulated against the distance
// to the wall, for a kernel (the Wendland's, or wcsph's pressure kernel, the
// quintic spline: terms/quintic.hpp); where two perpendicular walls meet,
// the quadrant beyond both, which the two half-planes count twice, is
// tabulated against both distances. Reads the kernel; no particle data.
#pragma once

#include <cmath>
#include <functional>
#include <vector>

#include "core/types.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

class WallTables {
 public:
  // Any kernel with h, h2, inv_h, value(r) and gradient_factor(r): read while
  // the tables are built (build), its support h while they are read.
  template <class Kernel>
  explicit WallTables(const Kernel& k)
      : k_{k.h, k.h2, k.inv_h, [k](Real r) { return k.value(r); },
           [k](Real r) { return k.gradient_factor(r); }} {}

  // A straight wall's share of a particle at distance d, tabulated on kTable + 1
  // points of d in [0, h]: half(d), the density share over rho0, and line(d),
  // the normal pressure push per unit 2 p rho0 / rho^2 (continuum: the
  // integral of W along the wall line; half is then its integral beyond d).
  static constexpr int kTable = 256;
  // Where two perpendicular walls meet, each wall's share covers the quadrant
  // beyond both, so a particle near the corner counts it twice; corner_half
  // and corner_line (as half and line, for the distances d1, d2 to the two
  // walls, on kCorner + 1 points of each in [0, h]) are what to take away.
  static constexpr int kCorner = 96;

  // Continuum tables by default; with a lattice spacing dx > 0 the wall's fluid
  // is instead the mirror image of the square lattice of particles of mass m,
  // so that a lattice resting against a wall has exactly its interior density.
  // Both tables are divided by rho0 (the caller multiplies by it).
  // With static_rows, the wall's fluid is instead rows fixed to the wall, at
  // dx/2, 3 dx/2, ... beyond it (a particle at distance d sees them at
  // d + dx/2 + k dx): the fluid's lattice continued through the wall for any
  // support, not only the particle's own image (which coincides with it for
  // the rows within h = 2 dx of the wall).
  void build(Real dx = 0, Real m_over_rho0 = 0, bool static_rows = false) {
    static_rows_ = static_rows && dx > 0;
    dx_ = dx;
    build_corner_tables(dx, m_over_rho0);
    // The hydrostatic push's tables: a lattice, or for the continuum a fine one.
    if (dx > 0) {
      build_hydrostatic_tables(dx, m_over_rho0);
    } else {
      const Real fine = k_.h / 64;
      build_hydrostatic_tables(fine, fine * fine);
    }
    if (dx > 0) {
      build_lattice_tables(dx, m_over_rho0);
      return;
    }
    line_.assign(kTable + 1, 0);
    half_.assign(kTable + 1, 0);
    const int nx = 400;
    for (int k = 0; k <= kTable; ++k) {
      const Real d = k_.h * k / kTable, reach = std::sqrt(std::max(k_.h2 - d * d, Real(0)));
      Real sum = 0;  // midpoint rule along the wall
      for (int i = 0; i < nx; ++i) {
        const Real x = -reach + (i + Real(0.5)) * 2 * reach / nx;
        sum += k_.value(std::sqrt(x * x + d * d));
      }
      line_[k] = sum * 2 * reach / nx;
    }
    // half(d) = int_d^h line(y) dy, by the trapezoid rule from the far end.
    for (int k = kTable - 1; k >= 0; --k)
      half_[k] = half_[k + 1] + Real(0.5) * (line_[k] + line_[k + 1]) * k_.h / kTable;
  }

  // A particle at distance d from the wall sees the mirrored lattice at normal
  // distances 2d + k dx (k >= 0) and tangential offsets i dx: half(d) sums W
  // there and line(d) the normal part of -grad W, each times m / rho0.
  void build_lattice_tables(Real dx, Real m_over_rho0) {
    line_.assign(kTable + 1, 0);
    half_.assign(kTable + 1, 0);
    const int reach = static_cast<int>(std::ceil(k_.h / dx)) + 1;
    for (int t = 0; t <= kTable; ++t) {
      const Real d = k_.h * t / kTable;
      Real sw = 0, sg = 0;
      for (int k = 0; first(d) + k * dx < k_.h; ++k) {
        const Real dn = first(d) + k * dx;
        for (int i = -reach; i <= reach; ++i) {
          const Real r = std::sqrt(dn * dn + (i * dx) * (i * dx));
          if (r >= k_.h) continue;
          sw += k_.value(r);
          sg += -k_.gradient_factor(r) * dn;
        }
      }
      half_[t] = sw * m_over_rho0;
      line_[t] = sg * m_over_rho0;
    }
  }

  // For the push of a half-plane whose pressure grows along gravity
  // (terms/delta.hpp, W20): nn(d) and tt(d) sum -W'/r s_n^2 and -W'/r s_t^2
  // over the mirrored lattice (s_n = 2d + k dx, s_t = i dx), times m / rho0.
  void build_hydrostatic_tables(Real dx, Real m_over_rho0) {
    nn_.assign(kTable + 1, 0);
    tt_.assign(kTable + 1, 0);
    friction_.assign(kTable + 1, 0);
    const int reach = static_cast<int>(std::ceil(k_.h / dx)) + 1;
    for (int t = 0; t <= kTable; ++t) {
      const Real d = k_.h * t / kTable;
      Real sn = 0, st = 0, sf = 0;
      for (int k = 0; first(d) + k * dx < k_.h; ++k) {
        const Real dn = first(d) + k * dx;
        const Real beta = dn / std::max(d, Real(0.5) * dx);
        for (int i = -reach; i <= reach; ++i) {
          const Real ds = i * dx, r = std::sqrt(dn * dn + ds * ds);
          if (r >= k_.h) continue;
          const Real g = -k_.gradient_factor(r);
          sn += g * dn * dn;
          st += g * ds * ds;
          sf += g * beta;
        }
      }
      nn_[t] = sn * m_over_rho0;
      tt_[t] = st * m_over_rho0;
      friction_[t] = sf * m_over_rho0;
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
    corner_11_.assign(static_cast<std::size_t>(side) * side, 0);
    corner_12_.assign(static_cast<std::size_t>(side) * side, 0);
    const int quad = 32;         // continuum: midpoints per axis
    const Real cell = k_.h / quad;  // over [0, h]^2 beyond the corner
    for (int a = 0; a <= kCorner; ++a)
      for (int b = 0; b <= kCorner; ++b) {
        const Real d1 = k_.h * a / kCorner, d2 = k_.h * b / kCorner;
        Real sw = 0, sg = 0, s11 = 0, s12 = 0;
        auto add = [&](Real u, Real v, Real weight) {  // u, v: along normals 1, 2
          const Real r = std::sqrt(u * u + v * v);
          if (r >= k_.h) return;
          const Real g = -k_.gradient_factor(r);
          sw += weight * k_.value(r);
          sg += weight * g * u;
          s11 += weight * g * u * u;
          s12 += weight * g * u * v;
        };
        if (dx > 0) {
          for (int k = 0; first(d1) + k * dx < k_.h; ++k)
            for (int l = 0; first(d2) + l * dx < k_.h; ++l)
              add(first(d1) + k * dx, first(d2) + l * dx, m_over_rho0);
        } else {
          for (int k = 0; k < quad; ++k)
            for (int l = 0; l < quad; ++l)
              add(d1 + (k + Real(0.5)) * cell, d2 + (l + Real(0.5)) * cell, cell * cell);
        }
        corner_half_[static_cast<std::size_t>(a) * side + b] = sw;
        corner_line_[static_cast<std::size_t>(a) * side + b] = sg;
        corner_11_[static_cast<std::size_t>(a) * side + b] = s11;
        corner_12_[static_cast<std::size_t>(a) * side + b] = s12;
      }
  }
  // Bilinear in the corner tables; 0 once either distance reaches h.
  Real corner(const std::vector<Real>& t, Real d1, Real d2) const {
    const Real f1 = d1 * k_.inv_h * kCorner, f2 = d2 * k_.inv_h * kCorner;
    if (!(f1 < kCorner && f2 < kCorner)) return 0;
    const int a = static_cast<int>(f1), b = static_cast<int>(f2), side = kCorner + 1;
    const Real s = f1 - a, u = f2 - b;
    const Real* row = t.data() + static_cast<std::size_t>(a) * side + b;
    return (1 - s) * ((1 - u) * row[0] + u * row[1]) + s * ((1 - u) * row[side] + u * row[side + 1]);
  }
  Real corner_half(Real d1, Real d2) const { return corner(corner_half_, d1, d2); }
  Real corner_line(Real d1, Real d2) const { return corner(corner_line_, d1, d2); }
  // The quadrant's sums of -W'/r s_1^2 and -W'/r s_1 s_2 (s_k along normal k),
  // for the hydrostatic push (terms/delta.hpp, W20).
  Real corner_11(Real d1, Real d2) const { return corner(corner_11_, d1, d2); }
  Real corner_12(Real d1, Real d2) const { return corner(corner_12_, d1, d2); }

  Real table(const std::vector<Real>& t, Real d) const {
    const Real f = d * k_.inv_h * kTable;
    if (f >= kTable) return 0;
    const int k = static_cast<int>(f);
    return t[k] + (f - k) * (t[k + 1] - t[k]);
  }
  // The nearest row of the wall's fluid, at normal distance first(d) from a
  // particle at distance d: its mirror image, or the first static row.
  Real first(Real d) const { return static_rows_ ? d + Real(0.5) * dx_ : 2 * d; }
  Real wall_line(Real d) const { return table(line_, d); }
  Real wall_half(Real d) const { return table(half_, d); }
  Real wall_nn(Real d) const { return table(nn_, d); }
  // The no-slip friction's sum of -W'/r beta over the rows, times m / rho0:
  // Morris, Fox & Zhu (1997) give a row at distance d_B behind the wall the
  // velocity -(d_B / d) v of a particle at d in front, so the pair's relative
  // velocity is (1 + d_B / d) v = (s_n / d) v; here beta = s_n / max(d, dx/2)
  // (a particle nearer the wall than the first lattice row is extrapolated
  // from there; Morris et al. cap beta at 1.5 instead, which with a support of
  // 3 dx leaves the first row slipping: Poiseuille's centreline 3.6 % fast at
  // 20 across).
  Real wall_friction(Real d) const { return table(friction_, d); }
  Real wall_tt(Real d) const { return table(tt_, d); }
  std::size_t bytes() const {
    return (line_.capacity() + half_.capacity() + nn_.capacity() + tt_.capacity() +
            friction_.capacity() +
            corner_half_.capacity() + corner_line_.capacity() + corner_11_.capacity() +
            corner_12_.capacity()) *
           sizeof(Real);
  }

 private:
  struct Kernel {
    Real h, h2, inv_h;
    std::function<Real(Real)> value, gradient_factor;
  };
  Kernel k_;
  bool static_rows_ = false;
  Real dx_ = 0;
  std::vector<Real> line_, half_, nn_, tt_, friction_;
  std::vector<Real> corner_half_, corner_line_, corner_11_, corner_12_;
};

}  // namespace sphfluid
