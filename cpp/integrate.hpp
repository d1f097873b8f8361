// The integrator every method shares (Context::integrate): the kick and the
// drift, the wall collision of the paths that may meet a wall (seed 4.2), the
// guard's checks of the new state, and, where the lanes run, a look ahead for
// the next sort (the new positions' bounding box and cells) and whether every
// particle stayed inside the domain. A method's step includes this header and
// instantiates the integration its feature set needs.
#pragma once

#include <algorithm>
#include <limits>

#include "context.hpp"
#include "simd/ints.hpp"
#include "simd/points.hpp"

namespace sphfluid {

#if SPHFLUID_AVX512
namespace integration {

// The lanes of `ok` whose path (from, to) may meet a wall. With the
// particles' clearances (clear2 of the eight, else null), a path shorter than
// its clearance meets no wall: every wall within h of it is in its lookup
// cell (none where no wall comes near, nor off the lookup grid), and the
// clearance is less than h / 2 and than the distance to the nearest of those
// walls. Without them, the walls' lookup grid says.
SPHFLUID_INLINE simd::Mask8 may_meet_wall(const WallSet& walls, simd::Mask8 ok, simd::D8 from_x,
                                          simd::D8 from_y, simd::D8 to_x, simd::D8 to_y,
                                          const float* clear2) {
  if (!clear2) return walls.may_hit8(ok, from_x, from_y, to_x, to_y);
  const simd::D8 c2 = simd::widen(simd::F8::loadu(clear2));
  const simd::D8 dx = to_x - from_x, dy = to_y - from_y;
  const simd::Mask8 short_path = simd::lt(0xFF, simd::fmadd(dx, dx, dy * dy), c2);
  return ok & static_cast<simd::Mask8>(~short_path);
}

}  // namespace integration
#endif

template <bool Walls, bool Periodic>
void Context::integrate(Real dt, Real kick, const Vec2* shift) {
  const Index n = size();
  if constexpr (Walls)
    if (walls.moves()) walls.aim(time_ + dt);  // where the moving walls end the step
  Vec2* x_new = ps.x.begin_write(n);
  Vec2* v_new = ps.v.begin_write(n);
  Integration r;
  if constexpr (!Periodic && kVector8) {
    if (!shift) {
      r = integrate8<Walls>(dt, kick, x_new, v_new);
    } else {
      r = integrate1<Walls, Periodic>(dt, kick, x_new, v_new, shift);
    }
  } else {
    r = integrate1<Walls, Periodic>(dt, kick, x_new, v_new, shift);
  }
  if (budget_stale) {  // (from the state before this integration)
    rebudget();
    budget_stale = false;
  }
  const Real kinetic = 0.5 * params_.mass * r.v2_sum;
  if (r.bad || (params_.guard &&
                !(kinetic + energy_removed <= params_.guard_energy_factor * energy_budget)))
    trip(dt, x_new, v_new, ps.rho.data(), kinetic);
  wall_crossings_ += r.crossings;  // (a step that trips is not counted)
  ps.x.commit_write();
  ps.v.commit_write();
  if (r.ahead) {
    search.grid().set_ahead(n, r.lo, r.hi);
  } else {
    search.grid().drop_ahead();
  }
  // (all finite here: the guard trips on any non-finite position)
  const Vec2 lo = params_.domain_min, hi = params_.domain_max;
  all_inside_ = r.box && (r.lo.array() >= lo.array()).all() && (r.hi.array() <= hi.array()).all();
}

// One particle at a time (and across periodic seams).
template <bool Walls, bool Periodic>
Context::Integration Context::integrate1(Real dt, Real kick, Vec2* x_new, Vec2* v_new,
                                        const Vec2* shift) {
  const Index n = size();
  const Vec2* x = ps.x.data();
  const Vec2* v = ps.v.data();
  const Vec2* a = ps.a.data();
  const Real* rho = ps.rho.data();
  [[maybe_unused]] const Real e = params_.restitution;
  const GuardLimits lim = guard_limits();
  const Real rho_min = lim.rho_min, rho_max = lim.rho_max, v2_max = lim.v2_max;
  ghosts.stale();  // the wall clearances serve one integration only
  bool bad = false;
  Real sum = 0;
  std::int64_t crossings = 0;
#pragma omp parallel for schedule(static) num_threads(team()) reduction(|| : bad) \
    reduction(+ : sum, crossings)
  for (Index i = 0; i < n; ++i) {
    const Vec2 x_old = x[i];
    Vec2 vi = v[i] + kick * a[i];
    Vec2 xi = x_old + dt * vi;
    if (shift) xi += shift[i];
    if constexpr (Walls)
      if (xi.allFinite() && vi.allFinite() && walls.may_hit(x_old, xi))
        crossings += walls.collide(x_old, xi, vi, e);
    if constexpr (Periodic) xi = box.wrap(xi);
    const Real v2 = vi.squaredNorm();
    // Written so that NaN fails every comparison and so trips.
    bad = bad || !(xi.allFinite() && v2 <= v2_max && rho[i] <= rho_max && rho[i] > rho_min);
    sum += v2;
    x_new[i] = xi;
    v_new[i] = vi;
  }
  Integration r;
  r.bad = bad;
  r.v2_sum = sum;
  r.crossings = crossings;
  return r;
}

// Eight particles at a time (without periodic seams): the same arithmetic on
// the interleaved x and y, the wall check for eight paths at once, and the
// collision itself only for the paths that may meet a wall.
template <bool Walls>
Context::Integration Context::integrate8(Real dt, Real kick, Vec2* x_new, Vec2* v_new) {
  Integration r;
#if SPHFLUID_AVX512
  using simd::D8;
  using simd::Mask8;
  const Index n = size();
  const Vec2* x = ps.x.data();
  const Vec2* v = ps.v.data();
  const Vec2* a = ps.a.data();
  const Real* rho = ps.rho.data();
  [[maybe_unused]] const Real e = params_.restitution;
  const Real inf = std::numeric_limits<Real>::infinity();
  const GuardLimits lim = guard_limits();
  const Real rho_max = lim.rho_max, v2_max = lim.v2_max;
  const D8 rho_floor = D8::splat(lim.rho_min);
  // The clearances found by this step's ghost search, for the positions x;
  // they serve this integration only.
  // (not past moving walls: one may come closer than a clearance in a step)
  [[maybe_unused]] const bool clear_known = ghosts.fresh_for(n) && !walls.moves();
  [[maybe_unused]] const float* clear2_of = ghosts.clearances();
  ghosts.stale();
  // Ahead of the next sort (CellGrid::set_ahead): the new positions'
  // bounding box (std::min's rule: a NaN is passed over), which also tells
  // whether any left the domain, their cells on the current grid, and a
  // byte per eight particles marking those whose cell changed.
  CellGrid& grid = search.grid();
  Index* const cells_ahead = grid.can_look_ahead(n) ? grid.ahead_cells(n) : nullptr;
  unsigned char* const moved_ahead = grid.ahead_moved();
  const Index* const cells_now = grid.sorted_cells();
  const CellGrid::Cells8 cells8 = grid.cells8();
  const Index chunks = (n + 7) / 8;
  const D8 kv = D8::splat(kick), dtv = D8::splat(dt);
  const D8 v2_cap = D8::splat(v2_max), rho_cap = D8::splat(rho_max);
  bool bad = false;
  Real sum = 0, lx = inf, ly = inf, hx = -inf, hy = -inf;
  std::int64_t crossings = 0;
#pragma omp parallel num_threads(team()) reduction(|| : bad) reduction(+ : sum, crossings) \
    reduction(min : lx, ly) reduction(max : hx, hy)
  {
    D8 vlx = D8::splat(inf), vly = vlx, vhx = D8::splat(-inf), vhy = vhx;
#pragma omp for schedule(static)
    for (Index c = 0; c < chunks; ++c) {
      const Index i0 = 8 * c;
      const simd::Span8 s(n - i0);
      const std::size_t o = 2 * static_cast<std::size_t>(i0);
      // The interleaved x and y of the chunk in two halves (points 0-3, 4-7).
      D8 x_lo, x_hi, a_lo, a_hi, v_lo, v_hi;
      simd::load_halves(x[0].data() + o, s, x_lo, x_hi);
      simd::load_halves(a[0].data() + o, s, a_lo, a_hi);
      simd::load_halves(v[0].data() + o, s, v_lo, v_hi);
      // v + kick a, then x + dt v: the scalar loop's arithmetic as GCC compiles
      // it (-ffp-contract=fast, the default with -std=gnu++17: one FMA each)
      v_lo = simd::fmadd(kv, a_lo, v_lo);
      v_hi = simd::fmadd(kv, a_hi, v_hi);
      D8 xn_lo = simd::fmadd(dtv, v_lo, x_lo), xn_hi = simd::fmadd(dtv, v_hi, x_hi);
      simd::store_halves(x_new[0].data() + o, s, xn_lo, xn_hi);
      simd::store_halves(v_new[0].data() + o, s, v_lo, v_hi);
      // The new positions and velocities as x and y lanes (again after any
      // collision, which may change them).
      D8 to_x = simd::x_of(xn_lo, xn_hi), to_y = simd::y_of(xn_lo, xn_hi);
      D8 vx = simd::x_of(v_lo, v_hi), vy = simd::y_of(v_lo, v_hi);
      if constexpr (Walls) {
        const Mask8 ok = s.lanes & simd::finite(to_x) & simd::finite(to_y) & simd::finite(vx) &
                         simd::finite(vy);
        const Mask8 may = integration::may_meet_wall(walls, ok, simd::x_of(x_lo, x_hi),
                                        simd::y_of(x_lo, x_hi), to_x, to_y,
                                        clear_known ? clear2_of + i0 : nullptr);
        if (may) {
          for (unsigned k = 0; k < 8; ++k) {
            if (!(may >> k & 1u)) continue;
            const Index i = i0 + static_cast<Index>(k);
            crossings += walls.collide(x[i], x_new[i], v_new[i], e);
          }
          simd::load_halves(x_new[0].data() + o, s, xn_lo, xn_hi);
          simd::load_halves(v_new[0].data() + o, s, v_lo, v_hi);
          to_x = simd::x_of(xn_lo, xn_hi);
          to_y = simd::y_of(xn_lo, xn_hi);
          vx = simd::x_of(v_lo, v_hi);
          vy = simd::y_of(v_lo, v_hi);
        }
      }
      const D8 v2 = simd::fmadd(vx, vx, vy * vy);
      // Written so that NaN fails every comparison and so trips.
      const D8 rho_i = D8::load(rho + i0, s.lanes);
      const Mask8 fine = simd::finite(to_x) & simd::finite(to_y) & simd::le(0xFF, v2, v2_cap) &
                         simd::le(0xFF, rho_i, rho_cap) & simd::gt(0xFF, rho_i, rho_floor);
      bad = bad || (fine & s.lanes) != s.lanes;
      sum += reduce_add(maskz(s.lanes, v2));
      vlx = mask_min(vlx, s.lanes, to_x, vlx);
      vly = mask_min(vly, s.lanes, to_y, vly);
      vhx = mask_max(vhx, s.lanes, to_x, vhx);
      vhy = mask_max(vhy, s.lanes, to_y, vhy);
      if (cells_ahead) {
        const simd::I8 cells = cells8(to_x, to_y);
        cells.store(cells_ahead + i0, s.lanes);
        moved_ahead[c] = neq(s.lanes, cells, simd::I8::load(cells_now + i0, s.lanes));
      }
    }
    lx = simd::reduce_min(vlx);
    ly = simd::reduce_min(vly);
    hx = simd::reduce_max(vhx);
    hy = simd::reduce_max(vhy);
  }
  r.bad = bad;
  r.v2_sum = sum;
  r.crossings = crossings;
  r.box = true;
  r.ahead = cells_ahead != nullptr;
  r.lo = Vec2(lx, ly);
  r.hi = Vec2(hx, hy);
#else
  (void)dt, (void)kick, (void)x_new, (void)v_new;
  r.bad = true;
#endif
  return r;
}

}  // namespace sphfluid
