// raydamp::math::sin and sin4 (math/sine.hpp): accuracy against long double sinl,
// the four-lane form equal to the scalar one bit for bit on every path (series,
// reduced, libm fallback, mixed blocks, signed zeros, NaN), and the constants; the
// ensemble lanes' kernels (math/sine_lanes.hpp) in two- and four-lane registers equal
// to the scalar form bit for bit.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "check.hpp"
#include "raydamp/math/sine.hpp"
#include "raydamp/math/sine_lanes.hpp"

namespace {

using raydamp::math::sin;
using raydamp::math::sin4;

std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

// |sin(x) - sinl(x)| in units in the last place of the correctly rounded result.
double ulp_error(double x) {
  const long double exact = sinl(static_cast<long double>(x));
  const double rounded = static_cast<double>(exact);
  const double ulp = std::nextafter(std::fabs(rounded), 1e300) - std::fabs(rounded);
  return static_cast<double>(std::fabs(static_cast<long double>(sin(x)) - exact)) / ulp;
}

void check_accuracy() {
  std::mt19937_64 rng(7);
  // Ranges: the series alone, the first quadrants, a pendulum going over the top
  // many times, and up to kLarge.
  const double ranges[] = {1e-6, 0.5, 0.78, 3.2, 100.0, 1e4, 5e5};
  for (double range : ranges) {
    std::uniform_real_distribution<double> u(-range, range);
    double worst = 0.0, at = 0.0;
    for (int i = 0; i < 200000; ++i) {
      const double x = u(rng);
      const double e = ulp_error(x);
      if (e > worst) worst = e, at = x;
    }
    std::printf("|x| < %g: max error %.3f ulp (at %.17g)\n", range, worst, at);
    CHECK(worst <= 1.0);
  }
  // Near multiples of pi/2, where r is small and the reduction's error counts most.
  double worst = 0.0;
  for (int k = 1; k < 20000; ++k)
    for (double d : {-1e-9, -3e-12, 2e-13, 5e-10})
      worst = std::max(worst, ulp_error(k * 1.5707963267948966 + d));
  std::printf("near k pi/2: max error %.3f ulp\n", worst);
  CHECK(worst <= 1.0);
  CHECK(sin(0.0) == 0.0 && !std::signbit(sin(0.0)));
  CHECK(sin(-0.0) == 0.0 && std::signbit(sin(-0.0)));
  CHECK(std::isnan(sin(std::numeric_limits<double>::infinity())));
  CHECK(std::isnan(sin(std::numeric_limits<double>::quiet_NaN())));
  CHECK(sin(1e7) == std::sin(1e7));  // past kLarge: libm's
}

// Every block of four equals four scalar calls, bit for bit, whichever path the block
// takes: all small (series), some not (reduced, small lanes included), one huge or
// NaN lane (scalar fallback for the block).
void check_lanes_equal_scalar() {
  std::mt19937_64 rng(11);
  const double specials[] = {0.0, -0.0, 0.7799999, 0.78, -0.78, 1e-300, 3.0, -1e3, 1e6, -1e12,
                             std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
  std::uniform_real_distribution<double> small(-0.7, 0.7), wide(-50.0, 50.0);
  std::uniform_int_distribution<int> pick(0, 11), kind(0, 2);
  long mismatches = 0, blocks = 0;
  for (int b = 0; b < 300000; ++b) {
    double x[4], out[4];
    const int mode = kind(rng);
    for (double& xi : x) xi = mode == 0 ? small(rng) : mode == 1 ? wide(rng) : specials[pick(rng)];
    if (mode == 1 && b % 2) x[b % 4] = small(rng);  // small lanes inside a reduced block
    sin4(x, out);
    for (int k = 0; k < 4; ++k) mismatches += bits_of(out[k]) != bits_of(sin(x[k]));
    ++blocks;
  }
  std::printf("sin4 against sin: %ld lane mismatches in %ld blocks\n", mismatches, blocks);
  CHECK(mismatches == 0);
}

void check_constants() {
  // p1 + p2 + p3 against pi/2 in long double (64 bits: checks the first two parts and
  // the start of the third), and p1, p2 with at most 33 significant bits.
  const long double half_pi = 1.5707963267948966192313216916397514L;
  const long double sum = static_cast<long double>(raydamp::math::detail::kP1) +
                          static_cast<long double>(raydamp::math::detail::kP2) +
                          static_cast<long double>(raydamp::math::detail::kP3);
  CHECK(std::fabs(static_cast<double>(sum - half_pi)) < 1e-19);
  for (double p : {raydamp::math::detail::kP1, raydamp::math::detail::kP2}) CHECK((bits_of(p) & ((1u << 20) - 1)) == 0);
  CHECK(raydamp::math::detail::taylor(3) == -1.0 / 6.0);
  CHECK(raydamp::math::detail::taylor(4) == 1.0 / 24.0);
}

// The lanes' kernels, p[i] -= t sin(q[i]) and g[i] = sin(q[i]), against the scalar form bit
// for bit: every length from 0 to 40 (blocks of eight, of four, and a scalar tail), each
// with lanes of every path mixed in, for both register widths where the processor has AVX2
// (the width the ensemble picks on this machine is printed).
void check_lane_kernels() {
  using raydamp::math::SineWidth;
  std::mt19937_64 rng(13);
  const double specials[] = {0.0, -0.0, 0.78, -0.7799999, 1e-300, 3.0, -1e3, 1e6, -1e12,
                             std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
  std::uniform_real_distribution<double> small(-0.7, 0.7), wide(-50.0, 50.0), u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 10), kind(0, 9);
  std::vector<SineWidth> widths{SineWidth::two};
  if (raydamp::math::best_sine_width() == SineWidth::four) widths.push_back(SineWidth::four);
  std::printf("lane kernels: best width %d\n", static_cast<int>(raydamp::math::best_sine_width()));
  long mismatches = 0, lanes = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = trial % 41;
    const bool all_small = trial % 3 == 0;  // blocks that take the series alone
    std::vector<double> q(n), p0(n), expect_p(n), expect_g(n);
    const double t = 0.01 * u(rng);
    for (int i = 0; i < n; ++i) {
      const int k = kind(rng);
      q[i] = all_small || k < 4 ? small(rng) : k < 9 ? wide(rng) : specials[pick(rng)];
      p0[i] = u(rng);
      expect_g[i] = sin(q[i]);
      expect_p[i] = p0[i] - t * sin(q[i]);
    }
    for (SineWidth w : widths) {
      std::vector<double> p = p0, g(n);
      raydamp::math::kick_sine_lanes(w, q.data(), p.data(), t, n);
      raydamp::math::sine_lanes(w, q.data(), g.data(), n);
      for (int i = 0; i < n; ++i) {
        mismatches += bits_of(p[i]) != bits_of(expect_p[i]);
        mismatches += bits_of(g[i]) != bits_of(expect_g[i]);
      }
      lanes += n;
    }
  }
  std::printf("lane kernels against sin: %ld mismatches in %ld lanes\n", mismatches, lanes);
  CHECK(mismatches == 0);
  CHECK(lanes >= 50000 * static_cast<long>(widths.size()));
}

}  // namespace

int main() {
  check_constants();
  check_accuracy();
  check_lanes_equal_scalar();
  check_lane_kernels();
  TEST_MAIN_RETURN();
}
