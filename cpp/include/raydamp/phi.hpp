// Scalar functions of the damping exponent, accurate down to x = 0.
#pragma once

#include <cmath>

namespace raydamp {

// phi1(x) = (e^x - 1) / x, continued by phi1(0) = 1. The exact kick+damp flow
// p(t) = e^{-tA} p - t phi1(-tA) grad V needs it where tA is tiny (eps -> 0):
// expm1 keeps full relative accuracy there, and below |x| = 1e-5 the Taylor
// series 1 + x/2 + x^2/6 is exact to rounding and avoids 0/0.
inline double phi1(double x) {
  if (std::abs(x) < 1e-5) return 1.0 + x * (0.5 + x / 6.0);
  return std::expm1(x) / x;
}

}  // namespace raydamp
