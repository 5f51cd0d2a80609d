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

// phi2(x) = (phi1(x) - 1) / x = (e^x - 1 - x) / x^2, continued by phi2(0) = 1/2.
// A rank-one damping A = u w^T with a = w.u needs t^2 phi2(-t a) where a may be 0
// (a damper whose gradient vanishes). The direct form cancels (relative error about
// 2 eps_mach / |x|), so below |x| = 1/2 use the series sum_k x^k / (k+2)!, whose
// terms past k = 16 are below 1e-19 there.
inline double phi2(double x) {
  if (std::abs(x) < 0.5) {
    double sum = 0.0, inv_factorial = 1.0;  // 1/(k+2)! for k = 16, built down
    for (int k = 2; k <= 18; ++k) inv_factorial /= k;
    for (int k = 16; k >= 0; --k) {
      sum = sum * x + inv_factorial;
      inv_factorial *= (k + 2);
    }
    return sum;
  }
  return (std::expm1(x) - x) / (x * x);
}

}  // namespace raydamp
