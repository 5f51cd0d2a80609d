// The Kepler drift of many bodies at once (models/planets.hpp's drift: 1,000 test particles, an
// ensemble's members batched as particles): kepler::short_drift's arithmetic on two lanes per SSE2
// register, or four per AVX2 register where the processor has it, with each lane's operations in the
// scalar code's order, so a body's result is the same bits in a block or alone (tests/test_kepler.py's
// ensembles equal their single runs bit for bit).
//
// A block takes the short path only where the scalar code would take it on every lane and finish in the
// same way: a short step, a Stumpff argument needing no quadrupling (|x| <= 0.1), and Halley converged at
// its first iterate. Otherwise every lane of the block takes kepler::drift, one at a time; the scalar code
// then repeats exactly what the block would have done on the lanes that qualified.
//
// Why: the scalar drift is a chain of two divisions, a root and a Horner series with little to overlap;
// 1,000 independent orbits are the same chain in parallel (2s on Kepler(particles=1000), ns per member per
// step: benchmarks/bench_vs_rebound.py --ensemble-only).
//
// AVX2 only, not FMA, and built with -ffp-contract=off (CMakeLists.txt): a fused multiply-add would round
// a*b+c once where the scalar code rounds twice. cpp/tests/test_kepler_lanes.cpp runs at -O3, where GCC would
// contract.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "raydamp/flows/kepler.hpp"

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define RAYDAMP_KEPLER_LANES 1
#define RAYDAMP_KEPLER_INLINE inline __attribute__((always_inline))
#define RAYDAMP_KEPLER_KERNEL inline __attribute__((noinline))
#define RAYDAMP_KEPLER_KERNEL_AVX2 inline __attribute__((noinline, target("avx2")))
#else
#define RAYDAMP_KEPLER_LANES 0
#endif

namespace raydamp::kepler {

// A body's drift in the scalar code: q, p (momentum) of `d` coordinates at q_ and p_, mass m (1 / m given).
inline void drift_body(double mu, double m, double inverse, double t, int d, double* q_, double* p_) {
  struct Small {
    double x[3];
    int n;
    double& operator[](int i) { return x[i]; }
    double operator[](int i) const { return x[i]; }
    int size() const { return n; }
  };
  Small q{{q_[0], q_[1], d == 3 ? q_[2] : 0.0}, d};
  Small v{{inverse * p_[0], inverse * p_[1], d == 3 ? inverse * p_[2] : 0.0}, d};
  drift(mu, t, q, v);
  for (int j = 0; j < d; ++j) q_[j] = q[j], p_[j] = m * v[j];
}

#if RAYDAMP_KEPLER_LANES
namespace detail {

template <class V>
struct Ints;
template <>
struct Ints<double __attribute__((vector_size(16)))> {
  using type = std::int64_t __attribute__((vector_size(16)));
};
template <>
struct Ints<double __attribute__((vector_size(32)))> {
  using type = std::int64_t __attribute__((vector_size(32)));
};

template <class V>
RAYDAMP_KEPLER_INLINE V magnitude(V x) {
  using I = typename Ints<V>::type;
  I i;
  std::memcpy(&i, &x, sizeof i);
  i &= ~(I{} + INT64_MIN);
  std::memcpy(&x, &i, sizeof x);
  return x;
}

// Correctly rounded, as std::sqrt: SSE2's sqrtpd on each half (its AVX form is not declared outside a
// target("avx") function, and this template is instantiated for both).
template <class V>
RAYDAMP_KEPLER_INLINE V root(V x) {
  using D2 = double __attribute__((vector_size(16)));
  if constexpr (sizeof(V) == 16) {
    return __builtin_ia32_sqrtpd(x);
  } else {
    D2 half[2];
    std::memcpy(half, &x, sizeof x);
    half[0] = __builtin_ia32_sqrtpd(half[0]);
    half[1] = __builtin_ia32_sqrtpd(half[1]);
    std::memcpy(&x, half, sizeof x);
    return x;
  }
}

template <class M>
RAYDAMP_KEPLER_INLINE bool all(M m) {
  constexpr int L = sizeof(M) / sizeof(std::int64_t);
  bool ok = true;
  for (int l = 0; l < L; ++l) ok &= m[l] != 0;
  return ok;
}

// One block of L = sizeof(V) / 8 bodies starting at body b (coordinates d * b ...): drifted, true; or
// untouched, false (the caller drifts them one at a time). Each line is short_drift's, in its order.
template <class V, int D>
RAYDAMP_KEPLER_INLINE bool short_block(const double* mu_, const double* m_, const double* inverse_, double t,
                                        double* q_, double* p_) {
  constexpr int L = sizeof(V) / sizeof(double);
  // gathered into plain arrays, then copied whole into the vectors
  double lanes_mu[L], lanes_x[D][L], lanes_v[D][L];
  for (int l = 0; l < L; ++l) {
    lanes_mu[l] = mu_[l];
    for (int c = 0; c < D; ++c) lanes_x[c][l] = q_[D * l + c], lanes_v[c][l] = inverse_[D * l] * p_[D * l + c];
  }
  V mu, x[D], v[D];
  std::memcpy(&mu, lanes_mu, sizeof mu);
  std::memcpy(x, lanes_x, sizeof x);
  std::memcpy(v, lanes_v, sizeof v);
  // kepler::drift
  V r2 = x[0] * x[0], sigma0 = x[0] * v[0], v2 = v[0] * v[0];
  for (int c = 1; c < D; ++c) {
    r2 += x[c] * x[c];
    sigma0 += x[c] * v[c];
    v2 += v[c] * v[c];
  }
  const V r0 = root(r2), ir0 = 1.0 / r0;
  if (!all(2.0 * t * t * (v2 + mu * ir0) < kShortReach * kShortReach * r2)) return false;
  // kepler::short_drift
  const V beta = 2.0 * mu * ir0 - v2;
  const V ir3 = ir0 * ir0 * ir0;
  V s = t * ir0 * (1.0 + t * (-0.5 * sigma0 * ir3 * r0 +
                              t * (3.0 * sigma0 * sigma0 * ir3 * ir0 * ir0 - (v2 - mu * ir0) * ir3) * r0 / 6.0));
  // g_functions and stumpff at levels 0; each lane's Horner starts at its own top (stumpff's ranges)
  const V arg = beta * s * s;
  const V size = magnitude(arg);
  if (!all(size <= 0.1)) return false;
  const V y = -arg;
  constexpr const double* a2 = kStumpff2<double>;
  constexpr const double* a3 = kStumpff3<double>;
  V c2 = V{} + a2[7], c3 = V{} + a3[7];
  constexpr double below[] = {0, 0, 0, 1e-4, 1e-3, 1e-2, 0.03};  // top <= j where size < below[j]
  for (int j = 6; j >= 0; --j) {
    const V n2 = a2[j] + y * c2, n3 = a3[j] + y * c3;
    if (j >= 3) {
      const auto started = size < below[j];
      c2 = started ? V{} + a2[j] : n2;
      c3 = started ? V{} + a3[j] : n3;
    } else {
      c2 = n2, c3 = n3;
    }
  }
  const V c1 = 1.0 - arg * c3, c0 = 1.0 - arg * c2;
  const V g0 = c0, g1 = s * c1, g2 = s * s * c2, g3 = s * s * s * c3;
  const V r = r0 * g0 + sigma0 * g1 + mu * g2;
  const V f = r0 * g1 + sigma0 * g2 + mu * g3 - t;
  const V fp = r;
  const V fpp = sigma0 * g0 + (mu - beta * r0) * g1;
  const V ds = -f * fp / (fp * fp - 0.5 * f * fpp);
  if (!all(magnitude(ds) <= 1e-6 * magnitude(s))) return false;
  const V half = 0.5 * ds * ds;
  const V h0 = g0 - beta * (g1 * ds + g0 * half);
  const V h1 = g1 + g0 * ds - beta * g1 * half;
  const V h2 = g2 + g1 * ds + g0 * half;
  const V rr = r0 * h0 + sigma0 * h1 + mu * h2;
  const V ir = 1.0 / rr;
  const V f1 = -mu * h2 * ir0;
  const V g = r0 * h1 + sigma0 * h2;
  const V fdot = -mu * h1 * ir * ir0;
  const V gdot1 = -mu * h2 * ir;
  for (int c = 0; c < D; ++c) {
    const V qc = x[c], vc = v[c];
    x[c] = qc + (f1 * qc + g * vc);
    v[c] = vc + (fdot * qc + gdot1 * vc);
  }
  std::memcpy(lanes_x, x, sizeof x);
  std::memcpy(lanes_v, v, sizeof v);
  for (int l = 0; l < L; ++l)
    for (int c = 0; c < D; ++c) q_[D * l + c] = lanes_x[c][l], p_[D * l + c] = m_[D * l] * lanes_v[c][l];
  return true;
}

// Bodies [0, n): blocks of L, the rest (and any block refused) one at a time.
template <class V, int D>
RAYDAMP_KEPLER_INLINE void drift_lanes(const double* mu, const double* m, const double* inverse, double t, int n,
                                       double* q, double* p) {
  constexpr int L = sizeof(V) / sizeof(double);
  int b = 0;
  for (; b + L <= n; b += L)
    if (!short_block<V, D>(mu + b, m + D * b, inverse + D * b, t, q + D * b, p + D * b))
      for (int l = b; l < b + L; ++l) drift_body(mu[l], m[D * l], inverse[D * l], t, D, q + D * l, p + D * l);
  for (; b < n; ++b) drift_body(mu[b], m[D * b], inverse[D * b], t, D, q + D * b, p + D * b);
}

using D2 = double __attribute__((vector_size(16)));
using D4 = double __attribute__((vector_size(32)));

template <int D>
RAYDAMP_KEPLER_KERNEL void drift_sse2(const double* mu, const double* m, const double* inverse, double t, int n,
                                      double* q, double* p) {
  drift_lanes<D2, D>(mu, m, inverse, t, n, q, p);
}
template <int D>
RAYDAMP_KEPLER_KERNEL_AVX2 void drift_avx2(const double* mu, const double* m, const double* inverse, double t, int n,
                                           double* q, double* p) {
  drift_lanes<D4, D>(mu, m, inverse, t, n, q, p);
}

}  // namespace detail
#endif

// The Kepler flow over t of bodies [0, n), each with its own mu[i] and mass (m, inverse: per coordinate,
// d per body), positions q and momenta p of d = 2 or 3 coordinates per body. Four lanes where the
// processor has AVX2 (`wide`), two otherwise; the same bits as drift_body on each body either way.
inline void drift_bodies(const double* mu, const double* m, const double* inverse, double t, int d, int n, double* q,
                         double* p) {
  if (t == 0) return;
#if RAYDAMP_KEPLER_LANES
  static const bool wide = __builtin_cpu_supports("avx2");
  if (d == 2) return wide ? detail::drift_avx2<2>(mu, m, inverse, t, n, q, p) : detail::drift_sse2<2>(mu, m, inverse, t, n, q, p);
  return wide ? detail::drift_avx2<3>(mu, m, inverse, t, n, q, p) : detail::drift_sse2<3>(mu, m, inverse, t, n, q, p);
#else
  for (int b = 0; b < n; ++b) drift_body(mu[b], m[d * b], inverse[d * b], t, d, q + d * b, p + d * b);
#endif
}

}  // namespace raydamp::kepler
