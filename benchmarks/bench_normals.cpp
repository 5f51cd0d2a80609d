// Normal numbers per second from the thermal noise's stream (issue 29: a noisy step <= 2x a noiseless
// one): the buffered NormalStream (raydamp/random/philox.hpp) against the one-block-at-a-time stream it
// replaced (cpp/tests/reference_normal_stream.hpp), both in the same run, as the step loop draws them:
// fill() of a vector (a large model's damping flow) and single next() calls (the pendulum, lanes).
// The outputs are checked equal before timing. Prints figures only; exits 0 whatever they are.
// Built by benchmarks/CMakeLists.txt; RAYDAMP_NORMAL_BUFFER=8/16/32 compares buffer sizes and
// RAYDAMP_NORMAL_SIMD=0/1/2 the portable, SSE2 and AVX2 refills:
//   g++ -std=c++17 -O3 -fPIC -Icpp/include -Icpp/tests -DRAYDAMP_NORMAL_BUFFER=16 benchmarks/bench_normals.cpp
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "reference_normal_stream.hpp"

using namespace raydamp;

namespace {

template <class Run>
double best_ns_per_normal(Run run, long normals) {
  double best = 1e300;
  for (int repeat = 0; repeat < 7; ++repeat) {
    const auto start = std::chrono::steady_clock::now();
    run();
    const std::chrono::duration<double, std::nano> took = std::chrono::steady_clock::now() - start;
    best = std::min(best, took.count() / double(normals));
  }
  return best;
}

volatile double sink;

}  // namespace

int main() {
  const long normals = 4'000'000;
  std::vector<double> x(10'000), y(10'000);
  {  // the same numbers, or the figures mean nothing
    NormalStream s(1, 2);
    ReferenceNormalStream r(1, 2);
    s.fill(x);
    for (double& v : y) v = r.next();
    if (x != y) {
      std::printf("bench_normals: the buffered stream differs from the reference\n");
      return 1;
    }
  }
  NormalStream s(1, 2);
  ReferenceNormalStream r(1, 2);
  const double fill_old = best_ns_per_normal([&] {
    for (long i = 0; i < normals; i += long(y.size())) for (double& v : y) v = r.next();
    sink = y[0];
  }, normals);
  const double fill_new = best_ns_per_normal([&] {
    for (long i = 0; i < normals; i += long(x.size())) s.fill(x);
    sink = x[0];
  }, normals);
  const double next_old = best_ns_per_normal([&] {
    double acc = 0.0;
    for (long i = 0; i < normals; ++i) acc += r.next();
    sink = acc;
  }, normals);
  const double next_new = best_ns_per_normal([&] {
    double acc = 0.0;
    for (long i = 0; i < normals; ++i) acc += s.next();
    sink = acc;
  }, normals);
#if RAYDAMP_NORMAL_SIMD >= 2
  const char* refill = __builtin_cpu_supports("avx2") ? "AVX2" : "SSE2";
#else
  const char* refill = RAYDAMP_NORMAL_SIMD == 1 ? "SSE2" : "portable loop";
#endif
  std::printf("normal numbers, best of 7 x %ld; buffer %d blocks (%zu-byte stream), refill by %s\n", normals,
              NormalStream::kBuffered, sizeof(NormalStream), refill);
  std::printf("%-34s %12s %12s %8s\n", "", "reference", "buffered", "speedup");
  std::printf("%-34s %9.2f ns %9.2f ns %7.2fx\n", "fill of 10^4 (a large model)", fill_old, fill_new, fill_old / fill_new);
  std::printf("%-34s %9.2f ns %9.2f ns %7.2fx\n", "next() one at a time", next_old, next_new, next_old / next_new);
  std::printf("%-34s %9.1f M/s %8.1f M/s\n", "fill, normals per second", 1e3 / fill_old, 1e3 / fill_new);
  return 0;
}
