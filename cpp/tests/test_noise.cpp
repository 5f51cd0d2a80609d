// Thermal noise: Philox-4x32-10 against the published known-answer vectors (Salmon et al. 2011,
// Random123's kat_vectors), the normal stream's moments, and one exact OU damping flow's noise
// (isotropic damping, unit mass: p1 = e^{-at} p0 + sqrt(kT (1 - e^{-2at})) xi) drawn from the stream;
// the ziggurat's normals against the normal distribution function (Kolmogorov-Smirnov, tails).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

int main() {
  struct Kat { Philox4x32 ctr; PhiloxKey key; Philox4x32 out; };
  const Kat kats[] = {
      {{0, 0, 0, 0}, {0, 0}, {0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}},
      {{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, {0xffffffffu, 0xffffffffu},
       {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}},
      {{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, {0xa4093822u, 0x299f31d0u},
       {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}},
  };
  for (const Kat& k : kats) CHECK(philox4x32_10(k.ctr, k.key) == k.out);

  // 10^6 normals: mean 0, variance 1, fourth moment 3 within 5 standard errors; another stream differs.
  NormalStream a(12345, 0), b(12345, 1);
  const int N = 1000000;
  double s1 = 0, s2 = 0, s4 = 0, cross = 0;
  for (int i = 0; i < N; ++i) {
    const double x = a.next(), y = b.next();
    s1 += x;
    s2 += x * x;
    s4 += x * x * x * x;
    cross += x * y;
  }
  CHECK_NEAR(s1 / N, 0.0, 5.0 / std::sqrt(N));
  CHECK_NEAR(s2 / N, 1.0, 5.0 * std::sqrt(2.0 / N));
  CHECK_NEAR(s4 / N, 3.0, 5.0 * std::sqrt(96.0 / N));
  CHECK_NEAR(cross / N, 0.0, 5.0 / std::sqrt(N));
  // Kolmogorov-Smirnov against the normal distribution: the largest gap of the empirical CDF of 10^6 draws
  // below 1.95 / sqrt(N) (the 0.1% level), and the tails beyond 3 and 4 (ziggurat's base layer) as often as
  // they should be, within 5 standard errors.
  {
    NormalStream s(2025, 7);
    std::vector<double> x(N);
    for (double& v : x) v = s.next();
    std::sort(x.begin(), x.end());
    double gap = 0.0;
    for (int i = 0; i < N; ++i) {
      const double cdf = 0.5 * std::erfc(-x[i] / std::sqrt(2.0));
      gap = std::max({gap, std::abs(cdf - double(i) / N), std::abs(cdf - double(i + 1) / N)});
    }
    CHECK(gap < 1.95 / std::sqrt(double(N)));
    for (const double cut : {3.0, 4.0}) {
      const double p = std::erfc(cut / std::sqrt(2.0));  // P(|X| > cut)
      const double seen = double(std::count_if(x.begin(), x.end(), [&](double v) { return std::abs(v) > cut; })) / N;
      CHECK_NEAR(seen, p, 5.0 * std::sqrt(p * (1 - p) / N));
    }
  }
  // restoring a state replays the same numbers
  NormalStream c(7, 3);
  c.next();
  const NormalStream::State saved = c.state();
  const double first = c.next(), second = c.next();
  c.restore(saved);
  CHECK(c.next() == first && c.next() == second);

  // One damping flow of the damped pendulum (unit mass, A = eps I) at kT = 0.3 from the stream.
  const DampedPendulum model(0.5);
  WorkspaceFor<DampedPendulum> ws(1, 1);
  ws.sigma = std::sqrt(0.3);
  ws.noise = NormalStream(99, 0);
  State<1> z{Vector<1>(0.2), Vector<1>(1.5)};
  flows::damp(model, z, 0.4, ws);
  NormalStream same(99, 0);
  const double xi = same.next();
  CHECK_NEAR(z.p[0], std::exp(-0.2) * 1.5 + std::sqrt(0.3 * (1.0 - std::exp(-0.4))) * xi, 1e-15);
  CHECK(z.q[0] == 0.2);

  if (test::failures) std::printf("%d check(s) failed\n", test::failures);
  return test::failures ? 1 : 0;
}
