// The kernel of the batched screen (events/watcher.hpp, batch_screens): the first of a block's stored
// step ends that is not quiet for some group of affine events. A group's L, S and R at each end are taken
// as screen_groups() takes them (term by term in the group's order, from +0) and compared as inside()
// compares them, so each end is judged on the same bits as in the loop. On x86, two ends to an SSE2
// register, four where the processor has AVX2 (chosen at the call); the compares and R's sign bits come
// out as masks (movmskpd), with no branch per end.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "raydamp/math/cpu.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace raydamp::block_sums {

// The block's stored ends: q[i] of end j at q[j QS + i], M^-1 p at v[j VS + i], t at t[j].
struct Rows {
  const double *q, *v, *t;
};

// A group: its inputs [first, last) (which: 0 for q[index], 2 for t; coefficient), the gap its L must
// stay clear inside and the rate's sign to keep (EventWatcher::inside()).
template <class Input>
struct Group {
  const Input *first, *last;
  double lo, hi, lo_slack, hi_slack, slack;
  bool falling;  // the kept R is negative (its sign bit set)
};

#if defined(__x86_64__) || defined(__i386__)
// x[j Stride] and x[(j + 1) Stride].
template <int Stride>
__m128d pair(const double* x, long j) {
  if constexpr (Stride == 1) return _mm_loadu_pd(x + j);
  else if constexpr (Stride == 2) return _mm_unpacklo_pd(_mm_loadu_pd(x + 2 * j), _mm_loadu_pd(x + 2 * j + 2));
  else return _mm_set_pd(x[(j + 1) * Stride], x[j * Stride]);
}

// Bits 0, 1 set: ends j, j + 1 are not quiet for group g.
template <int QS, int VS, class Input>
unsigned loud2(const Group<Input>& g, Rows rows, long j) {
  __m128d L = _mm_setzero_pd(), S = L, R = L;
  const __m128d magnitude = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffff));
  for (const Input* in = g.first; in != g.last; ++in) {
    const __m128d c = _mm_set1_pd(in->coefficient);
    __m128d term;
    if (in->which == 0) {
      term = _mm_mul_pd(c, pair<QS>(rows.q + in->index, j));
      R = _mm_add_pd(R, _mm_mul_pd(c, pair<VS>(rows.v + in->index, j)));
    } else {
      term = _mm_mul_pd(c, pair<1>(rows.t, j));
      R = _mm_add_pd(R, c);
    }
    L = _mm_add_pd(L, term);
    S = _mm_add_pd(S, _mm_and_pd(term, magnitude));
  }
  const __m128d margin = _mm_mul_pd(_mm_set1_pd(g.slack), S);
  const __m128d above = _mm_cmpgt_pd(_mm_sub_pd(L, _mm_set1_pd(g.lo)), _mm_add_pd(_mm_set1_pd(g.lo_slack), margin));
  const __m128d below = _mm_cmpgt_pd(_mm_sub_pd(_mm_set1_pd(g.hi), L), _mm_add_pd(_mm_set1_pd(g.hi_slack), margin));
  const int quiet = _mm_movemask_pd(_mm_and_pd(above, below)) & ~(_mm_movemask_pd(R) ^ (g.falling ? 3 : 0));
  return static_cast<unsigned>(~quiet & 3);
}

// x[(j + u) Stride] for u < 4.
template <int Stride>
__attribute__((target("avx2"))) __m256d quad(const double* x, long j) {
  if constexpr (Stride == 1) {
    return _mm256_loadu_pd(x + j);
  } else if constexpr (Stride == 2) {  // x0 . x1 . | x2 . x3 . -> x0 x2 x1 x3 -> x0 x1 x2 x3
    const __m256d a = _mm256_loadu_pd(x + 2 * j), b = _mm256_loadu_pd(x + 2 * j + 4);
    return _mm256_permute4x64_pd(_mm256_unpacklo_pd(a, b), 0xD8);
  } else {
    return _mm256_set_pd(x[(j + 3) * Stride], x[(j + 2) * Stride], x[(j + 1) * Stride], x[j * Stride]);
  }
}

// A term's value and rate at four ends: c x and c dx/dt (c for t). Paired: q and v interleaved (Dim 1,
// M = 1: v = q + 1), both from one pair of loads, in the lane order (j, j + 2, j + 1, j + 3) that
// unpacking them gives, t permuted to match.
template <int QS, int VS, bool Paired, class Input>
__attribute__((target("avx2"))) void term4(const Input* in, Rows rows, long j, __m256d& term, __m256d& rate) {
  const __m256d c = _mm256_set1_pd(in->coefficient);
  if (in->which != 0) {
    const __m256d t = _mm256_loadu_pd(rows.t + j);
    term = _mm256_mul_pd(c, Paired ? _mm256_permute4x64_pd(t, 0xD8) : t);
    rate = c;
  } else if constexpr (Paired) {
    const __m256d a = _mm256_loadu_pd(rows.q + 2 * j), b = _mm256_loadu_pd(rows.q + 2 * j + 4);
    term = _mm256_mul_pd(c, _mm256_unpacklo_pd(a, b));
    rate = _mm256_mul_pd(c, _mm256_unpackhi_pd(a, b));
  } else {
    term = _mm256_mul_pd(c, quad<QS>(rows.q + in->index, j));
    rate = _mm256_mul_pd(c, quad<VS>(rows.v + in->index, j));
  }
}

// The first end in [j, m) not quiet for group g, or m: loud2's operations, four ends at a time, the
// group's constants held in registers across them. (L and S start from the first term, not from 0 plus
// it: they differ only in the sign of a zero, which no compare below sees; R's sign bit is read, so R
// keeps its 0 +.)
template <int QS, int VS, bool Paired, class Input>
__attribute__((noinline, target("avx2"))) long first_loud4(const Group<Input>& g, Rows rows, long j, long m) {
  const __m256d magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
  const __m256d lo = _mm256_set1_pd(g.lo), hi = _mm256_set1_pd(g.hi), lo_slack = _mm256_set1_pd(g.lo_slack),
                hi_slack = _mm256_set1_pd(g.hi_slack), slack = _mm256_set1_pd(g.slack);
  const int falling = g.falling ? 15 : 0;
  for (; j < m; j += 4) {
    __m256d L = _mm256_setzero_pd(), S = L, R = L;
    if (g.first != g.last) {
      __m256d term, rate;
      term4<QS, VS, Paired>(g.first, rows, j, term, rate);
      L = term;
      S = _mm256_and_pd(term, magnitude);
      R = _mm256_add_pd(R, rate);
      for (const Input* in = g.first + 1; in != g.last; ++in) {
        term4<QS, VS, Paired>(in, rows, j, term, rate);
        L = _mm256_add_pd(L, term);
        S = _mm256_add_pd(S, _mm256_and_pd(term, magnitude));
        R = _mm256_add_pd(R, rate);
      }
    }
    const __m256d margin = _mm256_mul_pd(slack, S);
    const __m256d above = _mm256_cmp_pd(_mm256_sub_pd(L, lo), _mm256_add_pd(lo_slack, margin), _CMP_GT_OQ);
    const __m256d below = _mm256_cmp_pd(_mm256_sub_pd(hi, L), _mm256_add_pd(hi_slack, margin), _CMP_GT_OQ);
    const int quiet = _mm256_movemask_pd(_mm256_and_pd(above, below)) & ~(_mm256_movemask_pd(R) ^ falling);
    unsigned loud = static_cast<unsigned>(~quiet & 15);
    if (Paired) loud = (loud & 9u) | ((loud & 2u) << 1) | ((loud & 4u) >> 1);  // lanes back in the ends' order
    if (loud) return std::min(j + __builtin_ctz(loud), m);  // (ends past the block's come after its own)
  }
  return m;
}
#else
// Bits 0, 1 set: ends j, j + 1 are not quiet for group g (one end at a time).
template <int QS, int VS, class Input>
unsigned loud2(const Group<Input>& g, Rows rows, long j) {
  unsigned out = 0;
  for (long u = 0; u < 2; ++u) {
    double L = 0.0, S = 0.0, R = 0.0;
    for (const Input* in = g.first; in != g.last; ++in) {
      const double c = in->coefficient;
      const double term = in->which == 0 ? c * rows.q[(j + u) * QS + in->index] : c * rows.t[j + u];
      R += in->which == 0 ? c * rows.v[(j + u) * VS + in->index] : c;
      L += term;
      S += std::abs(term);
    }
    const double margin = g.slack * S;
    const bool quiet = L - g.lo > g.lo_slack + margin && g.hi - L > g.hi_slack + margin && std::signbit(R) == g.falling;
    out |= static_cast<unsigned>(!quiet) << u;
  }
  return out;
}
#endif

// The first end in [j, m) not quiet for group g, or m: two ends at a time.
template <int QS, int VS, class Input>
__attribute__((noinline)) long first_loud2(const Group<Input>& g, Rows rows, long j, long m) {
  for (; j < m; j += 2) {
    const unsigned loud = loud2<QS, VS>(g, rows, j);
    if (loud) return std::min(j + __builtin_ctz(loud), m);
  }
  return m;
}

// The first end in [j, m) not quiet for some group of groups[0, count), or m (rows readable to m + 3):
// the least of the groups' first, each group scanned only as far as those before it left it to find.
template <int QS, int VS, class Input>
long first_loud(const Group<Input>* groups, std::size_t count, Rows rows, long j, long m) {
  for (std::size_t g = 0; g < count; ++g) {
#if defined(__x86_64__) || defined(__i386__)
    if (has_avx2()) {
      const bool paired = QS == 2 && VS == 2 && rows.v == rows.q + 1;
      m = paired ? first_loud4<2, 2, true>(groups[g], rows, j, m) : first_loud4<QS, VS, false>(groups[g], rows, j, m);
      continue;
    }
#endif
    m = first_loud2<QS, VS>(groups[g], rows, j, m);
  }
  return m;
}

}  // namespace raydamp::block_sums
