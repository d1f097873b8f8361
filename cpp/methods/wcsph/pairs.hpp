// wcsph's pair sums as the traversals take them: the pair force (terms/wcsph.hpp,
// eqs. W4-W6) bound to the data it reads, on any lane type, for the cell
// clusters (load a group, add a pair's shares) and, one pair at a time, for
// the list loops, with the list loops' visitor.
#pragma once

#include <algorithm>

#include "core/types.hpp"
#include "neighbours/access.hpp"
#include "terms/wcsph.hpp"

namespace sphfluid::wcsph {

// The pair force over densities rho, p / rho^2 (por2) and 1 / rho (ir) and
// the velocities: i gets f, j gets -f (it is antisymmetric).
template <class L, bool Viscosity>
struct ForcePairs {
  const Real* rho;
  const Real* por2;
  const Real* ir;
  InterleavedVelocity v;
  Wendland W;
  PairConstants<L> c;
  struct Data {
    L rho, por2, ir, vx, vy;
  };
  template <class S>
  SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
    d.rho = simd::load<L>(rho + j, s.lanes);
    d.por2 = simd::load<L>(por2 + j, s.lanes);
    d.ir = Viscosity ? simd::load<L>(ir + j, s.lanes) : simd::zero<L>();
    v.template group<L>(j, s, d.vx, d.vy);
  }
  SPHFLUID_INLINE void add(Index i, const Data& dj, simd::Mask<L> in, L dx, L dy, L r2, L& fix,
                           L& fiy, L& fjx, L& fjy) const {
    const L vijx = simd::splat<L>(v.x(i)) - dj.vx, vijy = simd::splat<L>(v.y(i)) - dj.vy;
    L fx, fy;
    PairForce<Viscosity>::f(in, W, c, simd::splat<L>(rho[i]) + dj.rho,
                            simd::splat<L>(por2[i]) + dj.por2, simd::splat<L>(ir[i]), dj.ir, dx,
                            dy, r2, vijx, vijy, fx, fy);
    fix = fix + fx;
    fiy = fiy + fy;
    fjx = fjx - fx;
    fjy = fjy - fy;
  }
};

// The list loops' visitor (neighbours/pair_loops.hpp): the pair force's sums
// into a[]; over full lists (Gather) each particle's sum goes to
// finish(i, f), the method's per-particle end.
template <bool Viscosity, bool Gather, class Finish>
struct ListVisitor {
  ForcePairs<Real, Viscosity> forces;
  Vec2* a;
  Finish finish;

  void begin_block(Index lo, Index hi) const { std::fill(a + lo, a + hi, Vec2::Zero()); }
  Vec2 begin(Index i) const {
    if constexpr (Gather) {
      return Vec2::Zero();
    } else {
      return a[i];  // from the pairs with earlier particles of the block
    }
  }
  void pair(Vec2& f, Index i, Index j, const Vec2& r, Real r2, bool mine) const {
    typename ForcePairs<Real, Viscosity>::Data d;
    forces.load(j, Span1{}, d);
    if (mine) {
      forces.add(i, d, true, r.x(), r.y(), r2, f.x(), f.y(), a[j].x(), a[j].y());
    } else {
      Real jx = 0, jy = 0;
      forces.add(i, d, true, r.x(), r.y(), r2, f.x(), f.y(), jx, jy);
    }
  }
  void end(Index i, const Vec2& f) const {
    if constexpr (Gather) {
      finish(i, f);
    } else {
      a[i] = f;
    }
  }
};

}  // namespace sphfluid::wcsph
