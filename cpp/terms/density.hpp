// The summation density of both methods (seed eq. 10, wcsph eq. W2):
// rho_i = sum_j m W(r_ij), the particle itself included. The traversals sum
// the neighbours' weights; this turns a sum into the density.
#pragma once

#include "core/types.hpp"

namespace sphfluid {

// m (W(0) + sum_j W(r_ij)) for self = W(0) and the neighbours' weights `sum`.
SPHFLUID_INLINE Real summation_density(Real m, Real self, Real sum) { return m * (self + sum); }

}  // namespace sphfluid
