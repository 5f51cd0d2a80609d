// Bouc-Wen's return maps for a whole set of springs at once, several springs to a vector: two (SSE2, NEON), or
// four where the processor has AVX2, chosen when first called. The kick of a structure with Bouc-Wen springs
// calls it (materials/springs.hpp).
//
// Why: a step waits for its springs' forces, and one Bouc-Wen return map is some 35 floating-point
// operations (BoucWen::force: phi1's Pade approximant most of them) where Bilinear's is a handful. A 10-storey
// frame (3s, h = 0.0025, a C++ driver with bench_springs.py's frame in free vibration) stepped in 128 ns with
// Bouc-Wen storeys in two lanes, 112-114 ns in four, and 77 ns as a LinearStructure without springs. Eight
// lanes (AVX-512, called from the module's SSE2 code) took 174 ns: none here.
//
// The common step, on one side of w = 0 with |x| = |c D| <= 1/2 (materials.hpp's notation), takes no branch
// that depends on the data: the side's rate c by a mask, phi1 by the [6/6] Pade approximant of e^x. A step
// that reaches w = 0 from below (the rate changes there), a longer one, or a non-finite deformation goes
// through BoucWen::force, one spring at a time. Every spring takes the same vector arithmetic, whatever the
// width (a block's missing lanes copy its last spring): a spring's force is the same bits wherever it stands
// in the set and whichever processor ran it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "raydamp/materials/materials.hpp"
#include "raydamp/math/cpu.hpp"

namespace raydamp::materials::bouc_wen_lanes {

using D2 = double __attribute__((vector_size(16)));
using I2 = std::int64_t __attribute__((vector_size(16)));
using D4 = double __attribute__((vector_size(32)));
using I4 = std::int64_t __attribute__((vector_size(32)));

// The largest |x| = c D the lanes take, and their phi1 (materials.hpp, where BoucWen's common step takes both).
inline constexpr double kBound = kPadeBound;
using materials::pade_phi1;

// The widest block: parameter arrays and forces are padded to a multiple of it.
inline constexpr std::size_t kWidest = 4;

// Each spring's parameters as the lanes load them, one array per parameter, padded to a multiple of kWidest
// (the pad repeats the last spring): a block loads its springs' parameter with one load instead of gathering
// it from BoucWen records.
struct Params {
  std::vector<double> per_yield, beta, gamma, elastic, hysteretic;

  void add(const BoucWen& m) {
    for (auto* v : arrays()) v->resize(count);
    per_yield.push_back(m.per_yield);
    beta.push_back(m.beta);
    gamma.push_back(m.gamma);
    elastic.push_back(m.elastic);
    hysteretic.push_back(m.hysteretic);
    ++count;
    for (auto* v : arrays()) v->resize(padded(count), v->back());
  }
  // The entries of a forces() output for n springs.
  static std::size_t padded(std::size_t n) { return (n + kWidest - 1) / kWidest * kWidest; }

 private:
  std::size_t count = 0;
  std::vector<std::vector<double>*> arrays() { return {&per_yield, &beta, &gamma, &elastic, &hysteretic}; }
};

template <class V>
inline __attribute__((always_inline)) V load(const double* p) {
  V v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

// out[s] = sigma_s(d[s]) = elastic d + hysteretic z and the trial state t[s] from the committed c[s], for s < n,
// L springs to a vector V (I: its integer twin); out holds Params::padded(n) entries. True where some spring's
// step is not the common one, whose force and trial state the caller then takes from BoucWen::force.
template <class V, class I, std::size_t L>
inline __attribute__((always_inline)) bool common_forces(const Params& P, const BoucWen::State* c, const double* d,
                                                         BoucWen::State* t, double* out, std::size_t n) {
  const I sign_bit = I{} + static_cast<std::int64_t>(std::uint64_t{1} << 63);
  I any_slow = I{};
  for (std::size_t s = 0; s < n; s += L) {
    // The last block's missing lanes repeat its last spring, and are not written back.
    V deformation, d0, z0;
    for (std::size_t l = 0; l < L; ++l) {
      const std::size_t k = std::min(s + l, n - 1);
      deformation[l] = d[k];
      d0[l] = c[k].d;
      z0[l] = c[k].z;
    }
    const V per_yield = load<V>(&P.per_yield[s]), beta = load<V>(&P.beta[s]), gamma = load<V>(&P.gamma[s]);
    // A cast between vector types of one size keeps the bits (GCC and Clang): the signs by masks.
    const V step = deformation - d0;
    const I sign = (I)step & sign_bit;  // s = sgn(step): w = s z, and z = s w, by flipping the sign bit
    const V w = (V)((I)z0 ^ sign);
    const V distance = (V)((I)step & ~sign_bit) * per_yield;
    const I below = w < 0.0;
    const V rate = beta + (V)((I)gamma ^ (below & sign_bit));  // beta - gamma below w = 0, beta + gamma above
    const V x = -rate * distance;
    const V end = w + (1.0 - rate * w) * (distance * pade_phi1(x));
    any_slow |= (below & (end > 0.0)) | ~((V)((I)x & ~sign_bit) <= kBound);
    const V z = (V)((I)end ^ sign);
    const V force = load<V>(&P.elastic[s]) * deformation + load<V>(&P.hysteretic[s]) * z;
    __builtin_memcpy(out + s, &force, sizeof force);
    for (std::size_t l = 0; l < L && s + l < n; ++l) t[s + l] = {deformation[l], z[l]};
  }
  bool slow = false;
  for (std::size_t l = 0; l < L; ++l) slow |= any_slow[l] != 0;
  return slow;
}

// Two springs to a vector (SSE2, NEON), and four where the processor has AVX2: the same operations in every
// lane (no FMA: the flags of the core keep a * b + c two roundings), so the same bits either way.
__attribute__((noinline)) inline bool common_forces2(const Params& P, const BoucWen::State* c, const double* d,
                                                     BoucWen::State* t, double* out, std::size_t n) {
  return common_forces<D2, I2, 2>(P, c, d, t, out, n);
}
#if defined(__x86_64__) || defined(__i386__)
__attribute__((noinline, target("avx2"))) inline bool common_forces4(const Params& P, const BoucWen::State* c,
                                                                    const double* d, BoucWen::State* t, double* out,
                                                                    std::size_t n) {
  return common_forces<D4, I4, 4>(P, c, d, t, out, n);
}
#endif

// out[s] = sigma_s(d[s]) and the trial state t[s] from the committed c[s], for the n springs m[0..n) with
// parameters P; out holds Params::padded(n) entries.
inline void forces(const BoucWen* m, const Params& P, const BoucWen::State* c, const double* d, BoucWen::State* t,
                   double* out, std::size_t n) {
#if defined(__x86_64__) || defined(__i386__)
  const bool slow = has_avx2() ? common_forces4(P, c, d, t, out, n) : common_forces2(P, c, d, t, out, n);
#else
  const bool slow = common_forces2(P, c, d, t, out, n);
#endif
  if (__builtin_expect(slow, 0)) {
    for (std::size_t s = 0; s < n; ++s) {
      double z;
      if (!m[s].common_step(c[s], d[s], z)) out[s] = m[s].force(c[s], d[s], t[s]);
    }
  }
}

}  // namespace raydamp::materials::bouc_wen_lanes
