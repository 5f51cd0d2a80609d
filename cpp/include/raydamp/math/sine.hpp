// sin(x) written once for one number and for blocks of vectors (sin_block; sin4 for
// four numbers), with the same operations in the same order on every lane, so
// sin4(x)[k] == sin(x[k]) bit for bit. The damped pendulum's ensemble lanes use it
// when asked for vector_sine (models/pendulum_lanes.hpp, through math/sine_lanes.hpp):
// their sines then run as SIMD, and a member's result does not depend on which lane,
// block or register width it ran in. Everything else keeps libm's
// sin: this one differs from it in the last bit for about 3% of arguments, and a
// System compiles sin to libm's, so the single pendulum, and ensembles by default,
// stay equal to them bit for bit. It is also slower than glibc's for one number
// near 0 (glibc returns x at once below 2^-26).
//
// Method: sin is odd, so work on a = |x| and give the result x's sign. Reduce
// a = n pi/2 + r, |r| <= pi/4, Cody-Waite style: pi/2 = p1 + p2 + p3 with p1 and p2
// of 33 significant bits, so n p1 and n p2 are exact for n < 2^20 and r comes out
// as r + lo (double-double) to first order. Then sin r and cos r by their Taylor
// series to r^17 and r^18 (the first omitted terms are below 1e-19 relative on
// |r| <= pi/4), evaluated in Estrin's order (shorter dependency chains than Horner:
// the single pendulum's step waits on this sine), and the quadrant n mod 4 picks
// +-sin r or +-cos r by bit masks, with no branch on a lane.
// - |x| < kSmall: n = 0, lo = +0, and the quadrant step is the identity, so sin is
//   sin_series(a) with x's sign; the scalar form then skips the reduction (a
//   shorter chain), and a block takes that path only when all its lanes would (the
//   result is the same bits either way).
// - |x| >= kLarge (or infinite): n p1 would stop being exact; libm's sin, lane by
//   lane, in both forms.
// Accuracy (cpp/tests/test_sine.cpp, against long double sinl): within 1 ulp, where
// libm is within about 0.52.
// Vector types are GCC/Clang vector extensions: SSE2 registers on baseline x86-64
// (AVX2 in sine_lanes.hpp's kernel, chosen at run time), NEON on arm64; other
// compilers would need a port of the block form.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

// Forced inline, so that a caller compiled for wider registers (math/sine_lanes.hpp's AVX2
// kernel) gets this code in its own instructions and no vector is passed by value across
// a call (a 32-byte vector's ABI differs with and without AVX).
#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_SINE_INLINE inline __attribute__((always_inline))
#else
#define RAYDAMP_SINE_INLINE inline
#endif

namespace raydamp::math {

namespace detail {

// Two lanes: an SSE2 register on baseline x86-64, a NEON one on arm64. (Four-lane
// vectors only inside math/sine_lanes.hpp's AVX2 kernel, which inlines all of this.)
using D2 = double __attribute__((vector_size(16)));
using I2 = std::int64_t __attribute__((vector_size(16)));

constexpr double factorial(int k) {
  double f = 1.0;  // exact as a double for k <= 22
  for (int i = 2; i <= k; ++i) f *= i;
  return f;
}
// The coefficient of x^k in the Taylor series of sin (k odd) or cos (k even).
constexpr double taylor(int k) { return ((k / 2) % 2 == 0 ? 1.0 : -1.0) / factorial(k); }

// pi/2 = p1 + p2 + p3 to 119 bits (cpp/tests/test_sine.cpp checks the sum); 2/pi rounded.
constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;
constexpr double kP1 = 0x1.921fb544p+0, kP2 = 0x1.0b4611a6p-34, kP3 = 0x1.3198a2e037073p-69;
constexpr double kRound = 0x1.8p52;  // (y + kRound) - kRound rounds y to an integer, |y| < 2^51

template <class To, class From>
RAYDAMP_SINE_INLINE To bits(const From& from) {
  static_assert(sizeof(To) == sizeof(From));
  To to;
  std::memcpy(&to, &from, sizeof to);
  return to;
}

// sum_k taylor(2k+3) z^k, k = 0..7 (so sin r = r + r z S(z)), and
// sum_k taylor(2k+4) z^k, k = 0..7 (so cos r = 1 - z/2 + z^2 C(z)), in Estrin's order.
template <class V>
RAYDAMP_SINE_INLINE V sin_tail(V z, V z2, V z4) {
  const V a = taylor(3) + taylor(5) * z, b = taylor(7) + taylor(9) * z;
  const V c = taylor(11) + taylor(13) * z, d = taylor(15) + taylor(17) * z;
  return (a + z2 * b) + z4 * (c + z2 * d);
}
template <class V>
RAYDAMP_SINE_INLINE V cos_tail(V z, V z2, V z4) {
  const V a = taylor(4) + taylor(6) * z, b = taylor(8) + taylor(10) * z;
  const V c = taylor(12) + taylor(14) * z, d = taylor(16) + taylor(18) * z;
  return (a + z2 * b) + z4 * (c + z2 * d);
}

// sin a, a = |x| < kSmall. The reduced form adds lo (1 - z/2) with lo = +0 to the
// same a z S(z): no change, even to the sign of a zero, since a >= +0.
template <class V>
RAYDAMP_SINE_INLINE V sin_series(V a) {
  const V z = a * a, z2 = z * z, z4 = z2 * z2;
  return a + (a * z) * sin_tail(z, z2, z4);
}

// sin a for a = |x| >= 0, any lane below kLarge: reduction, both series, quadrant.
template <class V, class I>
RAYDAMP_SINE_INLINE V sin_reduced(V a) {
  const V shifted = a * kTwoOverPi + kRound;
  const V n = shifted - kRound;
  const V r1 = a - n * kP1;  // exact
  const V w2 = n * kP2, t = r1 - w2;
  const V w3 = n * kP3, r = t - w3;
  const V lo = ((r1 - t) - w2) + ((t - r) - w3);  // what r lost to rounding
  const V z = r * r, z2 = z * z, z4 = z2 * z2;
  const V hz = 0.5 * z, one_minus_hz = 1.0 - hz;
  // sin(r + lo) = sin r + lo cos r, cos(r + lo) = cos r - lo sin r, to first order in lo.
  const V sin_r = r + ((r * z) * sin_tail(z, z2, z4) + lo * one_minus_hz);
  // 1 - z/2 with its rounding error carried (fdlibm's device) keeps cos within an ulp.
  const V cos_r = one_minus_hz + (((1.0 - one_minus_hz) - hz) + (z2 * cos_tail(z, z2, z4) - r * lo));
  const I quadrant = bits<I>(shifted);  // n in the low bits of the mantissa
  const I odd = -(quadrant & 1);        // all ones where n is odd: cos r
  const I picked = (bits<I>(cos_r) & odd) | (bits<I>(sin_r) & ~odd);
  return bits<V>(picked ^ ((quadrant & 2) << 62));  // n = 2, 3 mod 4: minus
}

}  // namespace detail

inline constexpr double kSmall = 0.78;       // below pi/4: n = 0
inline constexpr double kLarge = 524288.0;  // 2^19: n < 2^20 keeps n p1 and n p2 exact

// sin x, as sin4 computes it on each lane. In a vector register throughout (lane 0),
// so taking the sign off and putting it back are one instruction each, not trips
// through an integer register: the single pendulum's step waits on this latency.
inline double sin(double x) {
  using detail::D2;
  using detail::I2;
  using detail::bits;
  const D2 v = {x, 0.0};
  const I2 sign = bits<I2>(v) & static_cast<std::int64_t>(std::uint64_t{1} << 63);
  const D2 a = bits<D2>(bits<I2>(v) ^ sign);
  D2 s;
  if (a[0] < kSmall) s = detail::sin_series(a);
  else if (!(a[0] < kLarge)) return std::sin(x);  // huge, infinite or NaN
  else s = detail::sin_reduced<D2, I2>(a);
  return bits<D2>(bits<I2>(s) ^ sign)[0];
}

namespace detail {

// s[g][k] = sin(x[g L + k]) for the G vectors of L lanes at x: interleaved by the compiler, with
// one choice of path for all of them. One vector at a time in and out of memory (a copy of the
// whole array went through the stack in halves, and its reload stalled on them).
template <class V, class I, int G>
RAYDAMP_SINE_INLINE void sin_block(const double* x, V (&s)[G]) {
  constexpr int L = static_cast<int>(sizeof(V) / sizeof(double));
  V v[G], a[G];
  I sign[G];
  for (int g = 0; g < G; ++g) std::memcpy(&v[g], x + g * L, sizeof(V));
  const auto sign_bit = static_cast<std::int64_t>(std::uint64_t{1} << 63);
  for (int g = 0; g < G; ++g) {
    sign[g] = bits<I>(v[g]) & sign_bit;
    a[g] = bits<V>(bits<I>(v[g]) ^ sign[g]);
  }
  // Masks; NaN lanes count as large, as in sin().
  I small = a[0] < kSmall, large = ~(a[0] < kLarge);
  for (int g = 1; g < G; ++g) {
    small &= a[g] < kSmall;
    large |= ~(a[g] < kLarge);
  }
  std::int64_t all_small = small[0], any_large = large[0];
  for (int k = 1; k < L; ++k) {
    all_small &= small[k];
    any_large |= large[k];
  }
  if (all_small != 0) {
    for (int g = 0; g < G; ++g) s[g] = sin_series(a[g]);
  } else if (any_large != 0) {
    double out[G * L];
    for (int k = 0; k < G * L; ++k) out[k] = sin(x[k]);
    for (int g = 0; g < G; ++g) std::memcpy(&s[g], out + g * L, sizeof(V));
    return;
  } else {
    for (int g = 0; g < G; ++g) s[g] = sin_reduced<V, I>(a[g]);
  }
  for (int g = 0; g < G; ++g) s[g] = bits<V>(bits<I>(s[g]) ^ sign[g]);
}

}  // namespace detail

// out[k] = sin(x[k]), k = 0..3: two pairs of SIMD lanes, interleaved by the compiler.
inline void sin4(const double* x, double* out) {
  detail::D2 s[2];
  detail::sin_block<detail::D2, detail::I2, 2>(x, s);
  std::memcpy(out, &s[0], sizeof s[0]);
  std::memcpy(out + 2, &s[1], sizeof s[1]);
}

}  // namespace raydamp::math
