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

// A step that is long beside the orbit forms the orbit's invariants, the G functions and the update in
// long double (x87's 64-bit significand) and rounds to double once per coordinate at the end. In double,
// the rounding of r0, beta and the G functions is the same at every step of an orbit and drifts the
// energy steadily (4e-12 relative over 4e4 steps of e = 0.5, phase 7e-7 after 10^4 periods); in long
// double the final rounding to nearest is all that is left, and the error grows as rounding does
// (Brouwer's law). A step short beside the orbit (kShortReach) scales those roundings down by its
// length and is formed in double, at 0.6 of the cost (benchmarks/bench_kepler_drift.cpp).


// c2 = sum_j (-x)^j / (2j + 2)!, c3 = sum_j (-x)^j / (2j + 3)!, by Horner in stumpff (and in
// flows/kepler_lanes.hpp, which must round alike): |x| <= 0.1 puts the first term left out below 1e-23 of
// the first.
template <class Real>
inline constexpr Real kStumpff2[] = {1.0L / 2, 1.0L / 24, 1.0L / 720, 1.0L / 40320, 1.0L / 3628800, 1.0L / 479001600,
                                     1.0L / 87178291200, 1.0L / 20922789888000};
template <class Real>
inline constexpr Real kStumpff3[] = {1.0L / 6, 1.0L / 120, 1.0L / 5040, 1.0L / 362880, 1.0L / 39916800,
                                     1.0L / 6227020800, 1.0L / 1307674368000, 1.0L / 355687428096000};

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
  // Terms up to j = top: the first left out, |x|^(top+1) / (2 top + 4)!, is below 3e-23 of the first
  // in each range (a step short beside the orbit has a small x, and needs four).
  const Real size = std::abs(x);
  const int top = size < 1e-4 ? 3 : size < 1e-3 ? 4 : size < 1e-2 ? 5 : size < 0.03 ? 6 : 7;
  const Real y = -x;
  constexpr const Real* a2 = kStumpff2<Real>;
  constexpr const Real* a3 = kStumpff3<Real>;
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
    // t / r0 and the cube root (t >= mu s^3 / 6 on the way out) overshoot an unbound orbit's s
    s = t * ir;
    if (o.beta <= 0.0) {
      const Real cube = std::cbrt(6.0 * t / o.mu);
      if (std::abs(cube) < std::abs(s)) s = cube;
    }
    if (o.beta < 0.0) {
      // ... by as much as they like: far out |t| grows like c e^{k |s|}, k = sqrt(-beta), with
      // c = (mu / k^3 + sign(t) sigma0 / k^2 + r0 / k) / 2, so the log of |t| / c is within O(|s| c / |t|)
      // of the root, where Laguerre-Conway took two steps of s per iteration down from the cube root
      // (not converged in 100 at t = 1e7 on e = 1.5).
      const Real k = std::sqrt(-o.beta);
      const Real c = 0.5 * (o.mu / (k * k * k) + (t > 0 ? o.sigma0 : -o.sigma0) / (k * k) + o.r0 / k);
      if (c > 0) {
        const Real far = std::copysign(std::log1p(std::abs(t) / c) / k, t);
        if (std::abs(far) < std::abs(s)) s = far;
      }
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

// A step is short when |t| (|v0| + sqrt(mu / r0)) < kShortReach r0 (tested as 2 t^2 (v0^2 + mu / r0) <
// kShortReach^2 r0^2, which implies it): the increments f - 1, g - t, fdot, gdot - 1 are then small
// beside 1 and t, so a rounding of r0, beta or the G functions moves q by (at most) that rounding times
// |v0| t / r0, and the energy by that times sigma0 / (r0 |v0|), whose sign follows the orbit in and out.
// Formed in double there, the drift's own error stays a few hundredths of an ulp of q per step, under the
// rounding of the state that every step makes anyway (benchmarks/kepler_rounding.py measures both).
inline constexpr double kShortReach = 0.05;

// The short step in double: the anomaly from s(t)'s Taylor series (within O((|v0| t / r0)^4) of the
// root) and Halley's iteration; the G functions are carried from the last iterate s to s + ds by their
// Taylor series (dG_k/ds = G_{k-1}, dG_0/ds = -beta G_1), exact to (ds / s)^3 < 1e-18 where
// |ds| <= 1e-6 |s|, instead of forming them again. Returns false (q, v untouched) if Halley has not
// converged in four iterations, which leaves the step to the general solver.
template <class Q, class V>
inline bool short_drift(double mu, double t, double r0, double ir0, double sigma0, double v2, Q& q, V& v) {
  const Orbit<double> o{r0, sigma0, 2.0 * mu * ir0 - v2, mu};
  const double ir3 = ir0 * ir0 * ir0;
  double s = t * ir0 * (1.0 + t * (-0.5 * sigma0 * ir3 * r0 +
                                   t * (3.0 * sigma0 * sigma0 * ir3 * ir0 * ir0 - (v2 - mu * ir0) * ir3) * r0 / 6.0));
  Anomaly<double> a;
  for (int it = 0; it < 4; ++it) {
    g_functions(o, s, a);
    const double f = r0 * a.g1 + sigma0 * a.g2 + mu * a.g3 - t;
    const double fp = a.r;                                      // dt/ds = r
    const double fpp = sigma0 * a.g0 + (mu - o.beta * r0) * a.g1;  // dr/ds
    const double ds = -f * fp / (fp * fp - 0.5 * f * fpp);     // Halley
    if (!(std::abs(ds) <= 1e-6 * std::abs(s))) {
      s += ds;
      continue;
    }
    const double half = 0.5 * ds * ds;
    const double g0 = a.g0 - o.beta * (a.g1 * ds + a.g0 * half);
    const double g1 = a.g1 + a.g0 * ds - o.beta * a.g1 * half;
    const double g2 = a.g2 + a.g1 * ds + a.g0 * half;
    const double r = r0 * g0 + sigma0 * g1 + mu * g2;
    const double ir = 1.0 / r;
    const double f1 = -mu * g2 * ir0;  // f - 1
    const double g = r0 * g1 + sigma0 * g2;
    const double fdot = -mu * g1 * ir * ir0;
    const double gdot1 = -mu * g2 * ir;  // gdot - 1
    for (int i = 0; i < q.size(); ++i) {
      const double qi = q[i], vi = v[i];
      q[i] = qi + (f1 * qi + g * vi);
      v[i] = vi + (fdot * qi + gdot1 * vi);
    }
    return true;
  }
  return false;
}

// The Kepler flow over any t, formed in long double (see the top of this file).
template <class Q, class V>
inline void extended_drift(double mu_, double t_, Q& q, V& v) {
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
  // The anomaly is found in double, then taken one Newton step further in long double: an s off by a
  // little is the flow over a time off by a little, which keeps the energy but not the phase, and the
  // double solve leaves t(s) - t at the rounding of t(s)'s largest term in double (through the pericentre
  // of e = 0.99, 1e-13 of q). The G functions at that s and the update are formed in long double.
  const Orbit<double> od{static_cast<double>(o.r0), static_cast<double>(o.sigma0), static_cast<double>(o.beta),
                         mu_};
  const Anomaly<double> guess = solve_anomaly(od, static_cast<double>(t), static_cast<double>(v2));
  Anomaly<Real> a;
  g_functions(o, static_cast<Real>(guess.s), a);
  if (!(std::isfinite(guess.r))) a.r = guess.r;  // not converged: NaN, which the step loop stops on
  Real ir = 1 / a.r;
  {
    // |ds| / |s| is at the double solve's rounding, so first order in ds is exact to long double's.
    const Real ds = -(o.r0 * a.g1 + o.sigma0 * a.g2 + mu * a.g3 - t) * ir;
    const Real g0 = a.g0 - o.beta * a.g1 * ds, g1 = a.g1 + a.g0 * ds, g2 = a.g2 + a.g1 * ds;
    const Real r = o.r0 * g0 + o.sigma0 * g1 + mu * g2;
    ir *= 1 - (r - a.r) * ir;
    a.g0 = g0, a.g1 = g1, a.g2 = g2, a.r = r;
  }
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

// q, v <- the Kepler flow of (q, v) over time t (any sign), mu > 0; q and v are vectors of 2 or 3
// doubles (operator[] and size()): a short step in double, any other in long double.
template <class Q, class V>
inline void drift(double mu, double t, Q& q, V& v) {
  if (t == 0) return;
  double r2 = 0, sigma = 0, v2 = 0;
  for (int i = 0; i < q.size(); ++i) {
    r2 += q[i] * q[i];
    sigma += q[i] * v[i];
    v2 += v[i] * v[i];
  }
  const double r0 = std::sqrt(r2), ir0 = 1.0 / r0;
  if (2.0 * t * t * (v2 + mu * ir0) < kShortReach * kShortReach * r2 && short_drift(mu, t, r0, ir0, sigma, v2, q, v))
    return;
  extended_drift(mu, t, q, v);
}

}  // namespace raydamp::kepler
