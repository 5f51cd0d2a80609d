// Scalar functions of the damping exponent, accurate down to x = 0.
#pragma once

#include <array>
#include <cmath>

namespace raydamp {

namespace detail {
// 1/k! for k = 0..18, at compile time: the series of phi1 and phi2.
constexpr std::array<double, 19> inverse_factorials() {
  std::array<double, 19> c{};
  double f = 1.0;
  for (int k = 0; k < 19; ++k) {
    if (k > 0) f *= k;
    c[k] = 1.0 / f;
  }
  return c;
}
inline constexpr std::array<double, 19> kInverseFactorials = inverse_factorials();
}  // namespace detail

// sum_{k<K} x^k / (k+Offset)!, by Horner's rule (a serial chain of K multiply-adds,
// so K is kept as small as the accuracy allows).
template <int K, int Offset>
inline double factorial_series(double x) {
  double sum = detail::kInverseFactorials[K - 1 + Offset];
  for (int k = K - 2; k >= 0; --k) sum = sum * x + detail::kInverseFactorials[k + Offset];
  return sum;
}

// phi1(x) = (e^x - 1) / x, continued by phi1(0) = 1. The exact kick+damp flow
// p(t) = e^{-tA} p - t phi1(-tA) grad V needs it where tA is tiny (eps -> 0),
// and the dashpot kinds evaluate it at every new q. Its series sum x^k / (k+1)!
// truncated after K terms errs by about |x|^K / (K+1)!: below 1e-18 with 5 terms
// for |x| < 1e-3 and with 9 terms for |x| < 0.05; beyond, expm1 (accurate to
// rounding, and no 0/0) and one division.
inline double phi1(double x) {
  const double ax = std::abs(x);
  if (ax < 1e-3) return factorial_series<5, 1>(x);
  if (ax < 0.05) return factorial_series<9, 1>(x);
  return std::expm1(x) / x;
}

// phi2(x) = (phi1(x) - 1) / x = (e^x - 1 - x) / x^2, continued by phi2(0) = 1/2.
// A rank-one damping A = u w^T with a = w.u needs t^2 phi2(-t a) where a may be 0
// (a damper whose gradient vanishes). The direct form cancels (relative error about
// 2 eps_mach / |x|), so below |x| = 1/2 use the series sum x^k / (k+2)!: 5, 9 or 17
// terms as |x| is below 1e-3, 0.05 or 0.5 (truncation error under 1e-18 each).
inline double phi2(double x) {
  const double ax = std::abs(x);
  if (ax < 1e-3) return factorial_series<5, 2>(x);
  if (ax < 0.05) return factorial_series<9, 2>(x);
  if (ax < 0.5) return factorial_series<17, 2>(x);
  return (std::expm1(x) - x) / (x * x);
}

}  // namespace raydamp
