// Chebyshev expansions of a scalar function of a linear operator B with spectrum in
// [0, L]: f(B) x = sum_k c_k T_k(Y) x with Y = (2/L) B - I, using only products with
// B. For the sparse Rayleigh kind B = K M^{-1} and f is exp(-t(alpha + beta lambda))
// or t phi1(-t(alpha + beta lambda)), both entire, so the coefficients fall off
// faster than geometrically once k passes about sqrt(t beta L): a degree a little
// above that gives the function to rounding on the whole interval.
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/FFT>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/errors.hpp"

namespace raydamp {

// The truncated series leaves out at most this much (sum of the dropped |c_k|)
// relative to max |f| on the interval. B is self-adjoint in an inner product in
// which |T_k(Y)| <= 1, so this bounds the error of f(B) x relative to |x| in that
// norm; with the three-term recurrence's rounding it keeps the flows within 1e-12.
inline constexpr double kChebyshevTolerance = 1e-13;
inline constexpr int kMaxChebyshevDegree = 8192;

struct ChebyshevSeries {
  std::vector<double> c;  // c_0 .. c_degree (c_0 already halved)
  double scale = 0.0;     // max |f| at the sample points
  int degree() const { return static_cast<int>(c.size()) - 1; }
};

namespace detail {

// Coefficients of the interpolant of g at the N Chebyshev points y_j = cos(pi (j + 1/2) / N):
// c_k = (2/N) sum_j g(y_j) cos(pi k (j + 1/2) / N), c_0 halved: a DCT-II, done by one complex FFT of
// the samples reordered (even ones forward, odd ones backward) and a quarter-wave twiddle (Makhoul 1980).
// O(N log N): near the degree bound the direct O(N^2) sum took 0.1 s per sub-step length, which a
// stability search over many step lengths paid hundreds of times.
inline std::vector<double> chebyshev_interpolant(const std::vector<double>& values) {
  const int n = static_cast<int>(values.size());
  std::vector<std::complex<double>> v(n), spectrum;
  for (int j = 0; 2 * j < n; ++j) v[j] = values[2 * j];
  for (int j = 0; 2 * j + 1 < n; ++j) v[n - 1 - j] = values[2 * j + 1];
  Eigen::FFT<double> fft;
  fft.fwd(spectrum, v);
  std::vector<double> c(n);
  for (int k = 0; k < n; ++k) c[k] = (2.0 / n) * std::real(std::polar(1.0, -M_PI * k / (2.0 * n)) * spectrum[k]);
  c[0] *= 0.5;
  return c;
}

[[noreturn]] inline void refuse_degree(const char* what) {
  throw ChebyshevDegreeError(std::string(what) + ": needs a Chebyshev degree above " +
                              std::to_string(kMaxChebyshevDegree) + " (t beta lambda_max too large); take a smaller h");
}

}  // namespace detail

// The series of g(y) on [-1, 1]: the number of samples doubles until the upper half
// of the interpolant's coefficients is below the tolerance (then aliasing is too,
// the true coefficients falling faster than geometrically), and the series is cut
// at the lowest degree whose dropped tail stays below kChebyshevTolerance max |g|.
// tolerance: the dropped tail relative to max |g| (kChebyshevTolerance unless a caller needs less).
template <class G>
ChebyshevSeries chebyshev_series(G g, const char* what, double tolerance = kChebyshevTolerance) {
  for (int n = 32;; n *= 2) {
    std::vector<double> values(n);
    double scale = 0.0;
    for (int j = 0; j < n; ++j) {
      values[j] = g(std::cos(M_PI * (j + 0.5) / n));
      if (!std::isfinite(values[j])) throw std::invalid_argument(std::string(what) + ": not finite on the spectrum");
      scale = std::max(scale, std::abs(values[j]));
    }
    ChebyshevSeries s;
    s.scale = scale;
    if (scale == 0.0) {
      // Zero at every sample: g is zero, or so steep that the samples missed it. The points never reach
      // the ends of [-1, 1], where exp(-t(alpha + beta lambda)) is largest (lambda = 0): at t beta L above
      // about 1.25e6 its 32 samples all underflowed, and the zero series set every mode's p to 0, the
      // lowest (whose factor is about 1) too. Then more samples are taken, up to the degree bound.
      if (g(-1.0) == 0.0 && g(1.0) == 0.0) {
        s.c = {0.0};
        return s;
      }
      if (n > kMaxChebyshevDegree) detail::refuse_degree(what);
      continue;
    }
    std::vector<double> c = detail::chebyshev_interpolant(values);
    // Each computed coefficient carries rounding of about eps sqrt(N) max |g| (a sum of N
    // terms up to max |g|). Once the true coefficients fall below that, the upper half is
    // noise whose sum grows like N sqrt(N) eps and may never reach the tolerance (t beta L
    // above about 10^4 needs N in the thousands): then "the upper half is at the noise
    // level" is the convergence test, and coefficients below the noise are dropped freely.
    const double noise = 4.0 * std::numeric_limits<double>::epsilon() * std::sqrt(static_cast<double>(n)) * scale;
    double upper = 0.0, upper_max = 0.0;
    for (int k = n / 2; k < n; ++k) {
      upper += std::abs(c[k]);
      upper_max = std::max(upper_max, std::abs(c[k]));
    }
    const bool below_tolerance = upper <= 0.5 * tolerance * scale;
    if (!below_tolerance && upper_max > noise) {
      if (n > kMaxChebyshevDegree) detail::refuse_degree(what);
      continue;
    }
    const double floor = below_tolerance ? 0.0 : noise;
    int degree = n - 1;
    double dropped = 0.0;
    while (degree > 0) {
      const double excess = std::max(0.0, std::abs(c[degree]) - floor);
      if (dropped + excess > tolerance * scale) break;
      dropped += excess;
      --degree;
    }
    c.resize(degree + 1);
    s.c = std::move(c);
    return s;
  }
}

// y = sum_k c_k T_k(Y) x, Y = (2/L) B - I, by the three-term recurrence
// T_{k+1} = 2 Y T_k - T_{k-1} (one product with B per degree, through
// apply_b(in, out), out = B in, out never aliasing in). t0, t1, t2 are scratch of
// x's size; y must not alias x.
template <class ApplyB, class X, class Y, class V>
void chebyshev_apply(const ChebyshevSeries& s, double bound, ApplyB&& apply_b, const X& x, Y& y, V& t0, V& t1,
                     V& t2) {
  const auto& c = s.c;
  const int degree = s.degree();
  y = c[0] * x;
  if (degree == 0) return;
  const double two_over_l = 2.0 / bound;
  t0 = x;
  apply_b(t0, t1);
  t1 = two_over_l * t1 - t0;  // T_1(Y) x
  y += c[1] * t1;
  for (int k = 2; k <= degree; ++k) {
    apply_b(t1, t2);
    t2 = (2.0 * two_over_l) * t2 - 2.0 * t1 - t0;  // T_k(Y) x
    y += c[k] * t2;
    t0.swap(t1);  // (t0, t1) <- (t1, t2): pointer swaps, no copies
    t1.swap(t2);
  }
}

}  // namespace raydamp
