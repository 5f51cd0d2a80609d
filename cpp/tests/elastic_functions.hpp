// The elastic pendulum's functions (k = l = m = 1, g = (0, 0, -1)) with the
// compiled-function signature, written as the JIT would produce them: C stand-ins
// for the tests of compiled systems (test_system_kinds, test_dashpot_norm).
#pragma once

#include <cmath>

namespace raydamp::test::elastic {

inline double length(const double* q) { return std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]); }

inline void potential(double* out, const double* q, void*) {
  const double r = length(q);
  out[0] = 0.5 * (r - 1.0) * (r - 1.0) + q[2];
}
inline void gradient(double* out, const double* q, void*) {
  const double r = length(q);
  for (int i = 0; i < 3; ++i) out[i] = (1.0 - 1.0 / r) * q[i];
  out[2] += 1.0;
}
inline void hessian_product(double* out, const double* in, void*) {
  const double* q = in;
  const double* v = in + 3;
  const double r = length(q);
  const double qv = q[0] * v[0] + q[1] * v[1] + q[2] * v[2];
  for (int i = 0; i < 3; ++i) out[i] = (1.0 - 1.0 / r) * v[i] + qv / (r * r * r) * q[i];
}
// The gradient of the one dashpot's function |q|.
inline void radial_gradient(double* out, const double* q, void*) {
  const double r = length(q);
  for (int i = 0; i < 3; ++i) out[i] = q[i] / r;
}
// The dashpot's projection P(q, u) = grad g (grad g . u) = (q . u) q / |q|^2 (M = I).
inline void radial_projection(double* out, const double* in, void*) {
  const double* q = in;
  const double* u = in + 3;
  const double s = (q[0] * u[0] + q[1] * u[1] + q[2] * u[2]) / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
  for (int i = 0; i < 3; ++i) out[i] = s * q[i];
}
// J3 = q_x p_y - q_y p_x from (q, p).
inline void j3(double* out, const double* in, void*) { out[0] = in[0] * in[4] - in[1] * in[3]; }

}  // namespace raydamp::test::elastic
