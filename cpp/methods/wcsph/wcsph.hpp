// The wcsph method (docs/method-wcsph.md): weakly compressible SPH as
// engineers use it (Monaghan 1994, 2005; Becker & Teschner 2007). Its step as
// named phases: the first kick and the drift (with the wall collision and the
// guard), the domain's edge, then the evaluation at the new positions: the
// neighbour search with the summation density (W2), the walls' ghosts and
// their share of it (W7), the surface energy's tension (W10-W12), the Tait
// state equation (W3), the pair forces (W4-W6), the walls' forces (W8-W9),
// and the second kick riding on the last loop. Compiled once per feature set.
#pragma once

#include <vector>

#include "terms/wall_tables.hpp"
#include "context.hpp"
#include "core/features.hpp"
#include "methods/method.hpp"
#include "methods/wcsph/surface_energy.hpp"
#include "terms/wcsph.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

class WcsphMethod final : public SphMethod {
 public:
  explicit WcsphMethod(Context& ctx);

  void select(unsigned features) override;
  void step(Real dt, Real dt_cap) override { step_fn_(*this, dt, dt_cap); }
  void evaluate() override { eval_fn_(*this); }
  Real elastic_energy() const override;
  Real surface_energy() const override { return surface_.energy(); }
  std::size_t bytes() const override;

  struct Steps {
    template <unsigned F>
    static void run(WcsphMethod& m, Real dt, Real dt_cap) {
      m.step_impl<F>(dt, dt_cap);
    }
  };
  struct Evaluations {
    template <unsigned F>
    static void run(WcsphMethod& m) {
      m.evaluate_kick<F>(0);
    }
  };

 private:
  // Whether the fluid pairs run by cell clusters (neighbours/cell_pairs.hpp):
  // where the lanes run and without periodic seams (the surface energy reads
  // no pairs of the solver's).
  static constexpr bool by_cells(unsigned features) {
    return CellPairs::kAvailable && (features & kPeriodic) == 0;
  }

  template <unsigned F> void step_impl(Real dt, Real dt_cap);
  // The evaluation; with half > 0 also the second half-kick, v += half a.
  template <unsigned F> void evaluate_kick(Real half);
  // The phases.
  template <unsigned F> void density();
  template <unsigned F> void state();
  template <unsigned F> void forces();
  template <unsigned F> void accelerations(Real half);
  template <bool Viscosity> void forces_by_cells();
  template <unsigned F> void forces_by_lists();
  template <unsigned F> void add_wall_force(Index i, Vec2& f) const;

  using StepFn = void(WcsphMethod&, Real, Real);
  using EvalFn = void(WcsphMethod&);

  Context& ctx_;
  const SimParams& P_;
  Wendland kernel_;
  WendlandWeight weight_;
  WallTables walls_;      // the walls' half-plane shares (W7-W8)
  SurfaceEnergy surface_;  // the tension (inactive without it)
  StepFn* step_fn_ = nullptr;
  EvalFn* eval_fn_ = nullptr;
  std::vector<Real> por2_;     // p / rho^2
  std::vector<Real> inv_rho_;  // 1 / rho
};

}  // namespace sphfluid
