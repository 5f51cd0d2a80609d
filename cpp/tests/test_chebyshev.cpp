// The Chebyshev machinery behind the sparse damping flows (raydamp/damping/chebyshev.hpp):
// - the FFT interpolant equals the defining sum c_k = (2/N) sum_j g_j cos(pi k (j + 1/2) / N),
//   computed here directly in long double, to 1e-14 of max |g| for N = 32 .. 4096 (every radix
//   the series' doublings use);
// - the series of exp(-a (y + 1)) equals exp to 1e-12 of max |g| on [-1, 1] for a from 1e-3
//   to 1e4 (the degree climbing to the thousands), and a degree past the bound is refused.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "check.hpp"
#include "raydamp/damping/chebyshev.hpp"

namespace {

using raydamp::ChebyshevSeries;

std::vector<long double> direct_interpolant(const std::vector<double>& g) {
  const int n = static_cast<int>(g.size());
  const long double pi = 3.141592653589793238462643383279502884L;
  std::vector<long double> c(n, 0.0L);
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      // the multiple k (2j + 1) reduced mod 4N keeps the cosine's argument small
      const long long m = (static_cast<long long>(k) * (2 * j + 1)) % (4LL * n);
      c[k] += g[j] * std::cos(pi * m / (2.0L * n));
    }
    c[k] *= 2.0L / n;
  }
  c[0] *= 0.5L;
  return c;
}

void interpolant_equals_the_sum() {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int n = 32; n <= 16384; n *= 2) {
    std::vector<double> g(n);
    for (double& x : g) x = uniform(rng);
    const std::vector<double> fast = raydamp::detail::chebyshev_interpolant(g);
    const std::vector<long double> exact = direct_interpolant(g);
    double worst = 0.0;
    for (int k = 0; k < n; ++k) worst = std::max(worst, static_cast<double>(std::abs(fast[k] - exact[k])));
    if (!(worst <= 1e-14)) std::printf("N = %d: FFT interpolant off the sum by %.3g\n", n, worst);
    CHECK(worst <= 1e-14);
    if (n >= 4096) break;  // the long double reference costs O(N^2): 4096 is enough to cover the FFT's radix mix
  }
}

void exponential_to_rounding() {
  for (double a : {1e-3, 1.0, 30.0, 1e3, 1e4}) {
    auto g = [a](double y) { return std::exp(-a * (y + 1.0)); };
    const ChebyshevSeries s = raydamp::chebyshev_series(g, "test");
    double worst = 0.0;
    for (int i = 0; i <= 4000; ++i) {
      const double y = -1.0 + 2.0 * i / 4000.0;
      // Clenshaw on the scalar series
      double b1 = 0.0, b2 = 0.0;
      for (int k = s.degree(); k >= 1; --k) {
        const double b = 2.0 * y * b1 - b2 + s.c[k];
        b2 = b1;
        b1 = b;
      }
      const double value = y * b1 - b2 + s.c[0];
      worst = std::max(worst, std::abs(value - g(y)));
    }
    if (!(worst <= 1e-12)) std::printf("a = %g (degree %d): series off exp by %.3g\n", a, s.degree(), worst);
    CHECK(worst <= 1e-12);
  }
  bool refused = false;
  try {
    raydamp::chebyshev_series([](double y) { return std::cos(1e6 * y); }, "test");
  } catch (const raydamp::ChebyshevDegreeError&) {
    refused = true;
  }
  CHECK(refused);
}

}  // namespace

int main() {
  interpolant_equals_the_sum();
  exponential_to_rounding();
  if (raydamp::test::failures == 0) std::printf("test_chebyshev: all checks passed\n");
  return raydamp::test::failures == 0 ? 0 : 1;
}
