// The particle mass that gives the rest density inside a filled square lattice:
// rho0 / sum_j W(|r_ij|) over the lattice's points within the kernel's
// support, self included (the scene loader's default mass for each method).
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/types.hpp"
#include "terms/kernels.hpp"
#include "terms/wendland.hpp"

namespace sphfluid {

enum class LatticeKernel { kPoly6, kWendland };

inline Real lattice_mass(Real rho0, Real dx, Real h, LatticeKernel kernel) {
  if (!(std::isfinite(h) && h > 0)) throw std::invalid_argument("h must be > 0");
  if (!(dx > 0 && rho0 > 0)) throw std::invalid_argument("rho0 and dx must be > 0");
  const Kernels k(h);
  const Wendland w(h);
  const int reach = static_cast<int>(std::ceil(h / dx));
  Real sum = 0;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j) {
      const Real r2 = (i * i + j * j) * dx * dx;
      sum += kernel == LatticeKernel::kPoly6 ? k.w_poly6(r2) : w.value(std::sqrt(r2));
    }
  return rho0 / sum;
}

}  // namespace sphfluid
