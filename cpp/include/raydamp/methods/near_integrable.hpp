// Near-integrable tables (Laskar & Robutel, Celest. Mech. Dyn. Astron. 80 (2001) 39): for H = A + eps B with
// A's flow exact (a Kepler drift), the step A(a_0 h) B(b_1 h) A(a_1 h) ... B(b_n h) A(a_n h) errs by
// O(eps h^{2n} + eps^2 h^2) when the kicks, at times tau_i = a_0 + ... + a_{i-1} with weights b_i, form a
// quadrature rule exact for polynomials of degree 2n - 1 on [0, 1]: the eps-terms of the error are those of
// the quadrature of B along A's flow. SABA_n takes the n Gauss-Legendre nodes (every a_i > 0), SBAB_n the
// n + 1 Gauss-Lobatto ones (kicks at both ends, so a_0 = a_{n+1} = 0: BAB...B). Computed here in long
// double from the Legendre polynomials, never typed; composition.hpp checks the conditions when it builds
// them. Where eps is not small they are order-2 methods, as any symmetric splitting of this form.
#pragma once

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace raydamp::near_integrable {

// The step's fractions of h: ends[i] = a_i (the base's end flow, the drift), middles[i] = b_{i+1} (its middle
// flow, the kick); ends has one more entry than middles.
struct Table {
  std::vector<long double> ends, middles;
};

// P_n(x) and P_n'(x) by the three-term recurrence.
inline void legendre(int n, long double x, long double& p, long double& dp) {
  long double previous = 1.0L, current = x;
  if (n == 0) {
    p = 1.0L, dp = 0.0L;
    return;
  }
  for (int k = 2; k <= n; ++k) {
    const long double next = ((2 * k - 1) * x * current - (k - 1) * previous) / k;
    previous = current;
    current = next;
  }
  p = current;
  dp = n * (x * current - previous) / (x * x - 1.0L);
}

// Newton from x until the step is below rounding: f(x, value, slope) gives f and f' at x.
template <class F>
long double newton(long double x, F f) {
  for (int it = 0; it < 100; ++it) {
    long double value, slope;
    f(x, value, slope);
    const long double step = value / slope;
    x -= step;
    if (std::abs(step) <= 4.0L * std::numeric_limits<long double>::epsilon()) break;
  }
  return x;
}

// A table from kick times tau (in [0, 1], increasing, symmetric about 1/2) and weights w: each half the
// mirror of the other exactly, and a middle entry (where the count is odd) what makes the sum 1, as
// composition.hpp's palindromes are built.
inline std::vector<long double> mirrored(std::vector<long double> x) {
  const std::size_t k = x.size();
  long double outer = 0.0L;
  for (std::size_t i = 0; i < k / 2; ++i) {
    x[k - 1 - i] = x[i];
    outer += x[i];
  }
  if (k % 2 == 1) x[k / 2] = 1.0L - 2.0L * outer;
  return x;
}

inline Table from_nodes(const std::vector<long double>& tau, const std::vector<long double>& w) {
  Table t;
  long double at = 0.0L;
  for (long double x : tau) {
    t.ends.push_back(x - at);
    at = x;
  }
  t.ends.push_back(1.0L - at);
  t.ends = mirrored(t.ends);
  t.middles = mirrored(w);
  return t;
}

// SABA_n: kicks at the n Gauss-Legendre nodes of [0, 1], weighted as that rule.
inline Table saba(int n) {
  if (n < 1) throw std::invalid_argument("saba: n >= 1");
  std::vector<long double> tau(n), w(n);
  const long double pi = std::acos(-1.0L);
  for (int i = 0; i < n; ++i) {
    // the i-th root of P_n from below, from the asymptotic guess
    const long double x = newton(-std::cos(pi * (i + 0.75L) / (n + 0.5L)), [n](long double y, long double& v,
                                                                               long double& s) { legendre(n, y, v, s); });
    long double p, dp;
    legendre(n, x, p, dp);
    tau[i] = 0.5L * (1.0L + x);
    w[i] = 1.0L / ((1.0L - x * x) * dp * dp);  // 2 / ((1 - x^2) P_n'(x)^2), halved for [0, 1]
  }
  return from_nodes(tau, w);
}

// SBAB_n: kicks at the n + 1 Gauss-Lobatto nodes of [0, 1] (both ends and the roots of P_n'), weighted as
// that rule.
inline Table sbab(int n) {
  if (n < 1) throw std::invalid_argument("sbab: n >= 1");
  std::vector<long double> tau(n + 1), w(n + 1);
  const long double pi = std::acos(-1.0L);
  const long double end_weight = 1.0L / (n * (n + 1));  // 2 / (n (n + 1)), halved
  tau[0] = 0.0L, tau[n] = 1.0L;
  w[0] = w[n] = end_weight;
  for (int i = 1; i < n; ++i) {
    // P_n' = 0: Newton with P_n'' from Legendre's equation, (1 - x^2) P'' = 2 x P' - n (n + 1) P
    const long double x = newton(-std::cos(pi * i / n), [n](long double y, long double& v, long double& s) {
      long double p, dp;
      legendre(n, y, p, dp);
      v = dp;
      s = (2.0L * y * dp - n * (n + 1) * p) / (1.0L - y * y);
    });
    long double p, dp;
    legendre(n, x, p, dp);
    tau[i] = 0.5L * (1.0L + x);
    w[i] = end_weight / (p * p);
  }
  return from_nodes(tau, w);
}

}  // namespace raydamp::near_integrable
