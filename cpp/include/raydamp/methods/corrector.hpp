// Symplectic correctors (Wisdom, Holman & Touma 1996) for the leapfrog over a near-integrable split,
// H = A + B with B = O(eps): the step Phi = e^{hA/2} e^{hB} e^{hA/2} (sv; 2s and 3s without drag) is, to
// first order in B, the exact flow conjugated by a map C, Phi = C^{-1} e^{h(A+B) + O(eps^2 h^3)} C. Run from
// C^{-1}(z0) and read through C, the leapfrog's error linear in eps, O(eps h^2), goes, leaving O(eps^2 h^2):
// for planets of mass ratio eps ~ 1e-3 about 1/eps smaller. C depends on h, and only on the drift A and the
// kick B, so it applies without drag (a damping flow would add terms it does not remove).
//
// The map: log C = h G(ad_{hA}) B + O(eps^2), with G(x) = (F(x) - 1) / x, F(x) = (x/2) / sinh(x/2) the linear
// part of the symmetric product's logarithm: G odd, G(x) = g_1 x + g_3 x^3 + ..., g_1 = -1/24, g_3 = 7/5760,
// g_5 = -31/967680, g_7 = 127/154828800 (from the series of x / sinh x, 2^{-2k} times its x^{2k} term).
// It is built from exact flows, as a product of
//   Z(a, b) = e^{ahA} e^{bhB} e^{-2ahA} e^{-bhB} e^{ahA},  log Z = 2 b h sum_{k odd} (a^k / k!) ad_{hA}^k B + O(eps^2),
// so n factors with the a_i fixed and the b_i solving sum_i 2 b_i a_i^k / k! = -g_k for k = 1, 3, ..., 2n - 1
// (a Vandermonde system in a_i^2) match G through x^{2n-1}, and the eps-linear error left is O(eps h^{2n+2}).
// The sign: the step loop's sequence of flows composes its maps in the other order from the Lie operators'
// product above, which turns C into C^{-1}; measured (tests/test_correctors.py), -g_k is the one that corrects.
// Each factor's inverse is its flows backward in reverse order, so C^{-1} is C's exact inverse.
//
// Corrector(order) for order = 4, 6, 8, 10 (n = order / 2 - 1 factors): the eps-linear error left is
// O(eps h^order). a_i = i / n, i = 1..n: Z's drifts reach 2h, and the b_i stay below 0.6 (nodes in (0, 1/2]
// gave b_i up to 19 at n = 4, kicks that cancel to 1e-14 of their size).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace raydamp {

struct Corrector {
  int order = 0;
  std::vector<double> a, b;  // Z(a_i, b_i), applied i = 0, 1, ...

  explicit Corrector(int order_) : order(order_) {
    if (order != 4 && order != 6 && order != 8 && order != 10)
      throw std::invalid_argument("corrector: must be 4, 6, 8 or 10 (the power of h in the eps-linear error it "
                                  "leaves), got " + std::to_string(order));
    const int n = order / 2 - 1;
    // G's odd coefficients g_1, g_3, g_5, g_7 (x / sinh x at x / 2, less 1, over x)
    constexpr long double g[] = {-1.0L / 24, 7.0L / 5760, -31.0L / 967680, 127.0L / 154828800};
    // sum_i w_i (a_i^2)^j = -g_{2j+1} (2j+1)!, w_i = 2 b_i a_i: a Vandermonde system, solved in long double
    using Matrix = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
    using Vector = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
    Vector nodes(n), rhs(n);
    Matrix V(n, n);
    long double factorial = 1;
    for (int j = 0; j < n; ++j) {
      if (j > 0) factorial *= (2.0L * j) * (2.0L * j + 1);
      for (int i = 0; i < n; ++i) {
        nodes[i] = static_cast<long double>(i + 1) / n;
        V(j, i) = std::pow(nodes[i] * nodes[i], static_cast<long double>(j));
      }
      rhs[j] = -g[j] * factorial;
    }
    const Vector w = V.partialPivLu().solve(rhs);
    for (int i = 0; i < n; ++i) {
      a.push_back(static_cast<double>(nodes[i]));
      b.push_back(static_cast<double>(w[i] / (2 * nodes[i])));
    }
    validate(g);
  }

  // The conditions hold in the doubles kept: sum_i 2 b_i a_i^k / k! = -g_k, k = 1, 3, ..., 2n - 1.
  void validate(const long double* g) const {
    long double factorial = 1;
    for (std::size_t j = 0; j < a.size(); ++j) {
      if (j > 0) factorial *= (2.0L * j) * (2.0L * j + 1);
      long double s = 0;
      for (std::size_t i = 0; i < a.size(); ++i)
        s += 2.0L * b[i] * std::pow(static_cast<long double>(a[i]), static_cast<long double>(2 * j + 1)) / factorial;
      if (std::abs(s + g[j]) > 1e-14L * std::abs(g[j]))
        throw std::logic_error("corrector: condition " + std::to_string(2 * j + 1) + " fails");
    }
  }
};

// z <- C(z) (forward) or C^{-1}(z), for the leapfrog of step h over model's drift and kick.
template <class Model, class Vec>
void apply_corrector(const Model& model, const Corrector& c, double h, bool inverse, Vec& q, Vec& p) {
  const int n = static_cast<int>(c.a.size());
  for (int k = 0; k < n; ++k) {
    const int i = inverse ? n - 1 - k : k;
    const double a = (inverse ? -c.a[i] : c.a[i]) * h, b = c.b[i] * h;
    model.drift(q, p, a);
    model.kick(q, p, b);
    model.drift(q, p, -2.0 * a);
    model.kick(q, p, -b);
    model.drift(q, p, a);
  }
}

}  // namespace raydamp
