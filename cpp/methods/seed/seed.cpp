// The seed method's step (docs/method-seed.md, the paper's pseudocode 4.3) as
// ordered phases, each one parallel loop whose sums do not depend on the
// thread count: in gather form (iteration i reads its neighbours and writes
// only particle i), or, for the pair sums, over blocks fixed by the particles
// alone: of particles on the half lists, of cell rows by cell clusters.
#include "methods/seed/seed.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "integrate.hpp"
#include "methods/seed/pairs.hpp"
#include "neighbours/pair_loops.hpp"
#include "simd/cpu.hpp"

namespace sphfluid {

void SeedFloats::fill_velocities(const Vec2* v, Index i0, Index i1) {
  Index i = i0;
#if SPHFLUID_AVX512
  for (; i + 8 <= i1; i += 8) {
    simd::D8 qx, qy;
    simd::load_xy8(v[i].data(), qx, qy);
    simd::narrow(qx).store(vx.data() + i, 0xFF);
    simd::narrow(qy).store(vy.data() + i, 0xFF);
  }
#endif
  for (; i < i1; ++i) {
    vx[i] = static_cast<float>(v[i].x());
    vy[i] = static_cast<float>(v[i].y());
  }
}

SeedMethod::SeedMethod(Context& ctx)
    : ctx_(ctx),
      P_(ctx.params()),
      kern_(P_.h),
      weight_(kern_),
      colour_(kern_),
      recip_root_(simd::prefers_recip_root()) {}

void SeedMethod::select(unsigned features) {
  // One instantiation of the whole step per feature set, chosen here once.
  static constexpr auto steps = feature_table<Steps, StepFn>();
  static constexpr auto evals = feature_table<Evaluations, EvalFn>();
  step_fn_ = steps[features];
  eval_fn_ = evals[features];
  float_pairs_ = P_.float_pairs && (features & (kPeriodic | kSurfaceTension)) == 0 &&
                 CellPairs::kAvailable;
}

// p = k (rho - rho0): k (ln(rho/rho0) + rho0/rho - 1) per kg.
Real SeedMethod::elastic_energy() const {
  Real elastic = 0;
  for (Index i = 0; i < ctx_.size(); ++i) {
    const Real r = ctx_.ps.rho[i] / P_.rho0;
    elastic += P_.mass * P_.k * (std::log(r) + 1 / r - 1);
  }
  return elastic;
}

void SeedMethod::particles_added(Index first) {
  ParticleSet& ps = ctx_.ps;
  for (Index i = first; i < ps.size(); ++i) {
    ps.rho[i] = P_.rho0;
    ps.p[i] = seed::pressure(P_.k, P_.rho0, P_.rho0);
    ps.a[i] = Vec2::Zero();
  }
}

std::size_t SeedMethod::bytes() const {
  return (inv_rho_.capacity() + lap_c_.capacity()) * sizeof(Real) +
         normal_.capacity() * sizeof(Vec2) + cell_floats_.bytes() + floats_.bytes();
}

template <unsigned F>
void SeedMethod::step_impl(Real dt, Real dt_cap) {
  evaluate_impl<F>();
  dt = ctx_.step_size(dt, dt_cap);
  ctx_.integrate<(F & kWalls) != 0, (F & kPeriodic) != 0>(dt, dt);  // semi-implicit Euler
  ctx_.timer.mark(kIntegrate);
  ctx_.leave_domain();
  ctx_.timer.mark(kDomain);
  ctx_.advance(dt);
}

template <unsigned F>
void SeedMethod::evaluate_impl() {
  ctx_.timer.start();
  density<F>();
  forces<F>();
  ctx_.timer.mark(kForces);
}

// Seed eq. 10 over the fluid pairs (with the neighbour search), the walls'
// ghosts and their share (4.1), and the state equation (15).
template <unsigned F>
void SeedMethod::density() {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  if constexpr (by_cells(F)) {
    ctx_.search.clusters(ps, P_.h, P_.mass, ctx_.team(), weight_, ctx_.timer);
    if (float_pairs_) {  // filled with the state equation (finish_eos)
      cell_floats_.resize(n);
      floats_.resize(n);
    }
  } else {
    ctx_.search.lists<(F & kPeriodic) != 0, pairs_once(F)>(ps, P_.h, P_.mass, ctx_.team(),
                                                           ctx_.box, weight_, ctx_.timer);
  }
  inv_rho_.resize(n);
  if constexpr (by_cells(F) && (F & kWalls) != 0) {
    // The walls' share with the ghost search, and the state equation in the
    // same parallel region, each thread on its range once its ghosts are found.
    Real* rho = ps.rho.data();
    ctx_.ghosts.find(
        ctx_.walls, ps.x.data(), n, P_.h, ctx_.team(), false,
        [&](Index i, Row<Vec2> ghosts) { rho[i] += ghost_density(ghosts); },
        [&](Index i0, Index i1) { finish_eos<F>(i0, i1); });
    ctx_.timer.mark(kGhosts);
  } else {
    if constexpr ((F & kWalls) != 0) {
      ctx_.ghosts.find(ctx_.walls, ps.x.data(), n, P_.h, ctx_.team(), false);
      ctx_.timer.mark(kGhosts);
    }
    const int nt = ctx_.team();
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int t = 0; t < nt; ++t) {
      const Share s = share_of(n, t, nt);
      finish_density<F>(s.first, s.last);
    }
    ctx_.timer.mark(kDensity);
  }
}

// The wall ghosts' share of a particle's density (4.1), summed in their order.
Real SeedMethod::ghost_density(Row<Vec2> ghosts) const {
  Real g = 0;
  for (const Vec2& r : ghosts) g += weight_(r.squaredNorm());
  return P_.ghost_mass_ratio * P_.mass * g;
}

// The ghosts' share of the density of particles [i0, i1), for those that have
// ghosts, then the state equation for all.
template <unsigned F>
void SeedMethod::finish_density(Index i0, Index i1) {
  if constexpr ((F & kWalls) != 0) {
    Real* rho = ctx_.ps.rho.data();
    ctx_.ghosts.rows().for_each_nonempty_row_in(
        i0, i1, [&](Index i, Row<Vec2> ghosts) { rho[i] += ghost_density(ghosts); });
  }
  finish_eos<F>(i0, i1);
}

// The state equation (eq. 15) of particles [i0, i1) whose densities are
// complete, in a loop the compiler vectorises; with the float pair forces
// also their data.
template <unsigned F>
void SeedMethod::finish_eos(Index i0, Index i1) {
  ParticleSet& ps = ctx_.ps;
  const Real* rho = ps.rho.data();
  Real* p = ps.p.data();
  Real* inv_rho = inv_rho_.data();
  const Real k = P_.k, rho0 = P_.rho0;
  if constexpr (by_cells(F)) {
    if (float_pairs_) {  // and the float pair forces' data
      cell_floats_.fill(ctx_.search.grid(), ps.x.data(), i0, i1);
      floats_.fill_velocities(ps.v.data(), i0, i1);
      float* pf = floats_.p.data();
      float* ir = floats_.ir.data();
      const Real inv_rho0 = 1 / rho0;
      for (Index i = i0; i < i1; ++i) {
        const Real pi = seed::pressure(k, rho[i], rho0), ri = 1 / rho[i];
        p[i] = pi;
        inv_rho[i] = ri;
        pf[i] = static_cast<float>(pi * inv_rho0);
        ir[i] = static_cast<float>(rho0 * ri);
      }
      // An outlet's buffer holds the reference pressure, plus the hydrostatic
      // head under gravity (Context::outlet_held, outlet_pressure).
      if (const std::int8_t* held = ctx_.outlet_held()) {
        const Real* head = ctx_.outlet_pressure();
        for (Index i = i0; i < i1; ++i)
          if (held[i]) {
            p[i] = head[i];
            pf[i] = static_cast<float>(head[i] * inv_rho0);
          }
      }
      return;
    }
  }
  for (Index i = i0; i < i1; ++i) {
    p[i] = seed::pressure(k, rho[i], rho0);
    inv_rho[i] = 1 / rho[i];
  }
  // An outlet's buffer holds the reference pressure, plus the hydrostatic
  // head under gravity (Context::outlet_held, outlet_pressure).
  if (const std::int8_t* held = ctx_.outlet_held()) {
    const Real* head = ctx_.outlet_pressure();
    for (Index i = i0; i < i1; ++i)
      if (held[i]) p[i] = head[i];
  }
}

// Pressure (eq. 14), viscosity (17) and colour-field surface tension (18-20);
// a = f / rho + g. Wall ghosts add pressure and viscosity only.
template <unsigned F>
void SeedMethod::forces() {
  if constexpr (by_cells(F)) {
    // Each pair block finished as soon as its sums are complete.
    forces_by_cells<(F & kViscosity) != 0>(
        [&](Index i0, Index i1) { finish_accelerations<F>(i0, i1); });
  } else {
    forces_by_lists<F>();
  }
}

template <bool Viscosity, class Finish>
void SeedMethod::forces_by_cells(Finish finish) {
#if SPHFLUID_AVX512
  if constexpr (CellPairs::kAvailable) {
    ParticleSet& ps = ctx_.ps;
    const CellGrid& grid = ctx_.search.grid();
    const CellPairs& cells = ctx_.search.cells();
    if (float_pairs_) {
      // Lengths in cells, pressures over rho0 and densities times 1/rho0:
      // the pair sums times s are force densities, with l to match.
      const Real cw = grid.cell_width();
      const Real s = -Real(0.5) * P_.mass * kern_.spiky_grad * cw * cw;
      const Real l = P_.eta * P_.mass * kern_.visc_lap * cw / (P_.rho0 * s);
      force_scale_ = s;
      const CellFloatFrame frame(cell_floats_, grid, kern_.h);
      const seed::ForcePairs<simd::F8, Viscosity, false, SplitVelocity<float>> pair{
          floats_.p.data(), floats_.ir.data(), {floats_.vx.data(), floats_.vy.data()},
          simd::F8::splat(float_not_above(CellFloatFrame::support(grid, kern_.h))),
          simd::F8::splat(static_cast<float>(l))};
      cells.pair_sums(grid, frame, pair, ps.a.data(), ctx_.team(), finish);
      return;
    }
    force_scale_ = seed_scale();
    const PositionFrame<simd::D8> frame(ps.x.data(), kern_.h);
    const simd::D8 h = simd::D8::splat(kern_.h), l = simd::D8::splat(seed_lap());
    const InterleavedVelocity v{ps.v.data()};
    if (recip_root_) {
      const seed::ForcePairs<simd::D8, Viscosity, true, InterleavedVelocity> pair{
          ps.p.data(), inv_rho_.data(), v, h, l};
      cells.pair_sums(grid, frame, pair, ps.a.data(), ctx_.team(), finish);
    } else {
      const seed::ForcePairs<simd::D8, Viscosity, false, InterleavedVelocity> pair{
          ps.p.data(), inv_rho_.data(), v, h, l};
      cells.pair_sums(grid, frame, pair, ps.a.data(), ctx_.team(), finish);
    }
    return;
  }
#endif
  (void)finish;
  throw std::logic_error("the cell-cluster loops need AVX-512F and VL");
}

// The fluid pairs over neighbour lists: each pair once over the half lists
// (its square root and division serve both particles), or, across periodic
// seams, each particle over its full list with its end right after.
template <unsigned F>
void SeedMethod::forces_by_lists() {
  constexpr bool kVisc = (F & kViscosity) != 0, kTension = (F & kSurfaceTension) != 0;
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const Vec2* x = ps.x.data();
  Vec2* a = ps.a.data();
  force_scale_ = seed_scale();
  const seed::ScalarForces<kVisc> forces{ps.p.data(), inv_rho_.data(), {ps.v.data()}, kern_.h,
                                         seed_lap()};
  if constexpr (pairs_once(F)) {
    if (!ctx_.search.has_half_lists(n))
      throw std::logic_error("the pair-once loop needs this evaluation's half lists");
    if constexpr (kTension) {
      normal_.resize(n);
      lap_c_.resize(n);
    }
    auto none = [](Index, const seed::ListSums&) {};
    const seed::ListVisitor<kVisc, kTension, false, decltype(none)> visitor{
        forces, colour_, P_.mass, colour_.self_lap(), a, normal_.data(), lap_c_.data(), none};
    pair_loops::once(ctx_.search.lists(), x, n, NeighbourSearch::pair_block(n), ctx_.team(),
                     visitor);
    if constexpr (kTension) {
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
      for (Index i = 0; i < n; ++i) finish_particle<F>(i, a[i], normal_[i], lap_c_[i]);
    } else {
      const int nt = ctx_.team();
#pragma omp parallel for schedule(static) num_threads(nt)
      for (int t = 0; t < nt; ++t) {
        const Share s = share_of(n, t, nt);
        finish_accelerations<F>(s.first, s.last);
      }
    }
  } else {
    auto finish = [this](Index i, const seed::ListSums& s) {
      finish_particle<F>(i, s.f, s.normal, s.lap);
    };
    const seed::ListVisitor<kVisc, kTension, true, decltype(finish)> visitor{
        forces, colour_, P_.mass, colour_.self_lap(), a, nullptr, nullptr, finish};
    const PeriodicBox& box = ctx_.box;
    pair_loops::gather(ctx_.search.lists(), x, n, ctx_.team(),
                       [&](const Vec2& p, const Vec2& q) { return box.delta(p, q); }, visitor);
  }
}

// The wall ghosts' pressure and viscosity on a particle (4.1) as the pair
// term (eqs. 14, 17) with ghosts of mass m_g and density rho_g, at rest, whose
// pressure, like the particle's in the pair, is the positive part of p_i: the
// wall pushes back as hard as the fluid presses, and never pulls. The sum in
// the units of the pair sums (times seed_scale(): force density).
template <unsigned F>
Vec2 SeedMethod::wall_sum(Row<Vec2> ghosts, Real pi, const Vec2& xi, const Vec2& vi) const {
  const Real w = P_.ghost_mass_ratio / (P_.ghost_density_ratio * P_.rho0);
  const Real p_sum = 2 * std::max(pi, Real(0)), h = kern_.h, l = seed_lap();
  Real sx = 0, sy = 0;
  // (a moving wall's ghosts move with it: the velocity relative to theirs)
  const bool moves = ctx_.walls.moves();
  for (const Vec2& r : ghosts) {
    Real tx, ty;
    const Vec2 u = moves ? VelocityToWall{ctx_.walls, xi, vi}(r) : vi;
    seed::PairForce<(F & kViscosity) != 0>::t(true, h, l, p_sum, r.x(), r.y(), r.squaredNorm(),
                                              u.x(), u.y(), 0.0, 0.0, tx, ty);
    sx += tx;
    sy += ty;
  }
  return Vec2(w * sx, w * sy);
}

// Where the fluid pairs are summed once (without tension), a[] holds their
// pair sums: for the particles [i0, i1), on the calling thread, the walls'
// share first, for the particles that have ghosts, then a = s a / rho + g for
// all (s = force_scale_, the pair sums' factor), in a loop the compiler
// vectorises.
template <unsigned F>
void SeedMethod::finish_accelerations(Index i0, Index i1) {
  ParticleSet& ps = ctx_.ps;
  Vec2* a = ps.a.data();
  const Real* rho = ps.rho.data();
  const Real s = force_scale_;
  if constexpr ((F & kWalls) != 0) {
    const Real* p = ps.p.data();
    const Vec2* v = ps.v.data();
    const Real ratio = seed_scale() / s;  // the walls' sum in the pair sums' units
    ctx_.ghosts.rows().for_each_nonempty_row_in(i0, i1, [&](Index i, Row<Vec2> ghosts) {
      const Vec2 w = wall_sum<F>(ghosts, p[i], ps.x[i], v[i]);
      a[i] = Vec2(ratio * w.x() + a[i].x(), ratio * w.y() + a[i].y());
    });
  }
  const Vec2 g = P_.gravity;
  Real* ad = reinterpret_cast<Real*>(a);
  for (Index i = i0; i < i1; ++i) {
    ad[2 * i] = s * ad[2 * i] / rho[i] + g.x();
    ad[2 * i + 1] = s * ad[2 * i + 1] / rho[i] + g.y();
  }
}

// A particle's end over lists: the walls' share of its pair sum, the factor
// s, the tension (eq. 20), a = f / rho + g.
template <unsigned F>
void SeedMethod::finish_particle(Index i, const Vec2& sum, const Vec2& normal, Real lap_c) {
  ParticleSet& ps = ctx_.ps;
  Vec2 total = sum;
  if constexpr ((F & kWalls) != 0) total += wall_sum<F>(ctx_.ghosts.row(i), ps.p[i], ps.x[i], ps.v[i]);
  Vec2 f = force_scale_ * total;
  if constexpr ((F & kSurfaceTension) != 0)
    f += seed::tension(normal, lap_c, P_.sigma, P_.effective_surface_threshold());
  ps.a[i] = f / ps.rho[i] + P_.gravity;
}

}  // namespace sphfluid
