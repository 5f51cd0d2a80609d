// The exact Kepler flow, q'' = -mu q / |q|^3, over any time t, for elliptic, parabolic and
// hyperbolic orbits, in universal variables (Danby, Fundamentals of Celestial Mechanics, 6.9;
// Stiefel & Scheifele): with the universal anomaly s (ds/dt = 1/r) and beta = 2 mu / r0 - v0^2,
//   t = r0 G1(s) + sigma0 G2(s) + mu G3(s),    r(s) = r0 G0 + sigma0 G1 + mu G2,
// sigma0 = q0 . v0, G_k(s) = s^k c_k(beta s^2) with the Stumpff functions c_k. Then
//   q = f q0 + g v0,  v = fdot q0 + gdot v0,
//   f - 1 = -mu G2 / r0,  g = r0 G1 + sigma0 G2,  fdot = -mu G1 / (r r0),  gdot - 1 = -mu G2 / r,
// written as increments so that a small step keeps the digits of q0 and v0.
#pragma once

#include <cmath>
#include <limits>

namespace raydamp::kepler {

// The orbit's invariants, the G functions and the update are formed in long double (x87's 64-bit
// significand) and rounded to double once per coordinate at the end. In double, the rounding of r0,
// beta and the G functions is the same at every step of an orbit and drifts the energy steadily
// (4e-12 relative over 4e4 steps of e = 0.5, phase 7e-7 after 10^4 periods); in long double the final
// rounding to nearest is all that is left, and the error grows as rounding does (Brouwer's law).


// c0..c3 of x (Stumpff functions): c0 = cos sqrt x, c1 = sin sqrt x / sqrt x, c2 = (1 - c0) / x,
// c3 = (1 - c1) / x, and their cosh/sinh forms for x < 0. For |x| <= 4, by series at x / 4^k,
// |x / 4^k| < 0.1, then quadrupled back with c0(4x) = 2 c0^2 - 1, c1(4x) = c0 c1,
// c2(4x) = c1^2 / 2, c3(4x) = (c2 + c0 c3) / 4: the closed forms of c2 and c3 cancel near 0, and
// the at most three quadruplings cost an ulp or two each.
template <class Real>
struct Stumpff {
  Real c0, c1, c2, c3;
};

template <class Real>
inline Stumpff<Real> stumpff(Real x) {
  // Far from 0 the closed forms lose nothing (1 - cos s as 2 sin^2(s/2), s - sin s and sinh s - s are
  // far from cancelling once s > 2), where quadrupling from the series would double a relative error
  // per level: 32 ulp on cosh sqrt 30.
  if (x > 4.0) {
    const Real s = std::sqrt(x), half = std::sin(0.5 * s), sine = std::sin(s);
    return {std::cos(s), sine / s, 2.0 * half * half / x, (s - sine) / (s * x)};
  }
  if (x < -4.0) {
    const Real s = std::sqrt(-x), half = std::sinh(0.5 * s), sine = std::sinh(s);
    return {std::cosh(s), sine / s, -2.0 * half * half / x, (s - sine) / (s * x)};
  }
  int levels = 0;
  while (std::abs(x) > 0.1) {
    x *= 0.25;
    ++levels;
  }
  // c2 = sum_j (-x)^j / (2j + 2)!, c3 = sum_j (-x)^j / (2j + 3)! by Horner: |x| <= 0.1 puts the
  // first term left out below 1e-23 of the first.
  constexpr Real a2[] = {1.0L / 2, 1.0L / 24, 1.0L / 720, 1.0L / 40320, 1.0L / 3628800, 1.0L / 479001600,
                         1.0L / 87178291200, 1.0L / 20922789888000};
  constexpr Real a3[] = {1.0L / 6, 1.0L / 120, 1.0L / 5040, 1.0L / 362880, 1.0L / 39916800, 1.0L / 6227020800,
                         1.0L / 1307674368000, 1.0L / 355687428096000};
  // Terms up to j = top: the first left out, |x|^(top+1) / (2 top + 4)!, is below 3e-23 of the first
  // in each range (a step short beside the orbit has a small x, and needs four).
  const Real size = std::abs(x);
  const int top = size < 1e-4 ? 3 : size < 1e-3 ? 4 : size < 1e-2 ? 5 : size < 0.03 ? 6 : 7;
  const Real y = -x;
  Real c2 = a2[top], c3 = a3[top];
  for (int j = top - 1; j >= 0; --j) {
    c2 = a2[j] + y * c2;
    c3 = a3[j] + y * c3;
  }
  Real c1 = 1.0 - x * c3;
  Real c0 = 1.0 - x * c2;
  for (int k = 0; k < levels; ++k) {
    const Real n3 = 0.25 * (c2 + c0 * c3);
    const Real n2 = 0.5 * c1 * c1;
    const Real n1 = c0 * c1;
    const Real n0 = 2.0 * c0 * c0 - 1.0;
    c0 = n0, c1 = n1, c2 = n2, c3 = n3;
  }
  return {c0, c1, c2, c3};
}

// What a drift needs from the start of the step, computed once per step.
template <class Real>
struct Orbit {
  Real r0;      // |q0|
  Real sigma0;  // q0 . v0
  Real beta;    // 2 mu / r0 - |v0|^2: > 0 bound, 0 parabolic, < 0 unbound
  Real mu;
};

template <class Real>
struct Anomaly {
  Real s;                // the universal anomaly reached
  Real g0, g1, g2, g3;  // G_k(s)
  Real r;               // |q| at the end
};

// G_k(s) at beta s^2.
template <class Real>
inline void g_functions(const Orbit<Real>& o, Real s, Anomaly<Real>& a) {
  const Stumpff<Real> c = stumpff(o.beta * s * s);
  a.s = s;
  a.g0 = c.c0;
  a.g1 = s * c.c1;
  a.g2 = s * s * c.c2;
  a.g3 = s * s * s * c.c3;
  a.r = o.r0 * a.g0 + o.sigma0 * a.g1 + o.mu * a.g2;
}

// The s with t = r0 G1 + sigma0 G2 + mu G3 (t already reduced modulo the period of a bound
// orbit). The start is s(t)'s Taylor series to t^3 (s' = 1/r, s'' = -sigma / r^3,
// s''' = 3 sigma^2 / r^5 - (v^2 - mu / r) / r^3), within O(t^4) of the root for a step that is
// short beside the orbit; Halley's iteration (cubic) then takes it to rounding in one or two
// steps. Where the series start is poor (a long step) Laguerre-Conway's iteration (order 5,
// convergent from any start on Kepler's equation) is used instead.
template <class Real>
inline Anomaly<Real> solve_anomaly(const Orbit<Real>& o, Real t, Real v2) {
  Anomaly<Real> a{};
  const Real r0 = o.r0, ir = 1.0 / r0, ir3 = ir * ir * ir;
  Real s = t * ir * (1.0 + t * (-0.5 * o.sigma0 * ir3 * r0 +
                                  t * (3.0 * o.sigma0 * o.sigma0 * ir3 * ir * ir - (v2 - o.mu * ir) * ir3) * r0 / 6.0));
  // The series is trusted while its last term is small beside its first (|t| well inside the
  // time scale r0 / v0 and the orbit's); else a plain start for Laguerre-Conway.
  const bool short_step = std::abs(t) * (std::sqrt(v2) + std::sqrt(o.mu * ir)) < 0.3 * r0;
  if (!short_step && o.beta > 0) {
    // A bound orbit: s = (E - E0) / sqrt(beta) with E the eccentric anomaly, and E - E0 differs from
    // the mean anomaly's change n t by e (sin E - sin E0), at most 2: s = t beta / mu is that close.
    s = t * o.beta / o.mu;
  } else if (!short_step) {
    s = t * ir;
    if (o.beta < 0.0) {
      const Real cube = std::cbrt(6.0 * t / o.mu);
      if (std::abs(cube) < std::abs(s)) s = cube;
    }
  }
  constexpr Real eps = std::numeric_limits<Real>::epsilon();
  Real last = std::numeric_limits<Real>::infinity();
  for (int it = 0; it < 100; ++it) {
    g_functions(o, s, a);
    const Real f = o.r0 * a.g1 + o.sigma0 * a.g2 + o.mu * a.g3 - t;
    const Real fp = a.r;                                               // dt/ds = r
    const Real fpp = o.sigma0 * a.g0 + (o.mu - o.beta * o.r0) * a.g1;  // dr/ds
    Real ds;
    if (short_step) {
      ds = -f / (fp - 0.5 * f * fpp / fp);  // Halley
    } else {
      constexpr Real n = 5.0;  // Laguerre-Conway
      const Real disc = std::abs((n - 1.0) * (n - 1.0) * fp * fp - n * (n - 1.0) * f * fpp);
      ds = -n * f / (fp + std::copysign(std::sqrt(disc), fp));
    }
    if (!std::isfinite(ds)) break;
    const Real size = std::abs(ds);
    // Halley's error cubes each iteration: a correction below 1e-6 of s leaves one below 1e-18 of s, under
    // the rounding of s, so the G functions need not be formed at s + ds to confirm it.
    if (short_step && size <= 1e-6 * std::abs(s)) {
      a.s = s + ds;
      return a;
    }
    // Converged: the correction is at the rounding of s, and a.* (at this s) are the G's to rounding.
    if (size <= 2.0 * eps * std::abs(s)) return a;
    s += ds;
    // Past 1e-10, a correction that no longer shrinks is rounding: stop there.
    if (size >= last && size <= 1e-10 * std::abs(s)) {
      g_functions(o, s, a);
      return a;
    }
    last = size;
  }
  // Not reached on any orbit tried (tests/test_kepler.py); if it were, the step loop's check stops the
  // run there, "non_finite", keeping what it computed.
  a.r = std::numeric_limits<Real>::quiet_NaN();
  return a;
}

// q, v <- the Kepler flow of (q, v) over time t (any sign), mu > 0; q and v are vectors of 2 or 3
// doubles (operator[] and size()).
template <class Q, class V>
inline void drift(double mu_, double t_, Q& q, V& v) {
  using Real = long double;
  const Real mu = mu_;
  Real t = t_;
  if (t == 0) return;
  Orbit<Real> o;
  o.mu = mu;
  Real r2 = 0, sigma = 0, v2 = 0;
  for (int i = 0; i < q.size(); ++i) {
    const Real x = q[i], u = v[i];
    r2 += x * x;
    sigma += x * u;
    v2 += u * u;
  }
  o.r0 = std::sqrt(r2);
  const Real ir0 = 1 / o.r0;  // x87 divisions are slow: one per radius, products after
  o.sigma0 = sigma;
  o.beta = 2 * mu * ir0 - v2;
  // A bound orbit's flow has period 2 pi mu / beta^{3/2}: a step is the same step modulo the period,
  // taken within half a period either way. |t| > half the period is t^2 beta^3 > pi^2 mu^2, tested
  // without a root (a step is almost always far shorter).
  constexpr Real pi = 3.141592653589793238462643383279502884L;
  if (o.beta > 0 && t * t * o.beta * o.beta * o.beta > pi * pi * mu * mu) {
    const Real period = 2 * pi * mu / (o.beta * std::sqrt(o.beta));
    if (std::abs(t) > period / 2) t = std::remainder(t, period);
    if (t == 0) return;
  }
  // The anomaly is found in double: an s off by a rounding is the flow over a time off by a rounding,
  // which keeps the energy. The G functions at that s and the update are formed in long double.
  const Orbit<double> od{static_cast<double>(o.r0), static_cast<double>(o.sigma0), static_cast<double>(o.beta),
                         mu_};
  const Anomaly<double> guess = solve_anomaly(od, static_cast<double>(t), static_cast<double>(v2));
  Anomaly<Real> a;
  g_functions(o, static_cast<Real>(guess.s), a);
  if (!(std::isfinite(guess.r))) a.r = guess.r;  // not converged: NaN, which the step loop stops on
  const Real ir = 1 / a.r;
  const Real f1 = -mu * a.g2 * ir0;              // f - 1
  const Real g = o.r0 * a.g1 + o.sigma0 * a.g2;  // g
  const Real fdot = -mu * a.g1 * ir * ir0;
  const Real gdot1 = -mu * a.g2 * ir;            // gdot - 1
  for (int i = 0; i < q.size(); ++i) {
    const Real qi = q[i], vi = v[i];
    q[i] = static_cast<double>(qi + (f1 * qi + g * vi));
    v[i] = static_cast<double>(vi + (fdot * qi + gdot1 * vi));
  }
}

}  // namespace raydamp::kepler
