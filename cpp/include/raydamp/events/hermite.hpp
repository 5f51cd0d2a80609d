// Cubic Hermite interpolation on one step [t0, t0 + h] from the values and time derivatives at its
// ends: x(t0 + s h) = h00(s) x0 + h10(s) h x0' + h01(s) x1 + h11(s) h x1'. On a smooth solution it is
// fourth order in h where the end values are (an order-4 method's q, p and their exact derivatives
// M^{-1} p and the force), so events and dense output keep order 4 (and an order-2 method's order 2).
#pragma once

namespace raydamp::hermite {

struct Weights {
  double h00, h10, h01, h11;
};

// The weights of x0, h x0', x1, h x1' at s in [0, 1].
inline Weights value(double s) {
  const double s2 = s * s, s3 = s2 * s;
  return {2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2};
}

// Their derivatives in s (so dx/dt = (d00 x0 + d01 x1) / h + d10 x0' + d11 x1').
inline Weights slope(double s) {
  const double s2 = s * s;
  return {6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, 6.0 * s - 6.0 * s2, 3.0 * s2 - 2.0 * s};
}

inline double at(const Weights& w, double x0, double d0, double x1, double d1, double h) {
  return w.h00 * x0 + w.h10 * h * d0 + w.h01 * x1 + w.h11 * h * d1;
}

inline double rate_at(const Weights& w, double x0, double d0, double x1, double d1, double h) {
  return (w.h00 * x0 + w.h01 * x1) / h + w.h10 * d0 + w.h11 * d1;
}

}  // namespace raydamp::hermite
