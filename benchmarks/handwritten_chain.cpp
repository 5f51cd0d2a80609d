// The references for bench_large.py, with plain doubles and no Eigen or raydamp header:
//   chain N STEPS h alpha beta   the FPUT chain with fixed ends (m = 1, k = 1), leapfrog
//                                written as a person writes it for speed: a half drift,
//                                then (kick h, drift h) per step with the halves merged,
//                                a closing half drift; the force of each bond computed for
//                                both its sites so the loops vectorise. Started in mode 1
//                                (q_j = sin(pi (j+1)/(N+1)), p = 0), like bench_large.py.
//   triad N REPEATS              a STREAM-like triad a = b + s c over three arrays of N doubles.
// Prints one line of JSON: best seconds over 3 repeats; for the chain also the final
// sums of q and p and q[N/2], p[N/2] at full precision (bench_large.py checks raydamp's
// sv ends in the same state).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

inline double force(double r, double alpha, double beta) { return r * (1.0 + r * (alpha + r * beta)); }

void drift(double* __restrict q, const double* __restrict p, long n, double t) {
  for (long i = 0; i < n; ++i) q[i] += t * p[i];
}

void kick(const double* __restrict q, double* __restrict p, long n, double t, double alpha, double beta) {
  p[0] -= t * (force(q[0], alpha, beta) - force(q[1] - q[0], alpha, beta));
  for (long i = 1; i < n - 1; ++i)
    p[i] -= t * (force(q[i] - q[i - 1], alpha, beta) - force(q[i + 1] - q[i], alpha, beta));
  p[n - 1] -= t * (force(q[n - 1] - q[n - 2], alpha, beta) - force(-q[n - 1], alpha, beta));
}

int chain(long n, long steps, double h, double alpha, double beta) {
  std::vector<double> q(n), p(n);
  double best = 1e300;
  for (int repeat = 0; repeat < 3; ++repeat) {
    for (long j = 0; j < n; ++j) {
      q[j] = std::sin(M_PI * (j + 1) / (n + 1));
      p[j] = 0.0;
    }
    const double start = now();
    drift(q.data(), p.data(), n, 0.5 * h);
    for (long s = 0; s + 1 < steps; ++s) {
      kick(q.data(), p.data(), n, h, alpha, beta);
      drift(q.data(), p.data(), n, h);
    }
    kick(q.data(), p.data(), n, h, alpha, beta);
    drift(q.data(), p.data(), n, 0.5 * h);
    best = std::min(best, now() - start);
  }
  double sq = 0.0, sp = 0.0;
  for (long j = 0; j < n; ++j) {
    sq += q[j];
    sp += p[j];
  }
  std::printf("{\"seconds\": %.9g, \"sum_q\": %.17g, \"sum_p\": %.17g, \"q_mid\": %.17g, \"p_mid\": %.17g}\n", best,
              sq, sp, q[n / 2], p[n / 2]);
  return 0;
}

int triad(long n, long repeats) {
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  const double s = 3.0;
  double best = 1e300;
  for (long r = 0; r < repeats; ++r) {
    double* __restrict x = a.data();
    const double* __restrict y = b.data();
    const double* __restrict z = c.data();
    const double start = now();
    for (long i = 0; i < n; ++i) x[i] = y[i] + s * z[i];
    best = std::min(best, now() - start);
    b[r % n] = a[(r * 7) % n];  // keep the result live
  }
  std::printf("{\"seconds\": %.9g, \"check\": %.17g}\n", best, a[n / 3]);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "";
  if (what == "chain" && argc == 7)
    return chain(std::atol(argv[2]), std::atol(argv[3]), std::atof(argv[4]), std::atof(argv[5]), std::atof(argv[6]));
  if (what == "triad" && argc == 4) return triad(std::atol(argv[2]), std::atol(argv[3]));
  std::fprintf(stderr, "usage: handwritten_chain chain N STEPS h alpha beta | triad N REPEATS\n");
  return 2;
}
