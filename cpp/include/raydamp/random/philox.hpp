// Counter-based random numbers: Philox-4x32-10 (Salmon, Moraes, Dror and Shaw, "Parallel random
// numbers: as easy as 1, 2, 3", SC 2011), checked against the published known-answer vectors
// (cpp/tests/test_noise.cpp). A draw is a pure function of (key, counter): the thermal noise of
// ensemble member i is keyed by the run's seed and counted from i, so it depends on nothing else
// (not on threads, not on the other members) and a member equals its single run.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

// How refill() computes blocks: 2 = AVX2 when the processor has it (chosen at run time: the build targets
// baseline x86-64), else SSE2; 1 = SSE2; 0 = the portable loop. The same integer arithmetic each, so the
// numbers do not depend on the machine; the tests build all three (cpp/tests/CMakeLists.txt).
#ifndef RAYDAMP_NORMAL_SIMD
#if defined(__GNUC__) && defined(__x86_64__)
#define RAYDAMP_NORMAL_SIMD 2
#elif defined(__SSE2__)
#define RAYDAMP_NORMAL_SIMD 1
#else
#define RAYDAMP_NORMAL_SIMD 0
#endif
#endif
#if RAYDAMP_NORMAL_SIMD >= 1
#include <emmintrin.h>
#endif
#if RAYDAMP_NORMAL_SIMD >= 2
#include <immintrin.h>
#endif

// Overridable only so that benchmarks/bench_normals.cpp can compare buffer sizes (blocks) and chunks
// (SSE2 registers of two blocks taken through the ten rounds together: 4 keeps the state in 16 registers).
#ifndef RAYDAMP_NORMAL_BUFFER
#define RAYDAMP_NORMAL_BUFFER 16
#endif
#ifndef RAYDAMP_NORMAL_CHUNK
#define RAYDAMP_NORMAL_CHUNK 4
#endif

// The fast path marks a word outside its layer's core by NaN (NormalStream::fast_value), which
// -ffinite-math-only would let the compiler assume away: the slow path would never run.
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__
#error "raydamp/random/philox.hpp needs NaN: build without -ffast-math / -ffinite-math-only"
#endif

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
//
// The blocks are consumed strictly in counter order, one at a time, so they are computed ahead: kBuffered
// consecutive counters at once (refill), several blocks per SIMD register. A buffered block is a pure
// function of its counter, so the buffer is only a cache: take() reads a block from it when its counter lies
// in the buffered range and computes the range anew otherwise (after a restore() elsewhere, say). The
// numbers are bit for bit those of computing each block when it is consumed; cpp/tests/test_normal_buffer.cpp
// compares them with that stream (reference_normal_stream.hpp) over fill, next, restore and copies.
class NormalStream {
 public:
  // 16 blocks: 256 bytes of cache, in a stream that the step loop's workspace holds per run and per lane.
  // benchmarks/bench_normals.cpp (fill of 10^4, ns per normal, unbuffered 8.9): AVX2 3.9 (4.4 before fill ran
  // whole runs of blocks), SSE2 5.5-5.9,
  // the portable loop 10.1 (no gain: GCC does not vectorize it); 8 and 32 blocks within the noise of 16.
  static constexpr int kBuffered = RAYDAMP_NORMAL_BUFFER;
  static_assert(kBuffered % (2 * RAYDAMP_NORMAL_CHUNK) == 0, "whole chunks of SSE2 registers of blocks");

  struct State {
    std::uint64_t block = 0;  // the next block to consume
    bool spare = false;       // the second normal of the last block, not yet returned
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
    const std::uint64_t b = take();
    const Ziggurat& z = Ziggurat::tables();
    double first = fast_value(high_[b], z), second = fast_value(low_[b], z);
    if (first != first || second != second) outside_cores(b, first, second);
    state_.value = second;
    state_.spare = true;
    return first;
  }

  // out[i] <- the next out.size() normals, the same numbers as that many next() calls: a run of buffered
  // blocks at a time on the fast path, with the stream's state in registers (9% fewer ns per normal).
  template <class V>
  void fill(V& out) {
    using Index = decltype(out.size());
    const Index n = out.size();
    Index i = 0;
    if (n > 0 && state_.spare) {
      state_.spare = false;
      out[i++] = state_.value;
    }
    while (i + 1 < n) {
      std::uint64_t at = state_.block - base_;
      if (at >= filled_) {
        refill(state_.block);
        at = 0;
      }
      const std::uint64_t pairs = std::uint64_t((n - i) / 2);
      const std::uint64_t end = filled_ - at < pairs ? filled_ : at + pairs;
      const Ziggurat& z = Ziggurat::tables();
      for (; at < end; ++at, i += 2) {
        const double first = fast_value(high_[at], z), second = fast_value(low_[at], z);
        if (first != first || second != second) break;
        out[i] = first;
        out[i + 1] = second;
      }
      state_.block = base_ + at;
      if (at < end) {  // a word outside its layer's core: the slow path, which takes further blocks
        const std::uint64_t b = take();
        const Ziggurat& z = Ziggurat::tables();
        double first = fast_value(high_[b], z), second = fast_value(low_[b], z);
        outside_cores(b, first, second);
        out[i] = first;
        out[i + 1] = second;
        i += 2;
      }
    }
    if (i < n) out[i] = next();
  }

  const State& state() const { return state_; }
  // The buffer stays: it holds blocks by counter, and take() reads it only inside its range.
  void restore(const State& s) { state_ = s; }

 private:
  static constexpr double kUnit = 1.0 / 9007199254740992.0;  // 2^-53
  static constexpr double kNotFast = __builtin_nan("");      // a word outside its layer's core

  // The index in the buffer of block state_.block (computed now if outside the buffered range), and
  // the counter moves on. Unsigned differences: a counter before base_ is far outside, and the counter
  // wraps at 2^64 as a single block's would.
  std::uint64_t take() {
    const std::uint64_t b = state_.block++;
    std::uint64_t at = b - base_;
    if (at >= filled_) {
      refill(b);
      at = 0;
    }
    return at;
  }

  // Blocks base .. base + kBuffered - 1, each philox4x32_10 of its counter. With SSE2 (every x86-64) two
  // blocks per register: each word of a block in the low half of a 64-bit lane, which is all pmuludq reads,
  // so its product is the 64-bit p of the scalar round, p >> 32 its high word, and p itself serves as the
  // low word (the high halves carry junk that no later product reads and the output masks off). GCC 12
  // does not vectorize the plain loop (it unrolls the blocks first), hence intrinsics; the portable loop
  // below and refill_avx2 are the same arithmetic.
  void refill(std::uint64_t base) {
    constexpr std::uint32_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u, W0 = 0x9E3779B9u, W1 = 0xBB67AE85u;
#if RAYDAMP_NORMAL_SIMD >= 2
    static const bool avx2 = __builtin_cpu_supports("avx2");
    if (avx2) {
      refill_avx2(base);
      base_ = base;
      filled_ = kBuffered;
      return;
    }
#endif
#if RAYDAMP_NORMAL_SIMD >= 1
    constexpr int kChunk = RAYDAMP_NORMAL_CHUNK;  // registers (of two blocks) through the ten rounds at a time
    const __m128i m0 = _mm_set1_epi32(int(M0)), m1 = _mm_set1_epi32(int(M1));
    const __m128i low = _mm_set_epi32(0, -1, 0, -1);
    const __m128i s2 = _mm_set1_epi32(int(std::uint32_t(stream_))), s3 = _mm_set1_epi32(int(std::uint32_t(stream_ >> 32)));
    for (int j0 = 0; j0 < kBuffered; j0 += 2 * kChunk) {
      __m128i c0[kChunk], c1[kChunk], c2[kChunk], c3[kChunk];
      for (int g = 0; g < kChunk; ++g) {
        const std::uint64_t b0 = base + std::uint64_t(j0 + 2 * g), b1 = b0 + 1;
        const __m128i b = _mm_set_epi64x(static_cast<long long>(b1), static_cast<long long>(b0));
        c0[g] = b;
        c1[g] = _mm_srli_epi64(b, 32);
        c2[g] = s2;
        c3[g] = s3;
      }
      std::uint32_t k0 = key_[0], k1 = key_[1];
      for (int round = 0; round < 10; ++round) {
        if (round > 0) {
          k0 += W0;
          k1 += W1;
        }
        const __m128i key0 = _mm_set1_epi32(int(k0)), key1 = _mm_set1_epi32(int(k1));
        for (int g = 0; g < kChunk; ++g) {
          const __m128i p0 = _mm_mul_epu32(c0[g], m0), p1 = _mm_mul_epu32(c2[g], m1);
          c0[g] = _mm_xor_si128(_mm_xor_si128(_mm_srli_epi64(p1, 32), c1[g]), key0);
          c1[g] = p1;
          c2[g] = _mm_xor_si128(_mm_xor_si128(_mm_srli_epi64(p0, 32), c3[g]), key1);
          c3[g] = p0;
        }
      }
      for (int g = 0; g < kChunk; ++g) {  // word = c0 << 32 | c1 (low halves)
        _mm_storeu_si128(reinterpret_cast<__m128i*>(&high_[j0 + 2 * g]),
                         _mm_or_si128(_mm_slli_epi64(c0[g], 32), _mm_and_si128(c1[g], low)));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(&low_[j0 + 2 * g]),
                         _mm_or_si128(_mm_slli_epi64(c2[g], 32), _mm_and_si128(c3[g], low)));
      }
    }
#else
    std::uint32_t c0[kBuffered], c1[kBuffered], c2[kBuffered], c3[kBuffered];
    for (int j = 0; j < kBuffered; ++j) {
      const std::uint64_t b = base + std::uint64_t(j);
      c0[j] = std::uint32_t(b);
      c1[j] = std::uint32_t(b >> 32);
      c2[j] = std::uint32_t(stream_);
      c3[j] = std::uint32_t(stream_ >> 32);
    }
    std::uint32_t k0 = key_[0], k1 = key_[1];
    for (int round = 0; round < 10; ++round) {
      if (round > 0) {
        k0 += W0;
        k1 += W1;
      }
      for (int j = 0; j < kBuffered; ++j) {
        const std::uint64_t p0 = std::uint64_t(M0) * c0[j], p1 = std::uint64_t(M1) * c2[j];
        const std::uint32_t hi0 = std::uint32_t(p0 >> 32), lo0 = std::uint32_t(p0);
        const std::uint32_t hi1 = std::uint32_t(p1 >> 32), lo1 = std::uint32_t(p1);
        c0[j] = hi1 ^ c1[j] ^ k0;
        c1[j] = lo1;
        c2[j] = hi0 ^ c3[j] ^ k1;
        c3[j] = lo0;
      }
    }
    for (int j = 0; j < kBuffered; ++j) {
      high_[j] = std::uint64_t(c0[j]) << 32 | c1[j];
      low_[j] = std::uint64_t(c2[j]) << 32 | c3[j];
    }
#endif
    base_ = base;
    filled_ = kBuffered;
  }

#if RAYDAMP_NORMAL_SIMD >= 2
  // refill's SSE2 loop with four blocks (64-bit lanes) per 256-bit register.
  __attribute__((target("avx2"), noinline)) void refill_avx2(std::uint64_t base) {
    constexpr std::uint32_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u, W0 = 0x9E3779B9u, W1 = 0xBB67AE85u;
    constexpr int kChunk = RAYDAMP_NORMAL_CHUNK;
    const __m256i m0 = _mm256_set1_epi32(int(M0)), m1 = _mm256_set1_epi32(int(M1));
    const __m256i low = _mm256_set1_epi64x(0xffffffffll);
    const __m256i s2 = _mm256_set1_epi32(int(std::uint32_t(stream_))), s3 = _mm256_set1_epi32(int(std::uint32_t(stream_ >> 32)));
    for (int j0 = 0; j0 < kBuffered; j0 += 4 * kChunk) {
      __m256i c0[kChunk], c1[kChunk], c2[kChunk], c3[kChunk];
      const int chunk = kBuffered - j0 < 4 * kChunk ? (kBuffered - j0) / 4 : kChunk;
      for (int g = 0; g < chunk; ++g) {
        const std::uint64_t b0 = base + std::uint64_t(j0 + 4 * g);
        const __m256i b = _mm256_set_epi64x(static_cast<long long>(b0 + 3), static_cast<long long>(b0 + 2),
                                            static_cast<long long>(b0 + 1), static_cast<long long>(b0));
        c0[g] = b;
        c1[g] = _mm256_srli_epi64(b, 32);
        c2[g] = s2;
        c3[g] = s3;
      }
      std::uint32_t k0 = key_[0], k1 = key_[1];
      // Unrolled: the keys become immediates and no registers rotate (2.4 against 3.0 ns per block,
      // bench_normals at nice -20).
#pragma GCC unroll 10
      for (int round = 0; round < 10; ++round) {
        if (round > 0) {
          k0 += W0;
          k1 += W1;
        }
        const __m256i key0 = _mm256_set1_epi32(int(k0)), key1 = _mm256_set1_epi32(int(k1));
        for (int g = 0; g < chunk; ++g) {
          const __m256i p0 = _mm256_mul_epu32(c0[g], m0), p1 = _mm256_mul_epu32(c2[g], m1);
          c0[g] = _mm256_xor_si256(_mm256_xor_si256(_mm256_srli_epi64(p1, 32), c1[g]), key0);
          c1[g] = p1;
          c2[g] = _mm256_xor_si256(_mm256_xor_si256(_mm256_srli_epi64(p0, 32), c3[g]), key1);
          c3[g] = p0;
        }
      }
      for (int g = 0; g < chunk; ++g) {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(&high_[j0 + 4 * g]),
                            _mm256_or_si256(_mm256_slli_epi64(c0[g], 32), _mm256_and_si256(c1[g], low)));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(&low_[j0 + 4 * g]),
                            _mm256_or_si256(_mm256_slli_epi64(c2[g], 32), _mm256_and_si256(c3[g], low)));
      }
    }
  }
#endif

  // The first word of the next block (its second word unused).
  std::uint64_t word() { return high_[take()]; }
  // A uniform in (0, 1].
  double uniform() { return (double(word() >> 11) + 1.0) * kUnit; }

  // The ziggurat's fast path: a word's uniform u in (-1, 1) (never 0 or +-1) and layer i; the normal is
  // u x[i] when u lies inside the layer's core rectangle (~99% of words), else NaN (the slow path's).
  static double fast_value(std::uint64_t w, const Ziggurat& z) {
    const double u = uniform_of(w);
    const int i = int(w & 127u);
    return std::abs(u) < z.ratio[i] ? u * z.x[i] : kNotFast;
  }
  static double uniform_of(std::uint64_t w) { return (double(w >> 11) + 0.5) * (2.0 * kUnit) - 1.0; }

  // Block b's two normals where either word is outside its core. The words are read before the first
  // slow path, which takes the blocks after b (and may refill the buffer); the first word before the
  // second, as the blocks are consumed in order.
  void outside_cores(std::uint64_t b, double& first, double& second) {
    const std::uint64_t w0 = high_[b], w1 = low_[b];
    if (first != first) first = outside_core(uniform_of(w0), int(w0 & 127u));
    if (second != second) second = outside_core(uniform_of(w1), int(w1 & 127u));
  }

#if defined(__GNUC__)
  __attribute__((noinline))
#endif
  double outside_core(double u, int i) {
    const Ziggurat& z = Ziggurat::tables();
    for (;;) {
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
      const std::uint64_t w = word();  // rejected: a fresh word from the next block, as fast_value() reads it
      u = uniform_of(w);
      i = int(w & 127u);
      if (std::abs(u) < z.ratio[i]) return u * z.x[i];
    }
  }

  PhiloxKey key_{0, 0};
  std::uint64_t stream_ = 0;
  State state_;
  // Blocks base_ .. base_ + filled_ - 1 as their two words (0 blocks until the first draw).
  std::uint64_t base_ = 0, filled_ = 0;
  std::array<std::uint64_t, kBuffered> high_{}, low_{};
};

}  // namespace raydamp
