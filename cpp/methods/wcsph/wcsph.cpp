// The wcsph method's step (docs/method-wcsph.md) as ordered phases, each one
// parallel loop whose sums do not depend on the thread count: kick-drift-kick
// (W14) around the evaluation of the summation density (W2), the Tait state
// equation (W3), the pair forces (W4-W6), the walls (W7-W9) and the tension
// (W10-W12).
#include "methods/wcsph/wcsph.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "integrate.hpp"
#include "methods/wcsph/pairs.hpp"
#include "neighbours/frames.hpp"
#include "neighbours/pair_loops.hpp"

namespace sphfluid {

WcsphMethod::WcsphMethod(Context& ctx)
    : ctx_(ctx), P_(ctx.params()), kernel_(P_.h), weight_(kernel_), walls_(kernel_) {
  walls_.build(P_.spacing, P_.mass / P_.rho0);
  surface_ = SurfaceEnergy::summed(P_, ctx.box);
}

void WcsphMethod::select(unsigned features) {
  static constexpr auto steps = feature_table<Steps, StepFn>();
  static constexpr auto evals = feature_table<Evaluations, EvalFn>();
  step_fn_ = steps[features];
  eval_fn_ = evals[features];
}

// Tait, clamped at rho0 (W3).
Real WcsphMethod::elastic_energy() const {
  const Real B = P_.rho0 * P_.c0 * P_.c0 / wcsph::kTaitGamma;
  Real elastic = 0;
  for (Index i = 0; i < ctx_.size(); ++i)
    elastic += P_.mass * wcsph::elastic_energy(std::max(ctx_.ps.rho[i] / P_.rho0, Real(1)),
                                               P_.rho0, B);
  return elastic;
}

std::size_t WcsphMethod::bytes() const {
  return (por2_.capacity() + inv_rho_.capacity()) * sizeof(Real) + walls_.bytes() +
         surface_.bytes();
}

// Kick-drift-kick: v += dt/2 a; x += dt v (walls reflect); evaluate at the new
// positions (the dissipative terms with the half-step velocity); v += dt/2 a.
template <unsigned F>
void WcsphMethod::step_impl(Real dt, Real dt_cap) {
  dt = ctx_.step_size(dt, dt_cap);
  const Real half = Real(0.5) * dt;
  // The drift starts from the positions of the last evaluation (the end of
  // the previous step, or an evaluation after the state or the walls
  // changed), so the wall clearances of its ghost search hold for them.
  ctx_.integrate<(F & kWalls) != 0, (F & kPeriodic) != 0>(dt, half);
  ctx_.timer.mark(kIntegrate);
  ctx_.leave_domain();
  ctx_.timer.mark(kDomain);
  evaluate_kick<F>(half);  // the second kick rides on the last loop
  ctx_.timer.mark(kIntegrate);
  ctx_.advance(dt);
}

template <unsigned F>
void WcsphMethod::evaluate_kick(Real half) {
  ctx_.timer.start();
  density<F>();
  if constexpr ((F & kSurfaceTension) != 0) {
    surface_.evaluate(ctx_.ps.x.data(), ctx_.size(), P_.mass, ctx_.team());
    ctx_.timer.mark(kForces);
  }
  state<F>();
  forces<F>();
  accelerations<F>(half);
}

// W2 over the fluid pairs (with the neighbour search), and the walls' ghosts
// at their nearest points (W7: a convex corner's vertex and a free end have
// one; a joint of pieces shorter than h that another piece comes nearer
// than has none).
template <unsigned F>
void WcsphMethod::density() {
  ParticleSet& ps = ctx_.ps;
  if constexpr (by_cells(F)) {
    ctx_.search.clusters(ps, P_.h, P_.mass, ctx_.team(), weight_, ctx_.timer);
  } else {
    ctx_.search.lists<(F & kPeriodic) != 0, pairs_once(F)>(ps, P_.h, P_.mass, ctx_.team(),
                                                           ctx_.box, weight_, ctx_.timer);
  }
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.find(ctx_.walls, ps.x.data(), ps.size(), P_.h, ctx_.team(), true);
    ctx_.timer.mark(kGhosts);
  }
}

// The walls' share of the density (W7), for the particles that have ghosts,
// then the state equation (W3) for all, in a loop the compiler vectorises.
template <unsigned F>
void WcsphMethod::state() {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const Real rho0 = P_.rho0, B = rho0 * P_.c0 * P_.c0 / wcsph::kTaitGamma;
  const Real pb = P_.background_pressure;
  Real* rho = ps.rho.data();
  Real* p = ps.p.data();
  por2_.resize(n);
  inv_rho_.resize(n);
  Real* por2 = por2_.data();
  Real* inv_rho = inv_rho_.data();
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
      Real rho_i = rho[i];
      wcsph::add_wall_density(walls_, rho0, ghosts, rho_i);
      rho[i] = rho_i;
    });
  }
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    const Real rho_i = rho[i], p_i = wcsph::pressure(rho_i, rho0, B, pb), ir = 1 / rho_i;
    p[i] = p_i;
    inv_rho[i] = ir;
    por2[i] = p_i * ir * ir;
  }
  // An outlet's buffer holds the reference pressure, plus the hydrostatic
  // head under gravity (Context::outlet_held, outlet_pressure).
  if (const std::int8_t* held = ctx_.outlet_held()) {
    const Real* head = ctx_.outlet_pressure();
    for (Index i = 0; i < n; ++i)
      if (held[i]) {
        p[i] = wcsph::pressure(rho0, rho0, B, pb) + head[i];
        por2[i] = p[i] * inv_rho[i] * inv_rho[i];
      }
  }
  ctx_.timer.mark(kDensity);
}

// The fluid pairs (W4-W6) into a[]: each pair once by cell clusters or over
// the half lists, the walls' share (W8-W9) after; or, across periodic seams,
// each particle over its full list with its walls right after.
template <unsigned F>
void WcsphMethod::forces() {
  if constexpr (by_cells(F)) {
    forces_by_cells<(F & kViscosity) != 0>();
  } else {
    forces_by_lists<F>();
  }
  if constexpr (pairs_once(F) && (F & kWalls) != 0) {
    Vec2* a = ctx_.ps.a.data();
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2>) {
      Vec2 f = a[i];
      add_wall_force<F>(i, f);
      a[i] = f;
    });
  }
}

template <bool Viscosity>
void WcsphMethod::forces_by_cells() {
#if SPHFLUID_AVX512
  if constexpr (CellPairs::kAvailable) {
    ParticleSet& ps = ctx_.ps;
    // four lanes a group: the pair force's arithmetic outweighs the traversal
    const PositionFrame<simd::D4> frame(ps.x.data(), P_.h);
    const wcsph::ForcePairs<simd::D4, Viscosity> pair{
        ps.rho.data(), por2_.data(), inv_rho_.data(), {ps.v.data()}, kernel_, wcsph::pair_constants<simd::D4>(P_)};
    ctx_.search.cells().pair_sums(ctx_.search.grid(), frame, pair, ps.a.data(), ctx_.team());
    return;
  }
#endif
  throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
}

template <unsigned F>
void WcsphMethod::forces_by_lists() {
  constexpr bool kVisc = (F & kViscosity) != 0;
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  Vec2* a = ps.a.data();
  const wcsph::ForcePairs<Real, kVisc> forces{ps.rho.data(), por2_.data(), inv_rho_.data(),
                                              {ps.v.data()}, kernel_, wcsph::pair_constants<Real>(P_)};
  if constexpr (pairs_once(F)) {
    if (!ctx_.search.has_half_lists(n))
      throw std::logic_error("the pair-once loop needs this evaluation's half lists");
    auto none = [](Index, const Vec2&) {};
    const wcsph::ListVisitor<kVisc, false, decltype(none)> visitor{forces, a, none};
    pair_loops::once(ctx_.search.lists(), ps.x.data(), n, NeighbourSearch::pair_block(n),
                     ctx_.team(), visitor);
  } else {
    auto finish = [&](Index i, const Vec2& sum) {
      Vec2 f = sum;
      if constexpr ((F & kWalls) != 0) add_wall_force<F>(i, f);
      a[i] = f;
    };
    const wcsph::ListVisitor<kVisc, true, decltype(finish)> visitor{forces, a, finish};
    const PeriodicBox& box = ctx_.box;
    pair_loops::gather(ctx_.search.lists(), ps.x.data(), n, ctx_.team(),
                       [&](const Vec2& p, const Vec2& q) { return box.delta(p, q); }, visitor);
  }
}

template <unsigned F>
void WcsphMethod::add_wall_force(Index i, Vec2& f) const {
  const ParticleSet& ps = ctx_.ps;
  constexpr bool kVisc = (F & kViscosity) != 0;
  const wcsph::PairConstants<Real> c = wcsph::pair_constants<Real>(P_);
  const Row<Vec2> ghosts = ctx_.ghosts.row(i);
  if (ctx_.walls.moves()) {  // the ghosts move with their wall
    wcsph::add_wall_force<kVisc>(walls_, kernel_, c, P_.rho0, ghosts, por2_[i], inv_rho_[i],
                                 VelocityToWall{ctx_.walls, ps.x[i], ps.v[i]}, f);
  } else {
    wcsph::add_wall_force<kVisc>(walls_, kernel_, c, P_.rho0, ghosts, por2_[i], inv_rho_[i],
                                 VelocityAsIs{ps.v[i]}, f);
  }
}

// a = f + the tension (W12) + g (W13); with half > 0 also the second
// half-kick (Context::add_gravity_and_kick).
template <unsigned F>
void WcsphMethod::accelerations(Real half) {
  ctx_.add_gravity_and_kick(half, (F & kSurfaceTension) != 0 ? surface_.accelerations() : nullptr);
  ctx_.timer.mark(kForces);
}

}  // namespace sphfluid
