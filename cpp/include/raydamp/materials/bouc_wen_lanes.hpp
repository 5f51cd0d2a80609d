// Bouc-Wen's return maps for a whole set of springs at once, two springs to a vector (SSE2, NEON). The kick
// of a structure with Bouc-Wen springs calls it (materials/springs.hpp).
//
// Why: a step waits for its springs' forces, and one Bouc-Wen return map is some 35 floating-point
// operations (BoucWen::force: phi1's series most of them) where Bilinear's is a handful. A 10-storey frame
// under a record (3s, h = 0.0025, a C++ driver with the benchmark's frame) stepped in 163-165 ns with
// Bouc-Wen storeys and 89-93 without springs; in two lanes, 151-153 ns. Four lanes in AVX2 (called from
// the module's SSE2 code) took 189-195 ns: none here.
//
// The common step, on one side of w = 0 with |x| = |c D| <= 1/2 (materials.hpp's notation), takes no branch
// that depends on the data: the side's rate c by a mask, phi1 by the [6/6] Pade approximant of e^x. A step
// that reaches w = 0 from below (the rate changes there), a longer one, or a non-finite deformation goes
// through BoucWen::force, one spring at a time, as before. Every spring takes the same vector arithmetic
// (a block's missing lane copies its last spring): a spring's force is the same bits wherever it stands in
// the set.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "raydamp/materials/materials.hpp"

namespace raydamp::materials::bouc_wen_lanes {

using D2 = double __attribute__((vector_size(16)));
using I2 = std::int64_t __attribute__((vector_size(16)));

// The largest |x| = c D the lanes take, and their phi1 (materials.hpp, where BoucWen's common step takes both).
inline constexpr double kBound = kPadeBound;
using materials::pade_phi1;

// out[s] = sigma_s(d[s]) - k_s d[s] and the trial state t[s] from the committed c[s], for the L springs
// at[0..L): lanes past `valid` repeat a spring and are not written.
template <class V, class I, int L>
inline __attribute__((always_inline)) void block(const BoucWen* m, const BoucWen::State* c, const double* d,
                                                 BoucWen::State* t, double* out, const std::size_t (&at)[L],
                                                 int valid) {
  V deformation, d0, z0, per_yield, beta, gamma, elastic_drop, hysteretic;
  for (int l = 0; l < L; ++l) {
    const std::size_t s = at[l];
    deformation[l] = d[s];
    d0[l] = c[s].d;
    z0[l] = c[s].z;
    per_yield[l] = m[s].per_yield;
    beta[l] = m[s].beta;
    gamma[l] = m[s].gamma;
    elastic_drop[l] = m[s].elastic - m[s].k;
    hysteretic[l] = m[s].hysteretic;
  }
  const I sign_bit = I{} + static_cast<std::int64_t>(std::uint64_t{1} << 63);
  // A cast between vector types of one size keeps the bits (GCC and Clang): the signs by masks.
  const V step = deformation - d0;
  const I sign = (I)step & sign_bit;  // s = sgn(step): w = s z, and z = s w, by flipping the sign bit
  const V w = (V)((I)z0 ^ sign);
  const V distance = (V)((I)step & ~sign_bit) * per_yield;
  const I below = w < 0.0;
  const V rate = beta + (V)((I)gamma ^ (below & sign_bit));  // beta - gamma below w = 0, beta + gamma above
  const V x = -rate * distance;
  const V end = w + (1.0 - rate * w) * (distance * pade_phi1(x));
  const I slow = (below & (end > 0.0)) | ~((V)((I)x & ~sign_bit) <= kBound);
  const V z = (V)((I)end ^ sign);
  const V correction = elastic_drop * deformation + hysteretic * z;
  bool any_slow = false;
  for (int l = 0; l < valid; ++l) {
    const std::size_t s = at[l];
    t[s].d = deformation[l];
    t[s].z = z[l];
    out[s] = correction[l];
    any_slow |= slow[l] != 0;
  }
  if (__builtin_expect(any_slow, 0)) {
    for (int l = 0; l < valid; ++l) {
      const std::size_t s = at[l];
      if (slow[l]) out[s] = m[s].correction(c[s], d[s], t[s]);
    }
  }
}

template <class V, class I, int L>
inline __attribute__((always_inline)) void all(const BoucWen* m, const BoucWen::State* c, const double* d,
                                               BoucWen::State* t, double* out, std::size_t n) {
  std::size_t at[L];
  std::size_t s = 0;
  for (; s + L <= n; s += L) {
    for (int l = 0; l < L; ++l) at[l] = s + l;
    block<V, I, L>(m, c, d, t, out, at, L);
  }
  if (s < n) {
    for (int l = 0; l < L; ++l) at[l] = std::min(s + l, n - 1);
    block<V, I, L>(m, c, d, t, out, at, static_cast<int>(n - s));
  }
}

// out[s] = sigma_s(d[s]) - k_s d[s] for s < n, each return map from c[s], its trial state written to t[s].
// Out of line: one copy, whatever the method whose kick calls it.
__attribute__((noinline)) inline void corrections(const BoucWen* m, const BoucWen::State* c, const double* d,
                                                  BoucWen::State* t, double* out, std::size_t n) {
  all<D2, I2, 2>(m, c, d, t, out, n);
}

}  // namespace raydamp::materials::bouc_wen_lanes
