// The terms of wcsph's surface tension (docs/method-wcsph.md, eqs. W10-W12),
// each on any lane type: a particle's share of the colour field's gradient on
// a node, the force through the node positions (the kernel's Hessian applied
// to the node's unit normal, and the normal's part along the gradient), and
// the pair force through the volumes. The volumes' weights are WendlandWeight's
// (terms/wendland.hpp) with the colour kernel's support H. Values in, values
// out; methods/wcsph/surface_energy.cpp holds the node lattice they act on.
#pragma once

#include "core/types.hpp"
#include "simd/lanes.hpp"

namespace sphfluid::surface {

// W10: particle j's share of grad c on a node at offset (rx, dy) from it,
// V_j grad W_H = vg (1 - q)^3 (rx, dy) with vg = V_j grad (the kernel's
// gradient factor) and q = r / H: returns the factor of (rx, dy).
template <class L>
SPHFLUID_INLINE L node_gradient(L vg, L rx, L dy2, L inv_h) {
  const L om = simd::max(simd::splat<L>(1) - simd::sqrt(rx * rx + dy2) * inv_h, simd::zero<L>());
  return vg * om * om * om;
}

// W12 through the node positions, for a node at offset (rx, dy) from x_j with
// unit normal (cx, cy): adds H_H(rx, dy) n to (sx, sy) and n . grad W_H to sn,
// where H_H d = grad (1 - q)^2 ((1 - q) d - 3 (r . d) r / (H |r|)).
template <class L>
SPHFLUID_INLINE void node_force(L rx, L dy, L dy2, L cx, L cy, L inv_h, L grad, L& sx, L& sy,
                                L& sn) {
  const L rl = simd::sqrt(simd::fmadd(rx, rx, dy2));
  const L om = simd::max(simd::fnmadd(rl, inv_h, simd::splat<L>(1)), simd::zero<L>());
  const L rd = simd::fmadd(rx, cx, dy * cy);
  const L t = simd::splat<L>(3) * inv_h * rd / simd::max(rl, simd::splat<L>(1e-300));
  const L c2 = grad * (om * om);
  sx = simd::fmadd(c2, simd::fmsub(om, cx, t * rx), sx);
  sy = simd::fmadd(c2, simd::fmsub(om, cy, t * dy), sy);
  sn = simd::fmadd(c2 * om, rd, sn);
}

// W12 through the volumes: the pair force (gamma_j + gamma_l) grad W_H(r_jl)
// = g_sum grad (1 - q)^3 r_jl, with a = max(1 - q, 0): returns the factor of
// r_jl.
template <class L>
SPHFLUID_INLINE L volume_pair(L g_sum, L grad, L a) {
  return g_sum * grad * (a * a * a);
}

}  // namespace sphfluid::surface
