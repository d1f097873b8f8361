// The methods' registrations (methods/method.hpp): one entry a method.
#include <cmath>
#include <iterator>
#include <memory>
#include <stdexcept>

#include "methods/method.hpp"
#include "methods/dfsph/dfsph.hpp"
#include "methods/seed/seed.hpp"
#include "methods/wcsph/delta.hpp"
#include "methods/wcsph/wcsph.hpp"

namespace sphfluid {

namespace {

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

template <class M>
std::unique_ptr<SphMethod> make(Context& ctx) {
  return std::make_unique<M>(ctx);
}

// wcsph's density: the summation (W2), or the continuity equation (W17-W26).
std::unique_ptr<SphMethod> make_wcsph(Context& ctx) {
  if (ctx.params().continuity) return std::make_unique<DeltaWcsphMethod>(ctx);
  return std::make_unique<WcsphMethod>(ctx);
}

const MethodEntry kMethods[] = {
    // The seed (docs/method-seed.md): c^2 = dp/drho = k for p = k (rho - rho0);
    // the time-step conditions take the kernels' support h.
    {Method::kSeed, "seed", [](const SimParams& p) { return std::sqrt(p.k); },
     [](const SimParams& p) { return p.h; }, true, [](const SimParams&) {}, make<SeedMethod>},
    // wcsph (docs/method-wcsph.md): the speed of sound c0 of its Tait state
    // equation; the conditions take the smoothing length h/2 of its Wendland
    // kernel (support 2 x h/2).
    {Method::kWcsph, "wcsph", [](const SimParams& p) { return p.c0; },
     [](const SimParams& p) { return p.h / 2; }, true,
     [](const SimParams& p) {
       require(std::isfinite(p.c0) && p.c0 > 0, "wcsph needs a speed of sound c0 > 0");
       require(std::isfinite(p.alpha) && p.alpha >= 0, "artificial viscosity alpha must be >= 0");
       require(std::isfinite(p.background_pressure) && p.background_pressure >= 0,
               "background pressure must be >= 0");
       require(std::isfinite(p.spacing) && p.spacing >= 0, "spacing must be >= 0");
       require(std::isfinite(p.delta) && p.delta >= 0, "density diffusion delta must be >= 0");
       require(std::isfinite(p.shifting) && p.shifting >= 0, "shifting must be >= 0");
     },
     make_wcsph},
    // dfsph (docs/method-dfsph.md): incompressible, its steps follow the flow;
    // c0 (the scene's speed scale) bounds the guard's speeds only. The
    // conditions take wcsph's smoothing length h/2 (the same kernel).
    {Method::kDfsph, "dfsph", [](const SimParams& p) { return p.c0; },
     [](const SimParams& p) { return p.h / 2; }, false,
     [](const SimParams& p) {
       require(std::isfinite(p.c0) && p.c0 > 0, "dfsph needs a speed scale c0 > 0 (the guard's)");
       require(std::isfinite(p.spacing) && p.spacing >= 0, "spacing must be >= 0");
       require(std::isfinite(p.density_tolerance) && p.density_tolerance > 0,
               "the density tolerance must be > 0");
       require(std::isfinite(p.divergence_tolerance) && p.divergence_tolerance > 0,
               "the divergence tolerance must be > 0");
       require(p.min_iterations >= 0, "the least iterations must be >= 0");
       require(p.max_iterations >= p.min_iterations,
               "the most iterations must be >= the least");
     },
     make<DfsphMethod>},
};

}  // namespace

MethodEntries method_entries() { return {std::begin(kMethods), std::end(kMethods)}; }

const MethodEntry& method_entry(Method id) {
  for (const MethodEntry& e : method_entries())
    if (e.id == id) return e;
  throw std::invalid_argument("unknown method");
}

Real SimParams::sound_speed() const { return method_entry(method).sound_speed(*this); }
Real SimParams::step_length() const { return method_entry(method).step_length(*this); }

}  // namespace sphfluid
