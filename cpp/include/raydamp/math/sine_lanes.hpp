// The ensemble lanes' sines (models/pendulum_lanes.hpp, vector_sine): p[i] -= t sin(q[i]) and
// g[i] = sin(q[i]) over n lanes, with math::sin's arithmetic on every lane (math/sine.hpp), so
// lane i's result is the same bits whatever n, i or the kernel.
//
// Out of line, never inlined into the flattened step loop: inlined there, its code depended on
// the translation unit (64 lanes of 3s: 7.2-7.6 ns per member-step in the module's code, 6.3 in
// a small program with the same headers, at 69 and 68 instructions per member-step: the same
// work with more spills). Out of line, with the kick's p - t s in vectors too, the same code
// everywhere: 63 instructions, 3.8-3.9 ns (two lanes); 34 instructions, 2.4 ns (four). One call
// per kick of a whole run of lanes costs nothing measurable.
//
// Two kernels, chosen at run time: four lanes per AVX2 register where the processor has AVX2
// (the build targets baseline x86-64, so a wheel runs everywhere), else two per SSE2 register
// (NEON on arm64). AVX2 only, not FMA: a fused multiply-add would round a*b+c once where the
// SSE2 kernel rounds twice, and the lanes must not depend on the machine. RAYDAMP_SINE_SIMD
// chooses: 2 = AVX2 when present (the default on x86-64 with GCC or Clang), 1 = two-lane only.
#pragma once

#include "raydamp/math/sine.hpp"

#ifndef RAYDAMP_SINE_SIMD
#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#define RAYDAMP_SINE_SIMD 2
#else
#define RAYDAMP_SINE_SIMD 1
#endif
#endif

#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_SINE_KERNEL inline __attribute__((noinline))
#define RAYDAMP_SINE_KERNEL_AVX2 inline __attribute__((noinline, target("avx2")))
#else
#define RAYDAMP_SINE_KERNEL inline
#endif

namespace raydamp::math {

namespace detail {

// p[i] -= t sin(q[i]) (or, with Kick false, p[i] = sin(q[i])) for i < n: blocks of G vectors V,
// then blocks of four in two-lane vectors, then math::sin one lane at a time.
template <bool Kick, class V, class I, int G>
RAYDAMP_SINE_INLINE void sine_lanes(const double* q, double* p, double t, int n) {
  constexpr int L = static_cast<int>(sizeof(V) / sizeof(double)), B = G * L;
  int i = 0;
  for (; i + B <= n; i += B) {
    V s[G];
    sin_block<V, I, G>(q + i, s);
    for (int g = 0; g < G; ++g) {
      V out = s[g];
      if constexpr (Kick) {
        std::memcpy(&out, p + i + g * L, sizeof out);
        out -= t * s[g];  // p - (t s), as the scalar tail rounds
      }
      std::memcpy(p + i + g * L, &out, sizeof out);
    }
  }
  if constexpr (B > 4) {
    if (i + 4 <= n) {
      sine_lanes<Kick, D2, I2, 2>(q + i, p + i, t, 4);
      i += 4;
    }
  }
  for (; i < n; ++i) {
    if constexpr (Kick) p[i] -= t * sin(q[i]);
    else p[i] = sin(q[i]);
  }
}

template <bool Kick>
RAYDAMP_SINE_KERNEL void sine_lanes_sse2(const double* q, double* p, double t, int n) {
  sine_lanes<Kick, D2, I2, 2>(q, p, t, n);
}

#if RAYDAMP_SINE_SIMD >= 2
using D4 = double __attribute__((vector_size(32)));
using I4 = std::int64_t __attribute__((vector_size(32)));
// Two four-lane registers interleaved, as the SSE2 kernel interleaves two of two.
template <bool Kick>
RAYDAMP_SINE_KERNEL_AVX2 void sine_lanes_avx2(const double* q, double* p, double t, int n) {
  sine_lanes<Kick, D4, I4, 2>(q, p, t, n);
}
#endif

}  // namespace detail

// Vectors of two lanes (SSE2, NEON) or of four (AVX2): the same bits either way.
enum class SineWidth { two = 2, four = 4 };

// Four where this build has the AVX2 kernel and the processor AVX2, else two.
inline SineWidth best_sine_width() {
#if RAYDAMP_SINE_SIMD >= 2
  if (__builtin_cpu_supports("avx2")) return SineWidth::four;
#endif
  return SineWidth::two;
}

// p[i] -= t sin(q[i]), i < n, in vectors of `width` lanes (four only where best_sine_width() is).
inline void kick_sine_lanes(SineWidth width, const double* q, double* p, double t, int n) {
#if RAYDAMP_SINE_SIMD >= 2
  if (width == SineWidth::four) return detail::sine_lanes_avx2<true>(q, p, t, n);
#endif
  (void)width;
  detail::sine_lanes_sse2<true>(q, p, t, n);
}
// g[i] = sin(q[i]), i < n, likewise.
inline void sine_lanes(SineWidth width, const double* q, double* g, int n) {
#if RAYDAMP_SINE_SIMD >= 2
  if (width == SineWidth::four) return detail::sine_lanes_avx2<false>(q, g, 0.0, n);
#endif
  (void)width;
  detail::sine_lanes_sse2<false>(q, g, 0.0, n);
}

}  // namespace raydamp::math
