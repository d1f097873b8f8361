// The seed's pair sums as the traversals take them: the pressure and
// viscosity pair term (terms/seed.hpp, eqs. 14 and 17) bound to the data it
// reads, on any lane type (double arrays with interleaved velocities, or the
// float copies of the float path), for the cell clusters (load a group, add a
// pair's shares) and, one pair at a time, for the list loops; and the list
// loops' visitors, which add the colour field's sums (eqs. 18-19) where the
// scene has tension.
#pragma once

#include <algorithm>
#include <vector>

#include "core/types.hpp"
#include "neighbours/access.hpp"
#include "simd/points.hpp"
#include "terms/seed.hpp"

namespace sphfluid::seed {

// The pair term over pressures p and inverse densities ir (in the units of
// the frame: p / rho0 and rho0 / rho in float), velocities V, support h and
// viscosity factor l: i gets t ir_j, j gets -t ir_i.
template <class L, bool Viscosity, bool RecipRoot, class V>
struct ForcePairs {
  using T = simd::ScalarOf<L>;
  const T* p;
  const T* ir;
  V v;
  L h, l;
  struct Data {
    L p, ir, vx, vy;
  };
  template <class S>
  SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
    d.p = simd::load<L>(p + j, s.lanes);
    d.ir = simd::load<L>(ir + j, s.lanes);
    if constexpr (Viscosity) {
      v.template group<L>(j, s, d.vx, d.vy);
    } else {
      d.vx = d.vy = simd::zero<L>();  // (unread)
    }
  }
  SPHFLUID_INLINE void add(Index i, const Data& dj, simd::Mask<L> in, L dx, L dy, L r2, L& fix,
                           L& fiy, L& fjx, L& fjy) const {
    L tx, ty;
    PairForce<Viscosity, RecipRoot>::t(in, h, l, simd::splat<L>(p[i]) + dj.p, dx, dy, r2, v.x(i),
                                       v.y(i), dj.vx, dj.vy, tx, ty);
    fix = simd::fmadd(dj.ir, tx, fix);
    fiy = simd::fmadd(dj.ir, ty, fiy);
    const L iri = simd::splat<L>(ir[i]);
    fjx = simd::fnmadd(iri, tx, fjx);
    fjy = simd::fnmadd(iri, ty, fjy);
  }
};

template <bool Viscosity>
using ScalarForces = ForcePairs<Real, Viscosity, false, InterleavedVelocity>;

// What a list loop accumulates for a particle: its pair sum and, with
// tension, its colour field's gradient and Laplacian.
struct ListSums {
  Vec2 f, normal;
  Real lap;
};

// The list loops' visitor (neighbours/pair_loops.hpp): the pair term's sums
// and, with Tension, the colour field's (eqs. 18-19: m / rho_j grad W and
// m / rho_j lap W). Over the half lists (Gather false) they go to a[],
// normal and lap_c; over full lists each particle's go to finish(i, sums),
// the method's per-particle end.
template <bool Viscosity, bool Tension, bool Gather, class Finish>
struct ListVisitor {
  ScalarForces<Viscosity> forces;
  ColourField colour;
  Real m, lap_self;
  Vec2* a;
  Vec2* normal;
  Real* lap_c;
  Finish finish;

  // The half lists: each block's sums start from zero (lap c from the
  // particle's own share).
  void begin_block(Index lo, Index hi) const {
    std::fill(a + lo, a + hi, Vec2::Zero());
    if constexpr (Tension) {
      std::fill(normal + lo, normal + hi, Vec2::Zero());
      for (Index i = lo; i < hi; ++i) lap_c[i] = m * forces.ir[i] * lap_self;
    }
  }
  ListSums begin(Index i) const {
    if constexpr (Gather) return {Vec2::Zero(), Vec2::Zero(), m * forces.ir[i] * lap_self};
    // from the pairs with earlier particles of the block
    return {a[i], Tension ? normal[i] : Vec2::Zero(), Tension ? lap_c[i] : Real(0)};
  }
  void pair(ListSums& s, Index i, Index j, const Vec2& r, Real r2, bool mine) const {
    typename ScalarForces<Viscosity>::Data d;
    forces.load(j, Span1{}, d);
    if (mine) {
      forces.add(i, d, true, r.x(), r.y(), r2, s.f.x(), s.f.y(), a[j].x(), a[j].y());
    } else {
      Real jx = 0, jy = 0;
      forces.add(i, d, true, r.x(), r.y(), r2, s.f.x(), s.f.y(), jx, jy);
    }
    if constexpr (Tension) {
      Real g, l;
      colour.pair(r2, g, l);
      const Vec2 gw = g * r;
      s.normal += (m * forces.ir[j]) * gw;
      s.lap += (m * forces.ir[j]) * l;
      if (mine) {
        normal[j] -= (m * forces.ir[i]) * gw;
        lap_c[j] += (m * forces.ir[i]) * l;
      }
    }
  }
  void end(Index i, const ListSums& s) const {
    if constexpr (Gather) {
      finish(i, s);
    } else {
      a[i] = s.f;
      if constexpr (Tension) {
        normal[i] = s.normal;
        lap_c[i] = s.lap;
      }
    }
  }
};

}  // namespace sphfluid::seed
