// The continuity density's pair sums as the traversals take them (the cell
// clusters: load a group, add a pair's shares; the list loops: one lane at a
// time): the rate of the density with the viscous term's normalisation sum
// (terms/delta.hpp, W17-W18 and W24) with W30's velocity-gradient sums, and
// the pair force in the sum form (W19 with W4-W6, W30, W31), each bound to the
// data it reads, on any lane type. Two sums ride in the two components of
// each output's Vec2 array.
#pragma once

#include "core/types.hpp"
#include "neighbours/access.hpp"
#include "terms/delta.hpp"
#include "terms/quintic.hpp"
#include "terms/wcsph.hpp"

namespace sphfluid::delta {

// i's (rate, Laplacian sum) into (di, li), j's into (dj, lj); ir = 1 / rho.
// With Shift, also W27's share from the step's shifts (shift, times per_dt).
// With Gradient, outputs 1 and 2 take W30's velocity-gradient sums
// (g_xx, g_xy) and (g_yx, g_yy).
template <class L, bool Shift = false, bool Gradient = false>
struct RatePairs {
  static constexpr std::size_t kOutputs = Gradient ? 3 : 1;
  const Real* rho;
  const Real* ir;
  InterleavedVelocity v;
  Wendland W;
  RateConstants<L> c;
  InterleavedVelocity shift = {nullptr};
  L per_dt = simd::zero<L>();
  struct Data {
    L rho, vol, vx, vy, sx, sy;
  };
  template <class S>
  SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
    d.rho = simd::load<L>(rho + j, s.lanes);
    d.vol = c.m * simd::load<L>(ir + j, s.lanes);
    v.template group<L>(j, s, d.vx, d.vy);
    if constexpr (Shift) shift.template group<L>(j, s, d.sx, d.sy);
  }
  SPHFLUID_INLINE void add(Index i, const Data& d, simd::Mask<L> in, L dx, L dy, L r2, L& di,
                           L& li, L& dj, L& lj) const {
    L F, vol_i, vol_j, vijx, vijy;
    add(i, d, in, dx, dy, r2, di, li, dj, lj, F, vol_i, vol_j, vijx, vijy);
  }
  SPHFLUID_INLINE void add(Index i, const Data& d, simd::Mask<L> in, L dx, L dy, L r2,
                           L (&ix)[kOutputs], L (&iy)[kOutputs], L (&jx)[kOutputs],
                           L (&jy)[kOutputs]) const {
    static_assert(Gradient);
    L F, vol_i, vol_j, vijx, vijy;
    add(i, d, in, dx, dy, r2, ix[0], iy[0], jx[0], jy[0], F, vol_i, vol_j, vijx, vijy);
    velocity_gradient_share(F * vol_j, dx, dy, vijx, vijy, ix[1], iy[1], ix[2], iy[2]);
    velocity_gradient_share(F * vol_i, dx, dy, vijx, vijy, jx[1], jy[1], jx[2], jy[2]);
  }

 private:
  SPHFLUID_INLINE void add(Index i, const Data& d, simd::Mask<L> in, L dx, L dy, L r2, L& di,
                           L& li, L& dj, L& lj, L& F, L& vol_i, L& vol_j, L& vijx,
                           L& vijy) const {
    const L rho_i = simd::splat<L>(rho[i]);
    F = W.gradient_factor(simd::sqrt(r2));
    vol_i = simd::maskz(in, c.m * simd::splat<L>(ir[i]));
    vol_j = simd::maskz(in, d.vol);
    vijx = simd::splat<L>(v.x(i)) - d.vx;
    vijy = simd::splat<L>(v.y(i)) - d.vy;
    L ri, rj;
    rate<L>(in, F, c, rho_i, d.rho, vol_i, vol_j, dx, dy, vijx, vijy, ri, rj);
    if constexpr (Shift) {
      L si, sj;
      shift_rate<L>(F, rho_i, d.rho, vol_i, vol_j, dx, dy, per_dt * simd::splat<L>(shift.x(i)),
                    per_dt * simd::splat<L>(shift.y(i)), per_dt * d.sx, per_dt * d.sy, si, sj);
      ri = ri + si;
      rj = rj + sj;
    }
    di = di + ri;
    dj = dj + rj;
    li = li + laplacian_sum(F, r2, vol_j);
    lj = lj + laplacian_sum(F, r2, vol_i);
  }
};

// The pair force over rho, p, 1 / rho (ir) and the normalisation c (lap),
// the pressure's part divided by the lattice's S (times inv_s, W29):
// i gets f, j gets -f. With Reconstruct, the artificial viscosity leaves out
// the linear part of v_ij . r_ij from the strains e_xx, e_yy, e_xy (W30).
// With Quintic, the pressure's part takes the quintic spline's gradient
// (pressure_kernel, its own S in inv_s; W31), the viscosities W's.
template <class L, bool Viscosity, bool Reconstruct = false, bool Quintic = false>
struct ForcePairs {
  const Real* rho;
  const Real* p;
  const Real* ir;
  const Real* lap;
  InterleavedVelocity v;
  Wendland W;
  wcsph::PairConstants<L> c;
  L inv_s;
  const Real* exx = nullptr;  // W30's strains
  const Real* eyy = nullptr;
  const Real* exy = nullptr;
  L inv_dx2 = simd::zero<L>();  // 1 / spacing^2
  QuinticSpline pressure_kernel{1};  // W31 (read with Quintic only)
  struct Data {
    L rho, p, ir, lap, vx, vy;
    L exx, eyy, exy;
  };
  template <class S>
  SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
    d.rho = simd::load<L>(rho + j, s.lanes);
    d.p = simd::load<L>(p + j, s.lanes);
    d.ir = simd::load<L>(ir + j, s.lanes);
    d.lap = Viscosity ? simd::load<L>(lap + j, s.lanes) : simd::zero<L>();
    v.template group<L>(j, s, d.vx, d.vy);
    if constexpr (Reconstruct) {
      d.exx = simd::load<L>(exx + j, s.lanes);
      d.eyy = simd::load<L>(eyy + j, s.lanes);
      d.exy = simd::load<L>(exy + j, s.lanes);
    }
  }
  SPHFLUID_INLINE void add(Index i, const Data& d, simd::Mask<L> in, L dx, L dy, L r2, L& fix,
                           L& fiy, L& fjx, L& fjy) const {
    const L vijx = simd::splat<L>(v.x(i)) - d.vx, vijy = simd::splat<L>(v.y(i)) - d.vy;
    const L ir_i = simd::splat<L>(ir[i]);
    const L coef = inv_s * pressure_sum(simd::splat<L>(p[i]), d.p, ir_i, d.ir);
    const L lap_ij =
        Viscosity ? simd::splat<L>(Real(0.5)) * (simd::splat<L>(lap[i]) + d.lap) : simd::zero<L>();
    L linear = simd::zero<L>();
    if constexpr (Reconstruct) {
      linear = linear_vr(in, simd::splat<L>(exx[i]), simd::splat<L>(eyy[i]),
                         simd::splat<L>(exy[i]), d.exx, d.eyy, d.exy, dx, dy, r2, inv_dx2);
    }
    L fx, fy;
    wcsph::PairForce<Viscosity, true>::f(in, W, c, simd::splat<L>(rho[i]) + d.rho,
                                         Quintic ? simd::zero<L>() : coef, ir_i, d.ir, dx, dy,
                                         r2, vijx, vijy, fx, fy, lap_ij, linear);
    if constexpr (Quintic) {  // W31: the pressure's part on the spline
      const L mc = simd::maskz(in, c.m * coef * pressure_kernel.gradient_factor(simd::sqrt(r2)));
      fx = simd::fnmadd(mc, dx, fx);
      fy = simd::fnmadd(mc, dy, fy);
    }
    fix = fix + fx;
    fiy = fiy + fy;
    fjx = fjx - fx;
    fjy = fjy - fy;
  }
};

}  // namespace sphfluid::delta

namespace sphfluid::delta {

// With shifting, the force pass's three sums at once: the pair force (as
// ForcePairs), W21's shifting sum sum_j w_ij V_j r_ij (w the shifting weight
// times F) and the colour gradient sum_j F_ij V_j r_ij, into outputs 0, 1, 2;
// j's shares are the same with V_i and r_ji.
template <class L, bool Viscosity, bool Reconstruct = false>
struct ShiftForcePairs {
  static constexpr std::size_t kOutputs = 3;
  ForcePairs<L, Viscosity, Reconstruct> force;
  L inv_wdx;
  using Data = typename ForcePairs<L, Viscosity, Reconstruct>::Data;
  template <class S>
  SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
    force.load(j, s, d);
  }
  SPHFLUID_INLINE void add(Index i, const Data& d, simd::Mask<L> in, L dx, L dy, L r2,
                           L (&ix)[3], L (&iy)[3], L (&jx)[3], L (&jy)[3]) const {
    force.add(i, d, in, dx, dy, r2, ix[0], iy[0], jx[0], jy[0]);
    const L r = simd::sqrt(r2), m = force.c.m;
    const L vol_j = simd::maskz(in, m * d.ir), vol_i = simd::maskz(in, m * simd::splat<L>(force.ir[i]));
    const L w = shift_weight(force.W, r, inv_wdx), F = force.W.gradient_factor(r);
    ix[1] = simd::fmadd(w * vol_j, dx, ix[1]);
    iy[1] = simd::fmadd(w * vol_j, dy, iy[1]);
    jx[1] = simd::fnmadd(w * vol_i, dx, jx[1]);
    jy[1] = simd::fnmadd(w * vol_i, dy, jy[1]);
    ix[2] = simd::fmadd(F * vol_j, dx, ix[2]);
    iy[2] = simd::fmadd(F * vol_j, dy, iy[2]);
    jx[2] = simd::fnmadd(F * vol_i, dx, jx[2]);
    jy[2] = simd::fnmadd(F * vol_i, dy, jy[2]);
  }
};

}  // namespace sphfluid::delta
