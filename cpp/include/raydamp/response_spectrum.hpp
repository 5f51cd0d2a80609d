// The elastic response spectrum of a piecewise-linear ground acceleration: for each natural frequency
// omega, the peak |u| over the record's sample times of u'' + 2 zeta omega u' + omega^2 u = -a(t), from rest
// at the first sample, a(t) the straight lines through the samples.
//
// Over one sample interval the forcing is linear in time, so the step from (u, u') at t_k to t_{k+1} is exact
// and linear in (u, u', a_k, a_{k+1}) (Nigam and Jennings, 1969, BSSA 59(2), the recurrence behind every
// response-spectrum program): (u, u')_{k+1} = P (u, u')_k + b0 a_k + b1 a_{k+1}. Its coefficients come from the
// particular solution of the linear forcing, u_p(tau) = alpha + beta tau, and the free damped motion P:
// x(dt) = P (x - x_p(0)) + x_p(dt). They are formed in long double: x_p is O(1/omega^2) while the step's
// load terms are O(dt^2), so the subtraction cancels about (omega dt)^-2 of the digits.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace raydamp {

// One exact step over an interval of length dt, per unit mass.
struct OscillatorStep {
  double p11, p12, p21, p22;  // the free damped motion of (u, u') over dt
  double u0, u1, v0, v1;      // (u, u') gained per unit of a_k (u0, v0) and of a_{k+1} (u1, v1)
};

// The step of u'' + 2 zeta omega u' + omega^2 u = -a, a linear over dt; omega > 0, 0 <= zeta < 1, dt > 0.
inline OscillatorStep oscillator_step(double omega, double zeta, double dt) {
  using L = long double;
  const L w = omega, z = zeta, h = dt;
  const L wd = w * std::sqrt(1.0L - z * z);  // the damped frequency (zeta < 1: an underdamped oscillator)
  const L decay = std::exp(-z * w * h);
  const L c = std::cos(wd * h), s = std::sin(wd * h);
  const L p11 = decay * (c + z * w / wd * s), p12 = decay * s / wd;
  const L p21 = -decay * w * w / wd * s, p22 = decay * (c - z * w / wd * s);
  // -a(tau) = -(a_k + (a_{k+1} - a_k) tau / h): u_p = alpha + beta tau with beta = -(a_{k+1} - a_k) / (w^2 h)
  // and alpha = -a_k / w^2 - 2 z w beta / w^2, split into the parts proportional to a_k and to a_{k+1}.
  const L w2 = w * w, w3h = w2 * w * h;
  const L beta0 = 1.0L / (w2 * h), beta1 = -beta0;
  const L alpha0 = -1.0L / w2 - 2.0L * z / w3h, alpha1 = 2.0L * z / w3h;
  // x_p(h) - P x_p(0) for each part; x_p(h) = (alpha + beta h, beta).
  const auto gained_u = [&](L alpha, L beta) { return alpha + beta * h - (p11 * alpha + p12 * beta); };
  const auto gained_v = [&](L alpha, L beta) { return beta - (p21 * alpha + p22 * beta); };
  return {static_cast<double>(p11), static_cast<double>(p12), static_cast<double>(p21), static_cast<double>(p22),
          static_cast<double>(gained_u(alpha0, beta0)), static_cast<double>(gained_u(alpha1, beta1)),
          static_cast<double>(gained_v(alpha0, beta0)), static_cast<double>(gained_v(alpha1, beta1))};
}

// Intervals within this relative distance of the one a step was formed for reuse it: a record's sample times
// k dt differ from a whole multiple in their last bits only, which moves the response by as little.
inline constexpr double kSameIntervalTolerance = 1e-12;

// peaks[i] = max_k |u_k| for omega[i] (n_omega of them) under the n_samples samples (times[k], accel[k]).
// The caller checks the input (times increasing, everything finite, omega > 0, 0 <= zeta < 1).
inline void elastic_peaks(const double* omega, std::size_t n_omega, double zeta, const double* times,
                          const double* accel, std::size_t n_samples, double* peaks) {
  for (std::size_t i = 0; i < n_omega; ++i) {
    double u = 0.0, v = 0.0, peak = 0.0;
    double formed_for = -1.0;
    OscillatorStep step{};
    for (std::size_t k = 0; k + 1 < n_samples; ++k) {
      const double dt = times[k + 1] - times[k];
      if (!(std::abs(dt - formed_for) <= kSameIntervalTolerance * formed_for)) {
        step = oscillator_step(omega[i], zeta, dt);
        formed_for = dt;
      }
      const double u_next = step.p11 * u + step.p12 * v + step.u0 * accel[k] + step.u1 * accel[k + 1];
      v = step.p21 * u + step.p22 * v + step.v0 * accel[k] + step.v1 * accel[k + 1];
      u = u_next;
      peak = std::max(peak, std::abs(u));
    }
    peaks[i] = peak;
  }
}

}  // namespace raydamp
