// The dfsph method (docs/method-dfsph.md): divergence-free SPH after Bender &
// Koschier (2015, 2017), in 2D. Its step as named phases: the step size from
// the flow (no speed of sound), the constant-density solve on the predicted
// velocities (D6), the kick and drift (with the wall collision and the
// guard), the domain's edge, then at the new positions: the neighbour search
// with the summation density (D1), the walls' ghosts and shares (W7, D2), the
// stiffness factors (D3), the divergence-free solve on the velocities (D6),
// and the non-pressure accelerations of the next step (viscosity W6/W9, the
// tension W10-W12, gravity). Both solves are conjugate residuals on
// per-particle pressure values preconditioned by the stiffness factors,
// warm-started from the previous step's, over a pair table made with the
// search: each sum in one order whatever the thread count. The inlets' and
// outlets' buffers enter them as boundaries (find_buffers).
#pragma once

#include <cstdint>
#include <vector>

#include "context.hpp"
#include "core/features.hpp"
#include "methods/method.hpp"
#include "methods/wcsph/surface_energy.hpp"
#include "terms/dfsph.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

class DfsphMethod final : public SphMethod {
 public:
  explicit DfsphMethod(Context& ctx);

  void select(unsigned features) override;
  void step(Real dt, Real dt_cap) override { step_fn_(*this, dt, dt_cap); }
  void evaluate() override { eval_fn_(*this); }
  // Incompressible: no state equation stores energy.
  Real elastic_energy() const override { return 0; }
  Real surface_energy() const override { return surface_.energy(); }
  SolveStats solve_stats() const override { return stats_; }
  void particles_added(Index first) override;
  void flows_changed() override { find_buffers(); }
  // A checkpoint's fields replace the state: the next step evaluates first.
  void restore_carried(const std::vector<Real>&) override { evaluated_ = false; }
  std::size_t bytes() const override;

  struct Steps {
    template <unsigned F>
    static void run(DfsphMethod& m, Real dt, Real dt_cap) {
      m.step_impl<F>(dt, dt_cap);
    }
  };
  struct Evaluations {
    template <unsigned F>
    static void run(DfsphMethod& m) {
      m.neighbours<F>();
      m.non_pressure<F>();
    }
  };

 private:
  template <unsigned F> void step_impl(Real dt, Real dt_cap);
  // The search, the density (D1) and the walls' shares, and the stiffness
  // factors (D3), at the current positions.
  template <unsigned F> void neighbours();
  // a = the viscosity (W6, W9) + the walls' fluid's pressure along them (D8)
  // + the tension + g, kept for the next step.
  template <unsigned F> void non_pressure();
  // The constant-density solve: the velocities v + dt a corrected until the
  // density they make over dt is within the tolerance of the reference (D7);
  // a then holds the total acceleration. The divergence-free solve: v corrected until its
  // rate of density change is within the tolerance.
  void density_solve(Real dt);
  // roles_ and unknowns_ at the current positions.
  void find_buffers();
  void divergence_solve(Real dt);
  // One solve on the velocities u (n): the pressure values k (a field, warm
  // start in, result out) with per-particle error e_i = base_i + dt
  // rho_rate_i(u) - rho0 (base: rho0 + the step's share of rho - rho_ref for
  // the density, rho0 for the divergence), until the mean error share (D6,
  // D7) <= tol; iterations and the last mean.
  struct Solve {
    int iterations = 0;
    Real error = 0;
    bool converged = false;
  };
  // head: an outlet's held particles hold the hydrostatic pressure under
  // gravity (Context::outlet_pressure; the density solve), else 0.
  Solve solve(Vec2* u, Real* k, const Real* base, Real dt, Real tol, bool head = false);
  void conjugate_residuals(const Real* k, Real dt, Real tol, int& iterations);
  void start_residuals(const Real* k, Real inv_dt2);
  Real residual_step(Real alpha, Real inv_dt2);
  Real product(Real dt);
  Real directions(Real beta, bool first, Real inv_dt2);
  // e from velocities u (D4), the sum of the error shares; u += dt a_p(dk_),
  // k += dk_.
  Real errors(const Vec2* u, const Real* base, Real dt);
  void apply(Vec2* u, Real* k, Real dt);
  // dk of the inlets' buffers: their values the fluid's beside them.
  void extrapolate_inflow(const Real* k);
  // D5 and D4 of particle i over the pair table: the pressure acceleration
  // of the values value(j) (and value(i)), and the rate of velocities u.
  template <class Value>
  Vec2 pressure_acceleration(Index i, Value value) const {
    const Real vi = value(i);
    Vec2 acc = -vi * wall_g_[i];
    for (Index q = first_[i]; q < first_[i + 1]; ++q)
      acc += dfsph::pressure_pair(vi, value(pair_j_[q]), pair_mg_[q]);
    return acc;
  }
  Real rate(Index i, const Vec2* u) const {
    const Vec2 ui = u[i];
    Real r = ui.dot(wall_g_[i]);
    for (Index q = first_[i]; q < first_[i + 1]; ++q)
      r += dfsph::rate_pair(ui - u[pair_j_[q]], pair_mg_[q]);
    return r;
  }

  using StepFn = void(DfsphMethod&, Real, Real);
  using EvalFn = void(DfsphMethod&);

  Context& ctx_;
  const SimParams& P_;
  Wendland kernel_;
  WendlandWeight weight_;
  WallTables walls_;       // the walls' half-plane shares (W7, D2)
  SurfaceEnergy surface_;  // the tension (inactive without it)
  StepFn* step_fn_ = nullptr;
  EvalFn* eval_fn_ = nullptr;
  // The solves' pressure values (p / rho^2), the warm starts of the next step.
  Field<Real> kappa_{ctx_.ps, "dfsph_pressure", FieldKind::kState};
  Field<Real> kappa_v_{ctx_.ps, "dfsph_divergence_pressure", FieldKind::kState};
  // The last step's whole acceleration (non-pressure and the constant-density
  // solve's pressure): the next step's force condition reads it.
  Field<Vec2> a_last_{ctx_.ps, "dfsph_acceleration", FieldKind::kState};
  // The pair table of the last evaluation: particle i's neighbours
  // pair_j_[first_[i] .. first_[i+1]) and m grad W_ij for each (the solves'
  // iterations read it instead of the kernel).
  std::vector<Index> first_, pair_j_;
  std::vector<Vec2> pair_mg_;
  std::vector<Real> factor_;  // D3
  Real surface_g2_;           // D7's threshold of |s_i|^2 for a free surface
  bool free_surface_ = true;  // some particle is at a free surface (D7)
  std::vector<Vec2> wall_g_;  // D2 (zero without walls)
  // D4's sum v_w . g over G_i's shares where walls move or slide (empty
  // where none does): the walls' own velocity in the rate of density change.
  std::vector<Real> wall_rate_;
  std::vector<Vec2> a_np_;    // the non-pressure accelerations of the last evaluation
  std::vector<Vec2> u_;       // the density solve's predicted velocities
  std::vector<Real> e_, dk_;  // per particle: the error and the pressure change
  // The conjugate residuals' vectors, per particle: whether it takes part,
  // the solution, the residual, the preconditioned residual z, the direction
  // p, M z and M p (each its own array: the products gather z by neighbour).
  std::vector<char> active_;
  std::vector<Real> x_, r_, z_, p_, az_, ap_;
  std::vector<Real> partial_;  // block_sum's scratch
  std::vector<Vec2> du_;  // a velocity change (D5 times dt)
  std::vector<Real> rho0s_;   // rho0 per particle (the divergence solve's base)
  std::vector<Real> inv_rho_;  // 1 / rho (the viscosity)
  // Per particle with inlets or outlets (empty without): kFree, or in a
  // buffer (find_buffers); and how many are kFree (the mean error's count).
  enum Role : char { kFree, kInflow, kOutflow };
  std::vector<char> roles_;
  Index unknowns_ = 0;
  SolveStats stats_;
  // The search, factors and a_np_ hold for the current particles (the step
  // starts with a solve over them); false after a checkpoint is restored.
  bool evaluated_ = false;
  // The flow's own step (step_impl): the density solve undoes the present
  // error over it.
  Real undo_dt_ = 0;
};

}  // namespace sphfluid
