// wcsph with the density from the continuity equation (docs/method-wcsph.md,
// W17-W26; `solver.density: "continuity"`): the density is carried from step
// to step and changed by its rate, with a diffusion term (delta-SPH), and the
// particles may be shifted towards a uniform distribution. Its step as named
// phases: the first kick and the drift (with the shift of the last
// evaluation), the domain's edge, then at the new positions: the neighbour
// search (with the kernel sums that find the free surface), the walls'
// ghosts, the density rate and the density's drift, the Tait state equation,
// the pair forces with the shifting sums, the walls' forces, and the second
// kick. The pair loops run by cell clusters (each pair once, in lanes) or,
// across periodic seams or with shifting, over full neighbour lists.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "context.hpp"
#include "core/features.hpp"
#include "methods/method.hpp"
#include "methods/wcsph/delta_pairs.hpp"
#include "methods/wcsph/surface_energy.hpp"
#include "terms/delta.hpp"
#include "terms/quintic.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wcsph.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

class DeltaWcsphMethod final : public SphMethod {
 public:
  explicit DeltaWcsphMethod(Context& ctx);

  void select(unsigned features) override;
  void step(Real dt, Real dt_cap) override { step_fn_(*this, dt, dt_cap); }
  void evaluate() override { eval_fn_(*this); }
  void particles_added(Index first) override;
  bool fluid_filled() override;
  // "auto" shifting's decision, whether the next drift shifts, and the last
  // drift's shift rate (W27), as numbers.
  std::vector<Real> carried() const override;
  void restore_carried(const std::vector<Real>& values) override;
  Real elastic_energy() const override;
  Real surface_energy() const override { return surface_.energy(); }
  bool quintic_pressure() const override { return quintic_ && !shift_ready_; }
  std::size_t bytes() const override;

  struct Steps {
    template <unsigned F>
    static void run(DeltaWcsphMethod& m, Real dt, Real dt_cap) {
      m.step_impl<F>(dt, dt_cap);
    }
  };
  struct Evaluations {
    template <unsigned F>
    static void run(DeltaWcsphMethod& m) {
      m.evaluate_kick<F>(0, 0);
    }
  };

 private:
  bool hydrostatic() const;
  std::int64_t column(Index i) const;
  Real spacing() const;
  template <unsigned F> void step_impl(Real dt, Real dt_cap);
  // The evaluation after a drift of dt (the density drifts by dt times its
  // rate; dt = 0: none), and with half > 0 the second half-kick.
  template <unsigned F> void evaluate_kick(Real dt, Real half);
  template <unsigned F> void neighbours();
  template <unsigned F> void density(Real dt);
  template <unsigned F, bool Shift, bool Gradient, class Constants>
  void rate_pass(Constants constants, Vec2* rl);
  template <unsigned F, class Constants> void rates(Constants constants, Vec2* rl);
  void state();
  template <unsigned F> void forces();
  // R: W30's reconstruction; Q: the pressure on the quintic spline (W31).
  template <unsigned F, bool R, bool Q> void forces_with();
  template <unsigned F, bool R, bool Q> bool forces_by_cells();
  template <unsigned F, class L, bool R, bool Q = false>
  delta::ForcePairs<L, (F & kViscosity) != 0, R, Q> force_pairs() const;
  template <unsigned F, bool Q> void add_wall_force(Index i, Row<Vec2> ghosts, Vec2& f) const;
  // W4-W6's constants with W28's alpha.
  template <class L>
  wcsph::PairConstants<L> constants() const {
    wcsph::PairConstants<L> c = wcsph::pair_constants<L>(P_);
    c.av = simd::splat<L>(alpha_ * P_.c0 * Real(0.5) * P_.h);
    return c;
  }
  // Whether the fluid pairs can run by cell clusters (neighbours/cell_pairs.hpp):
  // where the lanes run and without periodic seams; they do when nothing
  // shifts (the shifting sums ride on the list loops).
  static constexpr bool by_cells(unsigned features) {
    return CellPairs::kAvailable && (features & kPeriodic) == 0;
  }
  // The shift of the next drift (W21-W22), from this evaluation's sums.
  template <unsigned F> bool shift_for(Real dt);
  // Whether the next drift shifts, so this evaluation takes the shifting sums:
  // with shifting, and with shift_confined only in a confined flow, one where
  // no particle of the first evaluation with particles was at a free surface
  // (a kernel sum below open_sum_, delta::open_surface_sum); a new fluid
  // (particles_added(0)) is tested again.
  bool shifts_next() const { return P_.shifting > 0 && (!P_.shift_confined || confined_); }

  using StepFn = void(DeltaWcsphMethod&, Real, Real);
  using EvalFn = void(DeltaWcsphMethod&);

  Context& ctx_;
  const SimParams& P_;
  Wendland kernel_;
  WendlandWeight weight_;
  WallTables walls_;
  // W31 (P_.quintic_pressure): the pressure's kernel where the flow is not
  // shifted (with a support h of at least kQuinticSupport spacings), its wall
  // tables and 1 / its S (W29)
  QuinticSpline pressure_kernel_;
  WallTables pressure_walls_;
  Real inv_s_quintic_ = 1;
  bool quintic_ = false;
  SurfaceEnergy surface_;  // the tension (W10-W12; inactive without it)
  StepFn* step_fn_ = nullptr;
  EvalFn* eval_fn_ = nullptr;
  Real inv_wdx_;                  // 1 / W(dx), the shifting's reference
  Real alpha_;                    // the artificial viscosity's alpha (W28)
  // kernel sums over the fluid and walls, / rho0 (the next drift's shift reads them)
  Field<Real> sums_{ctx_.ps, "kernel_sum", FieldKind::kDerived};
  bool by_cells_ = false;         // this evaluation's pairs run by cell clusters
  std::vector<Vec2> rate_lap_;    // (d rho / dt, W24's sum)
  std::vector<Real> lap_;         // the viscous term's normalisation c_i (W24)
  std::vector<Real> inv_rho_;     // 1 / rho
  // W30 (where the artificial viscosity acts, alpha' > 0): the rate pass's
  // velocity-gradient sums (g_xx, g_xy), (g_yx, g_yy), then each particle's
  // strain e_xx, e_yy, e_xy
  bool reconstruct_ = false;
  std::vector<Vec2> grad_x_, grad_y_;
  std::vector<Real> strain_[3];
  // With shifting only (make_shift_fields): the next drift's shift, m; W21's
  // sum of each particle (zero within h of a wall) and the sum of V_j grad
  // W_ij, the free surface's normal, from which the next step makes it.
  std::unique_ptr<Field<Vec2>> shift_, shift_sum_, colour_;
  void make_shift_fields();
  Real open_sum_;             // delta::open_surface_sum of the lattice
  Real inv_s_ = 1;  // 1 / the lattice's gradient normalisation (W29)
  bool shape_known_ = false;  // shift_confined: whether the fluid's shape is known,
  bool confined_ = false;     // and whether it has no free surface
  bool shift_ready_ = false;  // this evaluation took the shifting sums
  Real shift_per_dt_ = 0;         // 1 / dt of a step whose drift shifted, else 0
};

}  // namespace sphfluid
