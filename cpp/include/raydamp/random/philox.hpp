// Counter-based random numbers: Philox-4x32-10 (Salmon, Moraes, Dror and Shaw, "Parallel random
// numbers: as easy as 1, 2, 3", SC 2011), checked against the published known-answer vectors
// (cpp/tests/test_noise.cpp). A draw is a pure function of (key, counter): the thermal noise of
// ensemble member i is keyed by the run's seed and counted from i, so it depends on nothing else
// (not on threads, not on the other members) and a member equals its single run.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace raydamp {

using Philox4x32 = std::array<std::uint32_t, 4>;
using PhiloxKey = std::array<std::uint32_t, 2>;

// The 10-round bijection of the counter under the key (the key bumped before rounds 2..10).
inline Philox4x32 philox4x32_10(Philox4x32 c, PhiloxKey k) {
  constexpr std::uint32_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u, W0 = 0x9E3779B9u, W1 = 0xBB67AE85u;
  for (int round = 0; round < 10; ++round) {
    if (round > 0) {
      k[0] += W0;
      k[1] += W1;
    }
    const std::uint64_t p0 = std::uint64_t(M0) * c[0], p1 = std::uint64_t(M1) * c[2];
    const std::uint32_t hi0 = std::uint32_t(p0 >> 32), lo0 = std::uint32_t(p0);
    const std::uint32_t hi1 = std::uint32_t(p1 >> 32), lo1 = std::uint32_t(p1);
    c = {hi1 ^ c[1] ^ k[0], lo1, hi0 ^ c[3] ^ k[1], lo0};
  }
  return c;
}

// The ziggurat of the standard normal density f(x) = exp(-x^2/2) in 128 layers of equal area v (Marsaglia
// and Tsang 2000, with Doornik's 2005 improvement: the layer index and the position come from separate
// bits). x[0] = v / f(r) is the base layer's width (its rectangle plus the tail beyond r), x[1] = r,
// x[128] = 0; ratio[i] = x[i + 1] / x[i] is the part of layer i inside the density for every position.
struct Ziggurat {
  static constexpr int kLayers = 128;
  static constexpr double kR = 3.442619855899, kV = 9.91256303526217e-3;
  std::array<double, kLayers + 1> x{};
  std::array<double, kLayers> ratio{};

  Ziggurat() {
    double f = std::exp(-0.5 * kR * kR);
    x[0] = kV / f;
    x[1] = kR;
    x[kLayers] = 0.0;
    for (int i = 2; i < kLayers; ++i) {
      x[i] = std::sqrt(-2.0 * std::log(kV / x[i - 1] + f));
      f = std::exp(-0.5 * x[i] * x[i]);
    }
    for (int i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
  }

  static const Ziggurat& tables() {
    static const Ziggurat z;
    return z;
  }
};

// Standard normal numbers from one stream: key = the 64-bit seed, counter = (draw block: 64 bits,
// stream: 64 bits). Each Philox block is two 64-bit words; a word gives a uniform u in (-1, 1) from its
// top 53 bits and a layer of the ziggurat from 7 of the rest, so a block is two normal numbers on the
// fast path (about 99% of draws); the rest take further blocks. The state is three numbers, so the
// step loop can take it back when it replays a blown-up block of steps.
class NormalStream {
 public:
  struct State {
    std::uint64_t block = 0;
    bool spare = false;
    double value = 0.0;
  };

  NormalStream() = default;
  NormalStream(std::uint64_t seed, std::uint64_t stream)
      : key_{std::uint32_t(seed), std::uint32_t(seed >> 32)}, stream_(stream) {}

  double next() {
    if (state_.spare) {
      state_.spare = false;
      return state_.value;
    }
    const Philox4x32 r = draw();
    const double first = normal(std::uint64_t(r[0]) << 32 | r[1]);
    state_.value = normal(std::uint64_t(r[2]) << 32 | r[3]);
    state_.spare = true;
    return first;
  }

  template <class V>
  void fill(V& out) {
    for (decltype(out.size()) i = 0; i < out.size(); ++i) out[i] = next();
  }

  const State& state() const { return state_; }
  void restore(const State& s) { state_ = s; }

 private:
  static constexpr double kUnit = 1.0 / 9007199254740992.0;  // 2^-53

  Philox4x32 draw() {
    const std::uint64_t b = state_.block++;
    return philox4x32_10({std::uint32_t(b), std::uint32_t(b >> 32), std::uint32_t(stream_), std::uint32_t(stream_ >> 32)},
                         key_);
  }
  std::uint64_t word() {
    const Philox4x32 r = draw();
    return std::uint64_t(r[0]) << 32 | r[1];
  }
  // A uniform in (0, 1].
  double uniform() { return (double(word() >> 11) + 1.0) * kUnit; }

  double normal(std::uint64_t w) {
    const Ziggurat& z = Ziggurat::tables();
    for (;;) {
      const double u = (double(w >> 11) + 0.5) * (2.0 * kUnit) - 1.0;  // (-1, 1), never 0 or +-1
      const int i = int(w & 127u);
      if (std::abs(u) < z.ratio[i]) return u * z.x[i];  // inside the layer's core rectangle
      if (i == 0) {  // the base layer beyond its rectangle: the tail |x| > r (Marsaglia's method)
        double t, y;
        do {
          t = std::log(uniform()) / Ziggurat::kR;
          y = std::log(uniform());
        } while (-2.0 * y < t * t);
        return u < 0.0 ? t - Ziggurat::kR : Ziggurat::kR - t;
      }
      const double x = u * z.x[i];  // in the wedge between the density and the layer's core
      const double f0 = std::exp(-0.5 * (z.x[i] * z.x[i] - x * x)), f1 = std::exp(-0.5 * (z.x[i + 1] * z.x[i + 1] - x * x));
      if (f1 + uniform() * (f0 - f1) < 1.0) return x;
      w = word();
    }
  }

  PhiloxKey key_{0, 0};
  std::uint64_t stream_ = 0;
  State state_;
};

}  // namespace raydamp
