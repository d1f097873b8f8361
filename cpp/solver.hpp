// Solver: owns the particles, the cell grid and the walls, and advances them with
// the seed method (SPEC.md) as ordered phases: sort + neighbours, density,
// forces, integration + wall collision, domain removal. The step is compiled once
// per combination of optional terms (Feature flags) and chosen at construction.
#pragma once

#include <array>
#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

#include "neighbours/cell_pairs.hpp"
#include "neighbours/grid.hpp"
#include "terms/kernels.hpp"
#include "core/params.hpp"
#include "core/particles.hpp"
#include "boundary/periodic.hpp"
#include "methods/wcsph/surface_energy.hpp"
#include "boundary/walls.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

// Numerical blow-up detected during a step (arrives in Python as
// sphfluid.InstabilityError, a RuntimeError).
class InstabilityError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Wall-clock seconds spent in each phase of the step, summed over steps.
enum Phase : int { kSort, kNeighbours, kGhosts, kDensity, kForces, kIntegrate, kDomain, kNumPhases };
inline const char* phase_name(int p) {
  static const char* names[kNumPhases] = {"sort",   "neighbours", "ghosts", "density",
                                          "forces", "integrate",  "domain"};
  return names[p];
}

// The kNumFeatureSets instantiations of a member template of Solver, indexed
// by feature set (used to fill the step dispatch tables).
#define SPHFLUID_FEATURE_TABLE(fn)                                                        \
  {                                                                                       \
    &Solver::fn<0>, &Solver::fn<1>, &Solver::fn<2>, &Solver::fn<3>, &Solver::fn<4>,       \
        &Solver::fn<5>, &Solver::fn<6>, &Solver::fn<7>, &Solver::fn<8>, &Solver::fn<9>,   \
        &Solver::fn<10>, &Solver::fn<11>, &Solver::fn<12>, &Solver::fn<13>,               \
        &Solver::fn<14>, &Solver::fn<15>                                                  \
  }

class Solver {
 public:
  // positions, velocities: n entries each; ids: n entries or empty (0..n-1).
  Solver(const SimParams& params, std::vector<Vec2> positions, std::vector<Vec2> velocities,
         std::vector<Id> ids, std::vector<Segment> walls);

  // Advance n steps of size dt (seed 4.3).
  void step(Real dt, int n = 1);
  // Advance n steps, each with the largest stable dt (SimParams: cfl, ...).
  void step_adaptive(int n = 1);
  // Adaptive steps until time() reaches t_end (the last step is shortened to
  // land on it) or max_steps were taken; returns the number of steps.
  std::int64_t advance_adaptive(Real t_end, std::int64_t max_steps);
  Real last_dt() const { return last_dt_; }
  // The energy the scene can supply (J per m of depth): kinetic + the most
  // gravity can release within the domain + the EOS's elastic energy + a
  // surface-energy bound; set when the particles are set.
  Real energy_budget() const { return energy_budget_; }
  // Kinetic energy (J per m of depth) carried out of the domain by the particles
  // removed since the budget was set: the guard's energy check counts it, so a
  // blow-up that throws particles out of the domain still trips it.
  Real energy_removed() const { return energy_removed_; }
  // wcsph with surface tension: the surface energy sigma x length at the last
  // evaluation, J per m of depth (surface_energy.hpp); 0 otherwise.
  Real surface_energy() const { return surface_.energy(); }
  std::int64_t retried_steps() const { return retried_steps_; }
  // Messages of the most recent retries (at most kRetryLog), oldest first.
  const std::vector<std::string>& retry_log() const { return retry_log_; }
  TimeStepLimit last_limit() const { return last_limit_; }
  // Density, pressure and acceleration for the current state; nothing moves
  // (storage may be re-ordered, as in every step).
  void compute_forces();
  // Replace all particles; ids empty gives 0..n-1.
  void set_state(std::vector<Vec2> positions, std::vector<Vec2> velocities, std::vector<Id> ids);
  // Append particles with fresh ids (one above the largest in use).
  void add_particles(const std::vector<Vec2>& positions, const std::vector<Vec2>& velocities);
  // Replace the walls; the step is re-specialised if walls appear or vanish.
  void set_walls(std::vector<Segment> walls);

  const SimParams& params() const { return params_; }
  const ParticleSet& particles() const { return ps_; }
  const WallSet& walls() const { return walls_; }
  unsigned features() const { return features_; }
  Index size() const { return ps_.size(); }
  Real time() const { return time_; }
  std::int64_t step_count() const { return step_count_; }
  std::int64_t removed() const { return removed_; }
  int threads() const { return threads_; }
  // Whether the pair forces run in float (asked for, and the step runs them
  // by cell clusters), else double.
  bool float_pairs() const { return float_pairs_; }
  bool recip_root() const { return recip_root_; }
  void set_threads(int threads);
  // The threads of the step's loops: threads(), or one below kParallelMin
  // particles (parallel.hpp).
  int team() const { return threads_for(size(), threads_); }
  const std::array<double, kNumPhases>& phase_seconds() const { return phase_seconds_; }
  // Sorts since the solver was made, by what they did to the order: none
  // changed, few particles moved in place, or a full permutation
  // (CellGrid::Reorder); then how many of the moves were cut into parts for
  // the threads.
  const std::array<std::int64_t, 4>& sort_counts() const { return sort_counts_; }
  void reset_phase_seconds() { phase_seconds_.fill(0.0); }
  // Heap bytes held by the solver's arrays (capacity included), by part.
  std::vector<std::pair<std::string, std::size_t>> memory_bytes() const {
    return {{"particles", ps_.bytes()},
            {"sort", grid_.bytes() + order_.capacity() * sizeof(Index)},
            {"neighbours", nbrs_.bytes() + cell_pairs_.bytes()},
            {"wall ghosts", ghosts_.bytes()},
            {"scratch", (inv_rho_.capacity() + p_over_rho2_.capacity() + lap_c_.capacity()) *
                                sizeof(Real) +
                            normal_.capacity() * sizeof(Vec2) + keep_.capacity() + bad_.capacity() +
                            wall_clear2_.capacity() * sizeof(float) + floats_.bytes() +
                            surface_.bytes()}};
  }
  // Total number of stored neighbour pairs (i, j), j != i, of the last evaluation.
  std::int64_t neighbour_pairs() const;

 private:
  // dt > 0: a fixed step; otherwise the adaptive one, at most dt_cap when > 0.
  template <unsigned F> void step_impl(Real dt, Real dt_cap);
  Real choose_dt(Real dt_cap);
  // This step's dt: the fixed one (dt > 0) or choose_dt's; recorded as last_dt_.
  Real step_size(Real dt, Real dt_cap);
  // One step (fixed dt > 0, or adaptive), retried with halved dt on a trip.
  void guarded_step(Real dt, Real dt_cap);
  void compute_energy_budget();
  [[noreturn]] void trip(Real dt, const Vec2* x_new, const Vec2* v_new, const Real* rho_new,
                         Real kinetic) const;
  // The wcsph method (solver_wcsph.cpp): kick-drift-kick, summation density
  // with the Wendland C2 kernel, Tait EOS, artificial and Morris viscosity.
  void select_wcsph_step();
  template <unsigned F> void wcsph_step_impl(Real dt, Real dt_cap);
  template <unsigned F> void wcsph_evaluate_impl();
  template <unsigned F> void wcsph_evaluate_kick(Real half);
  template <unsigned F> void evaluate_impl();
  template <unsigned F> void compute_density();
  template <unsigned F> void compute_accelerations();
  template <bool Viscosity, bool Tension> void seed_pairs_once();
  template <bool Viscosity> void wcsph_pairs_once();
  template <unsigned F> void integrate(Real dt, Real kick);
  template <bool Periodic, bool Once, class KernelOfR2>
  void sort_and_find_neighbours(KernelOfR2 w);
  // The fluid pairs by cell clusters, without lists (cell_pairs.hpp), for
  // both methods: where AVX-512F and VL are available (SPHFLUID_CELL_PAIRS)
  // and without periodic seams; for the seed also without surface tension
  // (its colour field keeps the lists; wcsph's surface energy reads none,
  // surface_energy.hpp).
  static constexpr bool by_cells(unsigned features) {
    return CellPairs::kAvailable && (features & (kPeriodic | kSurfaceTension)) == 0;
  }
  static constexpr bool wcsph_by_cells(unsigned features) {
    return CellPairs::kAvailable && (features & kPeriodic) == 0;
  }
  // The particles into cell order (the sort phase).
  void sort_by_cell();
  template <class KernelOfR2> void sort_and_sum_density_by_cells(KernelOfR2 w);
  template <bool Viscosity, class Finish> void seed_forces_by_cells(Finish finish);
  // The per-particle ends of the seed's density and force passes, for the
  // particles [i0, i1) on the calling thread: per thread after the pairs, or
  // (the forces by cells) per pair block as soon as its sums are complete.
  template <unsigned F> void finish_density(Index i0, Index i1);
  template <unsigned F> void finish_eos(Index i0, Index i1);
  void add_ghost_density(Real& rho, Row<Vec2> ghosts) const;
  template <unsigned F> void finish_accelerations(Index i0, Index i1);
  template <unsigned F> Vec2 wall_sum(Row<Vec2> ghosts, Real pi, const Vec2& vi) const;
  // The seed's pair sums times seed_scale() are force densities (-m/2 spiky_grad),
  // and seed_lap() is the viscosity's factor in them (eta m visc_lap / seed_scale()).
  Real seed_scale() const { return -Real(0.5) * params_.mass * kern_.spiky_grad; }
  Real seed_lap() const { return params_.eta * params_.mass * kern_.visc_lap / seed_scale(); }
  template <bool Viscosity> void wcsph_forces_by_cells();
  // r_a - r_b: the minimum image when the step is specialised on kPeriodic.
  template <unsigned F> Vec2 separation(const Vec2& a, const Vec2& b) const {
    if constexpr ((F & kPeriodic) != 0) {
      return box_.delta(a, b);
    } else {
      return a - b;
    }
  }
  // Positions moved into the box along its periodic axes.
  void wrap_positions();
  void remove_outside_domain();
  void check_state(const std::vector<Vec2>& x, const std::vector<Vec2>& v,
                   const std::vector<Id>& ids) const;
  void select_step();
  void find_ghosts(bool interior_only);
  template <class Then> void find_ghosts(bool interior_only, bool density, Then then);

  using StepFn = void (Solver::*)(Real, Real);
  using EvalFn = void (Solver::*)();

  SimParams params_;
  Kernels kern_;
  Wendland wendland_;  // wcsph's kernel, with its wall tables
  SurfaceEnergy surface_;  // wcsph's surface tension (inactive without tension)
  WallSet walls_;
  PeriodicBox box_;
  unsigned features_ = 0;
  StepFn step_fn_ = nullptr;
  EvalFn eval_fn_ = nullptr;
  int threads_ = 1;

  ParticleSet ps_;
  CellGrid grid_;
  std::vector<Index> order_;
  // The particles are in the order of the grid's last sort, only moved since
  // (the next sort may then move just those that changed cell).
  bool in_sort_order_ = false;
  // The last integration found every particle within the domain (its
  // vector loop checks; remove_outside_domain's pass is then skipped).
  bool all_inside_ = false;
  std::array<std::int64_t, 4> sort_counts_{};  // sort_counts()
  Csr<Index> nbrs_;
  CellPairs cell_pairs_;
  // The seed's pair forces in float (SimParams::float_pairs, where the cell
  // clusters run): the per-particle floats they read.
  bool float_pairs_ = false;
  Real force_scale_ = 1;  // the factor of this evaluation's pair sums in a[] (finish_accelerations)
  SeedFloats floats_;
  // The seed's double pair forces by cell clusters take 1/r from rsqrt14 and
  // Newton steps on this CPU (prefers_recip_root in cell_pairs.hpp).
  bool recip_root_ = prefers_recip_root();
  std::int64_t cell_pair_count_ = -1;  // pairs of the last evaluation by cells, else -1
  Csr<Vec2> ghosts_;          // r_i - r_ghost of each wall ghost of particle i
  Balance ghost_balance_;     // the threads' shares of the ghost search (and the EOS)
  std::vector<Real> inv_rho_;     // 1 / rho, per particle, from the density pass
  std::vector<Real> p_over_rho2_; // wcsph: p / rho^2
  std::vector<Vec2> normal_;      // with tension, pairs once: the colour field's gradient
  std::vector<Real> lap_c_;       // ... and its Laplacian, per particle
  std::vector<char> keep_;    // scratch for domain removal
  // Per particle (8 entries of padding after n), from the last find_ghosts:
  // the squared length of a path from it that meets no wall, from the distance
  // to the nearest wall of its lookup cell (every wall within h of it is there;
  // none where no wall comes within h, nor off the lookup grid:
  // WallSet::near8, safe_path2). Fresh until the next integrate, which
  // then skips the wall check for paths shorter than it: the seed's right
  // after its evaluation, wcsph's drift in the next step (nothing moves or
  // re-orders the particles in between without evaluating again).
  std::vector<float> wall_clear2_;
  bool wall_clear_fresh_ = false;
  std::vector<char> bad_;     // per thread: a non-finite value was produced

  // Adds the time since the last mark to phase p (a few clock reads per step).
  void mark(int p) {
    const auto now = std::chrono::steady_clock::now();
    phase_seconds_[p] += std::chrono::duration<double>(now - mark_).count();
    mark_ = now;
  }
  std::array<double, kNumPhases> phase_seconds_{};
  std::chrono::steady_clock::time_point mark_;

  static constexpr std::size_t kRetryLog = 100;
  // The pair-once loops' blocks, a number that depends on n alone (so the sums
  // do not depend on the thread count): one up to kPairBlockMin particles, then
  // an even number, 2 ceil(n / (2 kPairBlockSize)) up to kPairBlocks, so that
  // two threads take equal shares. pair_block() is their size in particles
  // (the list loops); the cell clusters cut as near as whole cell rows allow.
  // A pair across two blocks is evaluated from each side, so blocks cost: at
  // 10k particles 2 blocks (of ~8k at most) ran 3.5 % faster than 10 (of ~1k)
  // on one thread, 4.8 % on two.
  static constexpr Index kPairBlocks = 16, kPairBlockMin = 1024, kPairBlockSize = 8192;
  Index pair_blocks() const {
    const std::int64_t n = size();
    if (n <= kPairBlockMin) return 1;
    return static_cast<Index>(std::min<std::int64_t>(
        kPairBlocks, 2 * ((n + 2 * kPairBlockSize - 1) / (2 * kPairBlockSize))));
  }
  Index pair_block() const {
    return std::max<Index>(1, (size() + pair_blocks() - 1) / pair_blocks());
  }
  bool half_lists_ = false;  // nbrs_ holds neighbours_once's half lists
  Real energy_budget_ = 0;
  Real energy_removed_ = 0;
  std::int64_t retried_steps_ = 0;
  std::vector<std::string> retry_log_;

  Real time_ = 0;
  Real last_dt_ = 0;
  TimeStepLimit last_limit_ = TimeStepLimit::kFixed;
  std::int64_t step_count_ = 0;
  std::int64_t removed_ = 0;
};

}  // namespace sphfluid
