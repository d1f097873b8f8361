// The seed method (docs/method-seed.md): the step of the paper's pseudocode
// (4.3) as named phases: the neighbour search with the fluid density (eq. 10),
// the walls' ghosts and their share of it (4.1), the state equation (15), the
// pair forces (14, 17) with the colour field's sums (18-19) where the scene
// has tension, the walls' forces and the tension (20), the semi-implicit
// Euler integration with the wall collision (4.2), and the domain's edge.
// Each phase is one parallel loop whose sums do not depend on the thread
// count; the step is compiled once per feature set (core/features.hpp).
#pragma once

#include <array>
#include <vector>

#include "context.hpp"
#include "core/features.hpp"
#include "methods/method.hpp"
#include "neighbours/frames.hpp"
#include "terms/kernels.hpp"
#include "terms/seed.hpp"

namespace sphfluid {

// The float path's copies of the pair forces' per-particle data (besides the
// positions in their cells, CellFloats): p / rho0, rho0 / rho and v, rounded
// once per evaluation. The density stays in double (a stiff state equation
// would amplify a float density's round-off into the pressure).
struct SeedFloats {
  std::vector<float> p, ir, vx, vy;
  void resize(Index n) {
    for (auto* a : {&p, &ir, &vx, &vy}) a->resize(static_cast<std::size_t>(n));
  }
  std::size_t bytes() const {
    std::size_t sum = 0;
    for (const auto* a : {&p, &ir, &vx, &vy}) sum += a->capacity();
    return sum * sizeof(float);
  }
  // vx, vy of particles [i0, i1) from v.
  void fill_velocities(const Vec2* v, Index i0, Index i1);
};

class SeedMethod final : public SphMethod {
 public:
  explicit SeedMethod(Context& ctx);

  void select(unsigned features) override;
  void step(Real dt, Real dt_cap) override { step_fn_(*this, dt, dt_cap); }
  void evaluate() override { eval_fn_(*this); }
  Real elastic_energy() const override;
  // Particles added after a step's evaluation (an emitter's rows, an inlet's)
  // hold the rest values until the next step evaluates them: rho0, the state
  // equation's pressure there (0), no acceleration.
  void particles_added(Index first) override;
  bool float_pairs() const override { return float_pairs_; }
  bool recip_root() const override { return recip_root_; }
  std::size_t bytes() const override;

  // The instantiations over the feature sets (core/features.hpp).
  struct Steps {
    template <unsigned F>
    static void run(SeedMethod& m, Real dt, Real dt_cap) {
      m.step_impl<F>(dt, dt_cap);
    }
  };
  struct Evaluations {
    template <unsigned F>
    static void run(SeedMethod& m) {
      m.evaluate_impl<F>();
    }
  };

 private:
  // Whether a step with these features takes its fluid pairs by cell
  // clusters (neighbours/cell_pairs.hpp), without lists: where the lanes run
  // and without periodic seams or surface tension (the colour field keeps
  // the lists).
  static constexpr bool by_cells(unsigned features) {
    return CellPairs::kAvailable && (features & (kPeriodic | kSurfaceTension)) == 0;
  }

  template <unsigned F> void step_impl(Real dt, Real dt_cap);
  template <unsigned F> void evaluate_impl();
  // The phases.
  template <unsigned F> void density();
  template <unsigned F> void forces();
  // The per-particle ends of the density and force passes, for particles
  // [i0, i1) on the calling thread: per thread after the pairs, or (the
  // clusters) per pair block as soon as its sums are complete.
  template <unsigned F> void finish_density(Index i0, Index i1);
  template <unsigned F> void finish_eos(Index i0, Index i1);
  template <unsigned F> void finish_accelerations(Index i0, Index i1);
  // A particle's end over full lists: walls, tension, acceleration.
  template <unsigned F> void finish_particle(Index i, const Vec2& sum, const Vec2& normal,
                                             Real lap_c);
  template <bool Viscosity, class Finish> void forces_by_cells(Finish finish);
  template <unsigned F> void forces_by_lists();
  // The walls' share of a particle's density (4.1) and of its pair sums.
  Real ghost_density(Row<Vec2> ghosts) const;
  template <unsigned F>
  Vec2 wall_sum(Row<Vec2> ghosts, Real pi, const Vec2& xi, const Vec2& vi) const;

  // The pair sums times seed_scale() are force densities (-m/2 spiky_grad),
  // and seed_lap() is the viscosity's factor in them (eta m visc_lap / seed_scale()).
  Real seed_scale() const { return -Real(0.5) * P_.mass * kern_.spiky_grad; }
  Real seed_lap() const { return P_.eta * P_.mass * kern_.visc_lap / seed_scale(); }

  using StepFn = void(SeedMethod&, Real, Real);
  using EvalFn = void(SeedMethod&);

  Context& ctx_;
  const SimParams& P_;
  Kernels kern_;
  Poly6Weight weight_;
  seed::ColourField colour_;
  StepFn* step_fn_ = nullptr;  // the step of the scene's feature set
  EvalFn* eval_fn_ = nullptr;

  std::vector<Real> inv_rho_;  // 1 / rho, per particle, from the density pass
  std::vector<Vec2> normal_;   // with tension, over half lists: the colour field's gradient
  std::vector<Real> lap_c_;    // ... and its Laplacian
  // The pair forces in float (SimParams::float_pairs, where the cell clusters
  // run): the per-particle floats they read.
  bool float_pairs_ = false;
  CellFloats cell_floats_;
  SeedFloats floats_;
  // The double pair forces by cell clusters take 1/r from rsqrt14 and Newton
  // steps on this CPU (simd::prefers_recip_root).
  bool recip_root_;
  Real force_scale_ = 1;  // the factor of this evaluation's pair sums in a[]
};

}  // namespace sphfluid
