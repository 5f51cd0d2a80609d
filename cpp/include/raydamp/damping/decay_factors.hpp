// The scalar functions of t a that the exact flows of a damping kind with one
// nonzero eigenvalue a need. A step applies each sub-flow for a fixed fraction of h,
// so the Workspace keeps them per sub-flow and recomputes them only when t changes
// (at a shortened last step): no exp, expm1 or phi1 per step.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "raydamp/phi.hpp"

namespace raydamp {

struct DecayFactors {
  double t = std::numeric_limits<double>::quiet_NaN();  // the time they are for (NaN: none yet)
  double exp = 1.0;        // e^{-t a}
  double expm1 = 0.0;      // e^{-t a} - 1
  double t_phi1 = 0.0;     // t phi1(-t a)
  double t_phi1_m1 = 0.0;  // t (phi1(-t a) - 1)
  // sqrt(1 - e^{-2 t a}): the thermal noise of the exact Ornstein-Uhlenbeck flow along a direction
  // that decays at rate a has variance kT m (1 - e^{-2 t a}) (m its mass).
  double noise = 0.0;
};

inline DecayFactors decay_factors(double a, double t) {
  const double x = -t * a;
  const double phi = phi1(x);
  const double expm1 = std::expm1(x);
  return {t, std::exp(x), expm1, t * phi, t * (phi - 1.0), std::sqrt(std::max(0.0, -expm1 * (2.0 + expm1)))};
}

}  // namespace raydamp
