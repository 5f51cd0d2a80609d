// The Kepler drift in SIMD lanes (flows/kepler_lanes.hpp) gives each body the bits of the scalar drift:
// blocks of two (SSE2) and four (AVX2, where the processor has it) against drift_body one at a time, on
// bodies whose steps take every path (short with each Horner length, a block refused by one long step,
// a Stumpff argument past 0.1, a tail shorter than a block), in 2 and 3 dimensions.
#include <cstring>
#include <random>
#include <vector>

#include "check.hpp"
#include "raydamp/flows/kepler_lanes.hpp"

using namespace raydamp;

namespace {

struct Bodies {
  std::vector<double> mu, m, inverse, q, p;
};

// n bodies of d coordinates; radii and speeds spread so that a step of t reaches each Stumpff range.
Bodies bodies(int n, int d, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), radius(0.3, 3.0), ecc(0.0, 0.95);
  Bodies b;
  for (int i = 0; i < n; ++i) {
    b.mu.push_back(0.5 + 0.5 * (unit(rng) + 1.0));
    const double mass = 0.2 + (unit(rng) + 1.0);
    const double r = radius(rng), speed = std::sqrt(b.mu.back() * (1.0 + ecc(rng)) / r);
    double dir[3] = {unit(rng), unit(rng), d == 3 ? unit(rng) : 0.0};
    const double norm = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int c = 0; c < d; ++c) {
      b.m.push_back(mass);
      b.inverse.push_back(1.0 / mass);
      b.q.push_back(r * dir[c] / norm);
    }
    // velocity across the radius, tilted a little inward or outward
    const double tilt = 0.3 * unit(rng);
    b.p.push_back(mass * speed * (-dir[1] / norm + tilt * dir[0] / norm));
    b.p.push_back(mass * speed * (dir[0] / norm + tilt * dir[1] / norm));
    if (d == 3) b.p.push_back(mass * speed * 0.2 * unit(rng));
  }
  return b;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

int main() {
  std::mt19937_64 rng(41);
  for (int d : {2, 3}) {
    for (double t : {1e-4, 2e-3, 5e-3, 1e-2, 2e-2, 3e-2, 0.5, -1e-2}) {
      const int n = 401;  // blocks of four or two, and a tail of one
      const Bodies start = bodies(n, d, rng);
      Bodies one = start;
      for (int b = 0; b < n; ++b)
        kepler::drift_body(one.mu[b], one.m[d * b], one.inverse[d * b], t, d, &one.q[d * b], &one.p[d * b]);
      Bodies lanes = start;
      kepler::drift_bodies(lanes.mu.data(), lanes.m.data(), lanes.inverse.data(), t, d, n, lanes.q.data(),
                           lanes.p.data());
      CHECK(same_bits(lanes.q, one.q) && same_bits(lanes.p, one.p));
#if RAYDAMP_KEPLER_LANES
      Bodies two = start;
      auto sse2 = d == 2 ? kepler::detail::drift_sse2<2> : kepler::detail::drift_sse2<3>;
      sse2(two.mu.data(), two.m.data(), two.inverse.data(), t, n, two.q.data(), two.p.data());
      CHECK(same_bits(two.q, one.q) && same_bits(two.p, one.p));
      if (__builtin_cpu_supports("avx2")) {
        Bodies four = start;
        auto avx2 = d == 2 ? kepler::detail::drift_avx2<2> : kepler::detail::drift_avx2<3>;
        avx2(four.mu.data(), four.m.data(), four.inverse.data(), t, n, four.q.data(), four.p.data());
        CHECK(same_bits(four.q, one.q) && same_bits(four.p, one.p));
      }
#endif
    }
  }
#if RAYDAMP_KEPLER_LANES
  // The paths are taken: a block of short steps drifts in lanes, and one long step refuses its block.
  {
    std::mt19937_64 again(7);
    Bodies b = bodies(2, 2, again);
    using D2 = kepler::detail::D2;
    CHECK((kepler::detail::short_block<D2, 2>(b.mu.data(), b.m.data(), b.inverse.data(), 1e-3, b.q.data(),
                                             b.p.data())));
    const std::vector<double> q = b.q;
    CHECK(!(kepler::detail::short_block<D2, 2>(b.mu.data(), b.m.data(), b.inverse.data(), 0.5, b.q.data(),
                                              b.p.data())));
    CHECK(same_bits(b.q, q));
  }
#endif
  return test::failures == 0 ? 0 : 1;
}
