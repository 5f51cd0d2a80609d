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

// Standard normal numbers from one stream: key = the 64-bit seed, counter = (draw block: 64 bits,
// stream: 64 bits). Each Philox block gives two 53-bit uniforms, u1 in (0, 1] and u2 in [0, 1),
// and so two normals by Box and Muller's transform. The state is three numbers, so the step loop
// can take it back when it replays a blown-up block of steps.
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
    const std::uint64_t b = state_.block++;
    const Philox4x32 r = philox4x32_10({std::uint32_t(b), std::uint32_t(b >> 32), std::uint32_t(stream_),
                                        std::uint32_t(stream_ >> 32)}, key_);
    constexpr double kUnit = 1.0 / 9007199254740992.0;  // 2^-53
    const std::uint64_t x = (std::uint64_t(r[0]) << 32 | r[1]) >> 11, y = (std::uint64_t(r[2]) << 32 | r[3]) >> 11;
    const double u1 = (double(x) + 1.0) * kUnit, u2 = double(y) * kUnit;
    const double radius = std::sqrt(-2.0 * std::log(u1)), angle = 6.283185307179586 * u2;
    state_.spare = true;
    state_.value = radius * std::sin(angle);
    return radius * std::cos(angle);
  }

  template <class V>
  void fill(V& out) {
    for (decltype(out.size()) i = 0; i < out.size(); ++i) out[i] = next();
  }

  const State& state() const { return state_; }
  void restore(const State& s) { state_ = s; }

 private:
  PhiloxKey key_{0, 0};
  std::uint64_t stream_ = 0;
  State state_;
};

}  // namespace raydamp
