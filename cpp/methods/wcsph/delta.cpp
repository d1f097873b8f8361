// wcsph with the continuity density (docs/method-wcsph.md, W17-W31) as
// ordered phases, each one parallel loop whose sums do not depend on the
// thread count: kick-drift-kick (W14) with the density drifted like a
// position (W22), around the rate (W17-W18, W20; with W30's strains), the
// Tait state equation without its clamp, the pair forces in the sum form
// (W19, W4-W6, W30; with W31 the pressure's on its kernel where nothing shifts) with
// the shifting sums (W21), and the walls (W8-W9, W20).
#include "methods/wcsph/delta.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "integrate.hpp"
#include "methods/wcsph/delta_pairs.hpp"
#include "neighbours/frames.hpp"
#include "neighbours/pair_loops.hpp"

namespace sphfluid {

namespace {
using delta::kSurfaceSum;
// The largest shift of one step, in spacings.
constexpr Real kShiftCap = 0.2;
// ... and at most this fraction of the largest speed times dt: a shift faster
// than the flow makes W27's rate outrun the pressure (the water dam break blew
// up at t = 0.69 s with 0.2 dx alone, which let particles shift at up to
// 27 m/s; half the largest speed made the cavity's error at 30 across 0.044
// against 0.034).
constexpr Real kShiftSpeed = 1.0;
// W31: the quintic spline's support where it carries the pressure, in
// spacings. Its square lattice is stable under a uniform pressure at 2.6-2.8
// (benchmarks/experiments/lattice_stability.py analysis 2.6,2.7,2.8 0 --quintic)
// and the pressure lends it almost no shear stiffness; at 2.5 and 2.9-3 it is
// unstable, as the Wendland kernel is at 2.8-3.5.
constexpr Real kQuinticSupport = 2.8;
}  // namespace

DeltaWcsphMethod::DeltaWcsphMethod(Context& ctx)
    : ctx_(ctx), P_(ctx.params()), kernel_(P_.h), weight_(kernel_), walls_(kernel_),
      pressure_kernel_(kQuinticSupport * spacing()), pressure_walls_(pressure_kernel_) {
  walls_.build(P_.spacing, P_.mass / P_.rho0, true);  // rows fixed to the wall (W20)
  const Real dx = spacing();
  inv_wdx_ = 1 / kernel_.value(dx);
  open_sum_ = delta::open_surface_sum(kernel_, dx, P_.mass / P_.rho0);
  inv_s_ = 1 / delta::gradient_normalisation(kernel_, dx, P_.mass / P_.rho0);  // W29
  // W31, asked for and within the search's reach (the loader refuses a support
  // h below 2.8 spacings with it; the core keeps W's pressure there)
  quintic_ = P_.quintic_pressure && pressure_kernel_.h <= P_.h * (1 + Real(1e-9));
  if (quintic_) {
    pressure_walls_.build(P_.spacing, P_.mass / P_.rho0, true);
    inv_s_quintic_ = 1 / delta::gradient_normalisation(pressure_kernel_, dx, P_.mass / P_.rho0);
  }
  alpha_ = delta::artificial_alpha(P_.alpha, P_.eta, P_.rho0, Real(0.5) * P_.h, P_.c0);
  reconstruct_ = P_.reconstruct_viscosity && alpha_ > 0;  // W30
  // The shift moves with its particle through the sort; with "auto" the field
  // waits for the fluid's shape (density()).
  if (P_.shifting > 0 && !P_.shift_confined) make_shift_fields();
  if (P_.sigma > 0)  // W10-W12; the colour kernel's support 4 dx (docs, "Surface tension")
    surface_ = SurfaceEnergy(P_.sigma, 4 * dx, dx, P_.domain_min, ctx.box);
  ctx_.ps.rho.set_kind(FieldKind::kState);  // carried from step to step
}

void DeltaWcsphMethod::select(unsigned features) {
  static constexpr auto steps = feature_table<Steps, StepFn>();
  static constexpr auto evals = feature_table<Evaluations, EvalFn>();
  step_fn_ = steps[features];
  eval_fn_ = evals[features];
}

// Whether a fluid at rest carries a hydrostatic pressure (W23): gravity, and
// no periodic axis along it.
bool DeltaWcsphMethod::hydrostatic() const {
  const bool along_seam = (P_.periodic_x && P_.gravity.x() != 0) ||
                          (P_.periodic_y && P_.gravity.y() != 0);
  return P_.gravity.norm() > 0 && !along_seam;
}

// Particle i's column: one spacing wide, across gravity (W23, W23b).
std::int64_t DeltaWcsphMethod::column(Index i) const {
  const Vec2 up = -P_.gravity.normalized(), across(up.y(), -up.x());
  return static_cast<std::int64_t>(std::floor(ctx_.ps.x[i].dot(across) / spacing()));
}

Real DeltaWcsphMethod::spacing() const {
  return P_.spacing > 0 ? P_.spacing : std::sqrt(P_.mass / P_.rho0);
}

// New particles start at the density of the hydrostatic pressure at their
// depth below the fluid above them (W23): the highest particle of their
// column is half a spacing below the surface. Without gravity, or with a
// periodic axis along it, at rho0.
void DeltaWcsphMethod::particles_added(Index first) {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  if (first == 0) {  // a new fluid (set_state): "auto" shifting decides again
    shape_known_ = confined_ = shift_ready_ = false;
  }
  if (shift_) {  // new particles were not shifted by the last drift (W27's share)
    for (Index i = first; i < n; ++i) (*shift_)[i] = Vec2::Zero();
  }
  if (!hydrostatic()) {
    for (Index i = first; i < n; ++i) ps.rho[i] = P_.rho0;
    return;
  }
  const Real gl = P_.gravity.norm();
  const Vec2 up = -P_.gravity / gl;
  // The highest particle of each new particle's column (of every column for
  // a new fluid; an emitter's rows are in a few).
  std::unordered_map<std::int64_t, Real> top;
  for (Index i = first; i < n; ++i) top.emplace(column(i), ps.x[i].dot(up));
  for (Index i = 0; i < first; ++i) {
    auto it = top.find(column(i));
    if (it != top.end()) it->second = std::max(it->second, ps.x[i].dot(up));
  }
  for (Index i = first; i < n; ++i) {
    Real& z = top[column(i)];
    z = std::max(z, ps.x[i].dot(up));
  }
  const Real B = P_.rho0 * P_.c0 * P_.c0 / wcsph::kTaitGamma, half = Real(0.5) * spacing();
  for (Index i = first; i < n; ++i) {
    const Real depth = top[column(i)] - ps.x[i].dot(up) + half;
    ps.rho[i] = wcsph::tait_density(P_.rho0 * gl * depth, P_.rho0, B);
  }
}

// W23b: the scene's fluid, at W23's densities, compressed along gravity to
// them. In each column, from its lowest particle up, every gap along gravity
// (and the half spacing below the lowest particle, down to what it rests on)
// shrinks by rho0 / rho, the mean of its two ends' (a gap wider than 1.5
// spacings, or one a wall crosses, ends a run: the run above it rests on its
// own lowest particle; a particle whose move would meet a wall stays and
// starts one). Across gravity nothing moves; the densities stay: the weight
// above a particle is its column's mass, however compressed.
bool DeltaWcsphMethod::fluid_filled() {
  if (!hydrostatic()) return false;
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const Vec2 up = -P_.gravity.normalized();
  std::vector<std::pair<std::int64_t, Real>> key(n);
  std::vector<Index> order(n);
  for (Index i = 0; i < n; ++i) {
    key[i] = {column(i), ps.x[i].dot(up)};
    order[i] = i;
  }
  std::sort(order.begin(), order.end(), [&](Index a, Index b) {
    return key[a] < key[b] || (key[a] == key[b] && a < b);
  });
  const WallSet& walls = ctx_.walls;
  const Real rho0 = P_.rho0, dx = spacing();
  std::vector<Real> drop(n, 0);
  Real shift = 0;  // the particle below's move
  for (Index k = 0; k < n; ++k) {
    const Index i = order[k], j = k > 0 ? order[k - 1] : i;
    const Real gap = key[i].second - key[j].second;
    if (k > 0 && key[j].first == key[i].first && gap <= Real(1.5) * dx &&
        !walls.meets(ps.x[j], ps.x[i])) {
      shift += gap * (1 - Real(0.5) * (rho0 / ps.rho[i] + rho0 / ps.rho[j]));
    } else {
      shift = Real(0.5) * dx * (1 - rho0 / ps.rho[i]);
    }
    if (walls.meets(ps.x[i], ps.x[i] - shift * up)) shift = 0;
    drop[i] = shift;
  }
  for (Index i = 0; i < n; ++i) ps.x[i] -= drop[i] * up;
  return n > 0;
}

void DeltaWcsphMethod::make_shift_fields() {
  if (shift_) return;
  ParticleSet& ps = ctx_.ps;
  shift_ = std::make_unique<Field<Vec2>>(ps, "shift", FieldKind::kState);
  shift_sum_ = std::make_unique<Field<Vec2>>(ps, "shift_sum", FieldKind::kDerived);
  colour_ = std::make_unique<Field<Vec2>>(ps, "colour_gradient", FieldKind::kDerived);
}

std::vector<Real> DeltaWcsphMethod::carried() const {
  return {Real(shape_known_), Real(confined_), Real(shift_ready_), shift_per_dt_,
          Real(shift_ != nullptr)};
}

void DeltaWcsphMethod::restore_carried(const std::vector<Real>& values) {
  if (values.size() != 5)
    throw std::invalid_argument("checkpoint: wcsph's continuity density carries 5 numbers, "
                                "not " + std::to_string(values.size()));
  shape_known_ = values[0] != 0;
  confined_ = values[1] != 0;
  shift_ready_ = values[2] != 0;
  shift_per_dt_ = values[3];
  if (values[4] != 0) {
    make_shift_fields();
  } else {
    shift_.reset();
    shift_sum_.reset();
    colour_.reset();
  }
}

// W3 without the clamp: below rho0 the energy of the stretched state.
Real DeltaWcsphMethod::elastic_energy() const {
  const Real B = P_.rho0 * P_.c0 * P_.c0 / wcsph::kTaitGamma;
  Real elastic = 0;
  for (Index i = 0; i < ctx_.size(); ++i)
    elastic += P_.mass * wcsph::elastic_energy(ctx_.ps.rho[i] / P_.rho0, P_.rho0, B);
  return elastic;
}

std::size_t DeltaWcsphMethod::bytes() const {
  return (lap_.capacity() + inv_rho_.capacity()) * sizeof(Real) +
         (rate_lap_.capacity() + grad_x_.capacity() + grad_y_.capacity()) * sizeof(Vec2) +
         (strain_[0].capacity() + strain_[1].capacity() + strain_[2].capacity()) * sizeof(Real) +
         walls_.bytes() + (quintic_ ? pressure_walls_.bytes() : 0) + surface_.bytes();
}

// Kick-drift-kick with the density drifted like a position (W22): v += dt/2 a;
// x += dt v + shift; at the new positions the rate from the half-step
// velocities, rho += dt D, then the forces; v += dt/2 a.
template <unsigned F>
void DeltaWcsphMethod::step_impl(Real dt, Real dt_cap) {
  dt = ctx_.step_size(dt, dt_cap);
  const Real half = Real(0.5) * dt;
  const bool shifted = P_.shifting > 0 && shift_for<F>(dt);
  shift_per_dt_ = shifted ? 1 / dt : 0;
  ctx_.integrate<(F & kWalls) != 0, (F & kPeriodic) != 0>(dt, half,
                                                           shifted ? shift_->data() : nullptr);
  ctx_.timer.mark(kIntegrate);
  ctx_.leave_domain();
  ctx_.timer.mark(kDomain);
  evaluate_kick<F>(dt, half);
  ctx_.advance(dt);
}

template <unsigned F>
void DeltaWcsphMethod::evaluate_kick(Real dt, Real half) {
  ctx_.timer.start();
  neighbours<F>();
  density<F>(dt);
  if constexpr ((F & kSurfaceTension) != 0) {
    surface_.evaluate(ctx_.ps.x.data(), ctx_.size(), P_.mass, ctx_.team());
    ctx_.timer.mark(kForces);
  }
  state();
  forces<F>();
  ctx_.add_gravity_and_kick(half, (F & kSurfaceTension) != 0 ? surface_.accelerations() : nullptr);
  ctx_.timer.mark(kForces);
}

// The sort and the pairs' structure (the kernel sums go to sums_, not to the
// density): cell clusters where they run, else full lists;
// and the walls' ghosts with their share of the kernel sums.
template <unsigned F>
void DeltaWcsphMethod::neighbours() {
  ParticleSet& ps = ctx_.ps;
  by_cells_ = false;
  if constexpr (by_cells(F)) {
    by_cells_ = true;
    ctx_.search.clusters(ps, P_.h, P_.mass / P_.rho0, ctx_.team(), weight_, ctx_.timer,
                         sums_.data());
  }
  if (!by_cells_)
    ctx_.search.lists<(F & kPeriodic) != 0, false>(ps, P_.h, P_.mass / P_.rho0, ctx_.team(),
                                                   ctx_.box, weight_, ctx_.timer, sums_.data());
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.find(ctx_.walls, ps.x.data(), ps.size(), P_.h, ctx_.team(), true);
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
      Real s = sums_[i];
      wcsph::add_wall_density(walls_, 1, ghosts, s);
      sums_[i] = s;
    });
    ctx_.timer.mark(kGhosts);
  }
}

// The rate pass's pair sums into rl (rate, W24's sum): by cell clusters or
// over full lists; with Shift, W27's share of this step's shifts; with
// Gradient, W30's velocity-gradient sums into grad_x_ and grad_y_.
template <unsigned F, bool Shift, bool Gradient, class Constants>
void DeltaWcsphMethod::rate_pass(Constants constants, Vec2* rl) {
  ParticleSet& ps = ctx_.ps;
  auto pairs = [&](auto lane) {
    using L = decltype(lane);
    delta::RatePairs<L, Shift, Gradient> p{ps.rho.data(), inv_rho_.data(), {ps.v.data()},
                                           kernel_, constants(lane)};
    if constexpr (Shift) {
      p.shift = {shift_->data()};
      p.per_dt = simd::splat<L>(shift_per_dt_);
    }
    return p;
  };
#if SPHFLUID_AVX512
  if constexpr (by_cells(F)) {
    if (by_cells_) {
      const PositionFrame<simd::D8> frame(ps.x.data(), P_.h);
      if constexpr (Gradient) {
        ctx_.search.cells().pair_sums(ctx_.search.grid(), frame, pairs(simd::D8{}),
                                      std::array<Vec2*, 3>{rl, grad_x_.data(), grad_y_.data()},
                                      ctx_.team());
      } else {
        ctx_.search.cells().pair_sums(ctx_.search.grid(), frame, pairs(simd::D8{}), rl,
                                      ctx_.team());
      }
      return;
    }
  }
#endif
  using Pairs = delta::RatePairs<Real, Shift, Gradient>;
  constexpr std::size_t N = Pairs::kOutputs;
  const Pairs rates = pairs(Real{});
  struct Sums {
    Real ix[N], iy[N];
  };
  struct Visitor {
    const Pairs& rates;
    Vec2* out[3];
    Sums begin(Index) const { return Sums{}; }
    void pair(Sums& s, Index i, Index j, const Vec2& r, Real r2, bool) const {
      typename Pairs::Data d;
      rates.load(j, Span1{}, d);
      Real jx[N] = {}, jy[N] = {};
      if constexpr (Gradient) {
        rates.add(i, d, true, r.x(), r.y(), r2, s.ix, s.iy, jx, jy);
      } else {
        rates.add(i, d, true, r.x(), r.y(), r2, s.ix[0], s.iy[0], jx[0], jy[0]);
      }
    }
    void end(Index i, const Sums& s) const {
      for (std::size_t o = 0; o < N; ++o) out[o][i] = Vec2(s.ix[o], s.iy[o]);
    }
  } visitor{rates, {rl, grad_x_.data(), grad_y_.data()}};
  const PeriodicBox& box = ctx_.box;
  pair_loops::gather(ctx_.search.lists(), ps.x.data(), ps.size(), ctx_.team(),
                     [&](const Vec2& p, const Vec2& q) { return box.delta(p, q); }, visitor);
}

// The rate pass (rate_pass) as this step needs it: with W27's share where the
// last drift shifted; where W30 reconstructs, with its velocity-gradient sums,
// from which each particle's strain follows (with W24's fluid sum, before the
// walls' share is added).
template <unsigned F, class Constants>
void DeltaWcsphMethod::rates(Constants constants, Vec2* rl) {
  const Index n = ctx_.size();
  if (!reconstruct_) {
    if (shift_per_dt_ > 0) {
      rate_pass<F, true, false>(constants, rl);
    } else {
      rate_pass<F, false, false>(constants, rl);
    }
    return;
  }
  grad_x_.resize(n);
  grad_y_.resize(n);
  for (std::vector<Real>& e : strain_) e.resize(n);
  if (shift_per_dt_ > 0) {
    rate_pass<F, true, true>(constants, rl);
  } else {
    rate_pass<F, false, true>(constants, rl);
  }
  const Vec2* gx = grad_x_.data();
  const Vec2* gy = grad_y_.data();
  Real* exx = strain_[0].data();
  Real* eyy = strain_[1].data();
  Real* exy = strain_[2].data();
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    const delta::Strain st = delta::reconstruction_strain(gx[i], gy[i], rl[i].y());
    exx[i] = st.xx;
    eyy[i] = st.yy;
    exy[i] = st.xy;
  }
}

// The rate of each particle's density (W17-W18, the walls' W20) from the
// half-step velocities at the new positions, with the viscous term's
// normalisation sum (W24), then rho += dt D.
template <unsigned F>
void DeltaWcsphMethod::density(Real dt) {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  rate_lap_.resize(n);
  lap_.resize(n);
  const Real hs = Real(0.5) * P_.h, k = P_.rho0 / (P_.c0 * P_.c0);
  auto constants = [&](auto lane) {
    using L = decltype(lane);
    return delta::RateConstants<L>{simd::splat<L>(P_.mass), simd::splat<L>(P_.delta * hs * P_.c0),
                                   simd::splat<L>(k * P_.gravity.x()),
                                   simd::splat<L>(k * P_.gravity.y())};
  };
  Vec2* rl = rate_lap_.data();
  inv_rho_.resize(n);
  {
    const Real* rho = ps.rho.data();
    Real* ir = inv_rho_.data();
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
    for (Index i = 0; i < n; ++i) ir[i] = 1 / rho[i];
  }
  rates<F>(constants, rl);
  const Real* rho = ps.rho.data();
  const Vec2* v = ps.v.data();
  if constexpr ((F & kWalls) != 0) {
    ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
      Real d = rl[i].x(), l = rl[i].y();
      if (ctx_.walls.moves()) {  // the rows move with their wall
        delta::add_wall_rate(walls_, ghosts, rho[i], VelocityToWall{ctx_.walls, ps.x[i], v[i]}, d);
      } else {
        delta::add_wall_rate(walls_, ghosts, rho[i], VelocityAsIs{v[i]}, d);
      }
      delta::add_wall_laplacian(walls_, ghosts, l);
      rl[i] = Vec2(d, l);
    });
  }
  Real* rho_w = ps.rho.data();
  const Real least = P_.mass * kernel_.value(0);  // W22b
  Real* lap = lap_.data();
  const Real* sums = sums_.data();
  const Real rho0 = P_.rho0;
  const bool floor_pressure = P_.surface_pressure;  // W26b, else W26
  Index surface = 0;
#pragma omp parallel for schedule(static) num_threads(ctx_.team()) reduction(+ : surface)
  for (Index i = 0; i < n; ++i) {
    // W22b: not below m W(0), a lone particle's summed density, nor below itself there
    const Real carried = std::max(rho_w[i] + dt * rl[i].x(), std::min(rho_w[i], least));
    rho_w[i] = floor_pressure ? carried : delta::surface_floor(carried, sums[i], rho0);
    lap[i] = delta::laplacian_norm(rl[i].y());
    if (!shape_known_) surface += sums[i] < open_sum_;
  }
  if (!shape_known_ && n > 0) {  // shift_confined: the fluid's shape at the start
    confined_ = surface == 0;
    shape_known_ = true;
    if (shifts_next()) make_shift_fields();
  }
  ctx_.timer.mark(kDensity);
}

// W3 without the clamp (with the continuity density a free surface keeps its
// density, and pressures below the background are real), and 1 / rho.
void DeltaWcsphMethod::state() {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const Real rho0 = P_.rho0, B = rho0 * P_.c0 * P_.c0 / wcsph::kTaitGamma;
  const Real pb = P_.background_pressure;
  inv_rho_.resize(n);
  const Real* rho = ps.rho.data();
  Real* p = ps.p.data();
  Real* inv_rho = inv_rho_.data();
  const Real* sums = sums_.data();
  const bool floor_pressure = P_.surface_pressure;  // W26b
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    const Real r = rho[i] / rho0, r2 = r * r, r3 = r2 * r;
    p[i] = B * (r3 * r3 * r - 1) + pb;
    if (floor_pressure) p[i] = delta::surface_pressure(p[i], sums[i], rho[i], rho0);
    inv_rho[i] = 1 / rho[i];
  }
  ctx_.timer.mark(kDensity);
}

template <unsigned F, class L, bool R, bool Q>
delta::ForcePairs<L, (F & kViscosity) != 0, R, Q> DeltaWcsphMethod::force_pairs() const {
  const ParticleSet& ps = ctx_.ps;
  return {ps.rho.data(), ps.p.data(), inv_rho_.data(), lap_.data(), {ps.v.data()}, kernel_,
          constants<L>(), simd::splat<L>(Q ? inv_s_quintic_ : inv_s_), strain_[0].data(),
          strain_[1].data(), strain_[2].data(), simd::splat<L>(1 / (spacing() * spacing())),
          pressure_kernel_};
}

// The force pass by cell clusters: with shifting, its three sums at once;
// with R, W30's reconstruction; with Q (nothing shifts), W31's pressure.
// Returns false where the clusters do not run.
template <unsigned F, bool R, bool Q>
bool DeltaWcsphMethod::forces_by_cells() {
#if SPHFLUID_AVX512
  if constexpr (by_cells(F)) {
    if (!by_cells_) return false;
    constexpr bool kVisc = (F & kViscosity) != 0;
    ParticleSet& ps = ctx_.ps;
    const bool shifting = shift_ready_;  // (never with Q: forces())
    // eight lanes a group (four: 10 % slower at 10k, three spacings' support)
    const PositionFrame<simd::D8> frame(ps.x.data(), P_.h);
    const CellPairs& cells = ctx_.search.cells();
    Vec2* a = ps.a.data();
    if constexpr (Q) {  // W31 where nothing shifts
      cells.pair_sums(ctx_.search.grid(), frame, force_pairs<F, simd::D8, R, Q>(), a,
                      ctx_.team());
    } else if (shifting) {
      const delta::ShiftForcePairs<simd::D8, kVisc, R> pair{force_pairs<F, simd::D8, R>(),
                                                            simd::splat<simd::D8>(inv_wdx_)};
      cells.pair_sums(ctx_.search.grid(), frame, pair,
                      std::array<Vec2*, 3>{a, shift_sum_->data(), colour_->data()}, ctx_.team());
    } else {
      cells.pair_sums(ctx_.search.grid(), frame, force_pairs<F, simd::D8, R, Q>(), a,
                      ctx_.team());
    }
    if constexpr ((F & kWalls) != 0) {
      ctx_.ghosts.rows().for_each_nonempty_row(ctx_.team(), [&](Index i, Row<Vec2> ghosts) {
        Vec2 f = a[i];
        add_wall_force<F, Q>(i, ghosts, f);
        a[i] = f;
        if (shifting) (*shift_sum_)[i] = Vec2::Zero();  // within h of a wall: no shift
      });
    }
    return true;
  }
#endif
  return false;
}

// The pair forces (W19 with W4-W6) with, where something shifts, the
// shifting sums (W21) and the colour gradient: by cell clusters, each pair
// once, the walls' share (W8-W9, W20) after; or over full lists, each
// particle's walls right after its pairs.
template <unsigned F>
void DeltaWcsphMethod::forces() {
  shift_ready_ = shifts_next();  // whether the next drift shifts (shift_for)
  const bool quintic = quintic_ && !shift_ready_;  // W31
  if (reconstruct_) {
    quintic ? forces_with<F, true, true>() : forces_with<F, true, false>();
  } else {
    quintic ? forces_with<F, false, true>() : forces_with<F, false, false>();
  }
  ctx_.timer.mark(kForces);
}

template <unsigned F, bool R, bool Q>
void DeltaWcsphMethod::forces_with() {
  ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  const bool shifting = shift_ready_;  // the shifting sums only where they are used
  if (forces_by_cells<F, R, Q>()) return;
  struct Sums {
    Vec2 f, s, c;
  };
  const auto force = force_pairs<F, Real, R, Q>();
  const Real* ir = inv_rho_.data();
  const Real m = P_.mass, inv_wdx = inv_wdx_;
  const Wendland& W = kernel_;
  auto add_pair = [&](Sums& sum, Index i, Index j, const Vec2& r, Real r2) {
    typename decltype(force)::Data d;
    force.load(j, Span1{}, d);
    Real jx = 0, jy = 0;
    force.add(i, d, true, r.x(), r.y(), r2, sum.f.x(), sum.f.y(), jx, jy);
    if (!shifting) return;
    const Real rl = std::sqrt(r2), vj = m * ir[j];
    sum.s += (delta::shift_weight(W, rl, inv_wdx) * vj) * r;
    sum.c += (W.gradient_factor(rl) * vj) * r;
  };
  auto finish = [&](Index i, const Sums& sum) {
    Vec2 f = sum.f, s = sum.s;
    if constexpr ((F & kWalls) != 0) {
      const Row<Vec2> ghosts = ctx_.ghosts.row(i);
      add_wall_force<F, Q>(i, ghosts, f);
      if (shifting && ghosts.begin() != ghosts.end()) s.setZero();  // within h of a wall
    }
    ps.a[i] = f;
    if (shifting) {
      (*shift_sum_)[i] = s;
      (*colour_)[i] = sum.c;
    }
  };
  struct Visitor {
    decltype(add_pair)& on_pair;
    decltype(finish)& on_end;
    Sums begin(Index) const { return {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()}; }
    void pair(Sums& s, Index i, Index j, const Vec2& r, Real r2, bool) const {
      on_pair(s, i, j, r, r2);
    }
    void end(Index i, const Sums& s) const { on_end(i, s); }
  } visitor{add_pair, finish};
  const PeriodicBox& box = ctx_.box;
  pair_loops::gather(ctx_.search.lists(), ps.x.data(), n, ctx_.team(),
                     [&](const Vec2& a, const Vec2& b) { return box.delta(a, b); }, visitor);
}


// The walls' push on particle i (W8-W9's pressure and artificial viscosity,
// W25's friction, W20's hydrostatic part) added to f; with Q the pressure's
// parts (W8, W20) on W31's kernel, as the fluid pairs' pressure.
template <unsigned F, bool Q>
void DeltaWcsphMethod::add_wall_force(Index i, Row<Vec2> ghosts, Vec2& f) const {
  const ParticleSet& ps = ctx_.ps;
  const Real* p = ps.p.data();
  const Real* ir = inv_rho_.data();
  const Vec2* v = ps.v.data();
  // W8 and W9's artificial viscosity, the rows at the particle's density
  // (W20); the physical one by W25's rows
  const wcsph::PairConstants<Real> c = constants<Real>();
  const WallTables& pressure = Q ? pressure_walls_ : walls_;
  const Real inv_s = Q ? inv_s_quintic_ : inv_s_;
  const Real pi2 = inv_s * p[i] * ir[i] * ir[i];
  if (ctx_.walls.moves()) {  // the ghosts move with their wall
    wcsph::add_wall_force<false>(pressure, kernel_, c, 1 / ir[i], ghosts, pi2, ir[i],
                                 VelocityToWall{ctx_.walls, ps.x[i], v[i]}, f);
  } else {
    wcsph::add_wall_force<false>(pressure, kernel_, c, 1 / ir[i], ghosts, pi2, ir[i],
                                 VelocityAsIs{v[i]}, f);
  }
  if constexpr ((F & kViscosity) != 0) {
    if (ctx_.walls.moving()) {
      delta::add_wall_friction(walls_, ghosts, P_.eta, lap_[i], ir[i],
                               VelocityToSurface{ctx_.walls, ps.x[i], v[i]}, f);
    } else {
      delta::add_wall_friction(walls_, ghosts, P_.eta, lap_[i], ir[i], VelocityAsIs{v[i]}, f);
    }
  }
  delta::add_wall_hydrostatic(pressure, ghosts, inv_s * P_.gravity, f);  // W29's 1 / S
}

// W21: the next drift's shift, -k U dt hs s_i (U the largest speed, hs = h/2),
// at most kShiftCap spacings and kShiftSpeed U dt; near a free surface (kernel
// sum below kSurfaceSum) only its part along the surface, whose normal is
// minus the colour gradient; none within h of a wall (the walls' rows rest,
// and their share of the rate follows the flow's velocity alone). Returns
// false where nothing shifts (no sums: shifts_next()).
template <unsigned F>
bool DeltaWcsphMethod::shift_for(Real dt) {
  const ParticleSet& ps = ctx_.ps;
  const Index n = ps.size();
  if (!shift_ready_) return false;
  Real v2 = 0;
#pragma omp parallel for schedule(static) num_threads(ctx_.team()) reduction(max : v2)
  for (Index i = 0; i < n; ++i) v2 = std::max(v2, ps.v[i].squaredNorm());
  const Real scale = -P_.shifting * std::sqrt(v2) * dt * Real(0.5) * P_.h;
  if (!(scale < 0)) return false;
  const Real dx = spacing();
  const Real cap = std::min(kShiftCap * dx, kShiftSpeed * std::sqrt(v2) * dt);
#pragma omp parallel for schedule(static) num_threads(ctx_.team())
  for (Index i = 0; i < n; ++i) {
    Vec2 d = scale * (*shift_sum_)[i];  // none within h of a wall (forces())
    if (sums_[i] < kSurfaceSum) {
      const Real cl = (*colour_)[i].norm();
      if (cl > 0) {
        const Vec2 normal = (*colour_)[i] / cl;
        d -= d.dot(normal) * normal;
      } else {
        d.setZero();
      }
    }
    const Real dl = d.norm();
    if (dl > cap) d *= cap / dl;
    (*shift_)[i] = d;
  }
  return true;
}

}  // namespace sphfluid
