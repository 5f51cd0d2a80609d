// The normal stream as it was before its blocks were buffered (raydamp/random/philox.hpp): each Philox block
// computed with philox4x32_10 when it is consumed, one next() at a time. test_noise.cpp and
// benchmarks/bench_normals.cpp hold the buffered stream to it bit for bit and time it against it.
#pragma once

#include "raydamp/random/philox.hpp"

namespace raydamp {

class ReferenceNormalStream {
 public:
  using State = NormalStream::State;

  ReferenceNormalStream() = default;
  ReferenceNormalStream(std::uint64_t seed, std::uint64_t stream)
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
