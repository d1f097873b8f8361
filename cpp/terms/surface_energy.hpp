// The terms of wcsph's surface tension (docs/method-wcsph.md, eqs. W10-W12),
// on any lane type: the force through the node positions (the kernel's Hessian
// applied to the node's unit normal, and the normal's part along the
// gradient); a particle's share of the colour field's gradient on a node and
// the pair force through the volumes are the kernel's gradient. The volumes' weights are WendlandWeight's
// (terms/wendland.hpp) with the colour kernel's support H. Values in, values
// out; methods/wcsph/surface_energy.cpp holds the node lattice they act on.
#pragma once

#include "core/types.hpp"
#include "simd/lanes.hpp"
#include "terms/wendland.hpp"

namespace sphfluid::surface {

// W10: particle j's share of grad c on a node at offset (rx, dy) from it is
// V_j grad W_H(rx, dy), and W12 through the volumes is the pair force
// (gamma_j + gamma_l) grad W_H(r_jl): both Wendland::gradient_factor's
// (terms/wendland.hpp) times the offset.

// W12 through the node positions, for a node at offset (rx, dy) from x_j with
// unit normal (cx, cy): adds H_H(rx, dy) n to (sx, sy) and n . grad W_H to sn,
// where H_H d = grad (1 - q)^2 ((1 - q) d - 3 (r . d) r / (H |r|)).
template <class L>
SPHFLUID_INLINE void node_force(const Wendland& W, L rx, L dy, L dy2, L cx, L cy, L& sx, L& sy,
                                L& sn) {
  const L inv_h = simd::splat<L>(W.inv_h);
  const L rl = simd::sqrt(simd::fmadd(rx, rx, dy2));
  const L om = W.one_minus_q(rl * inv_h);
  const L rd = simd::fmadd(rx, cx, dy * cy);
  const L t = simd::splat<L>(3) * inv_h * rd / simd::max(rl, simd::splat<L>(1e-300));
  const L c2 = simd::splat<L>(W.grad) * (om * om);
  sx = simd::fmadd(c2, simd::fmsub(om, cx, t * rx), sx);
  sy = simd::fmadd(c2, simd::fmsub(om, cy, t * dy), sy);
  sn = simd::fmadd(c2 * om, rd, sn);
}

}  // namespace sphfluid::surface
