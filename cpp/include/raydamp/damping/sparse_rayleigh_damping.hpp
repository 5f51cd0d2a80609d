// Rayleigh damping C = alpha M + beta K of a sparse linear structure, with eps = 1:
// the damping force on the momenta is -A p, A = C M^{-1} = alpha I + beta B, B = K M^{-1}
// (M^{-1} acts first: p -> velocity -> force). B is similar to the symmetric
// M^{-1/2} K M^{-1/2}, so its spectrum is real, in [0, lambda_max], the squared
// circular frequencies; B is self-adjoint in the M^{-1} inner product.
// The exact flows (paper section 3, q frozen) are functions of B,
//   damp:      p <- exp(-tA) p = e^{-t alpha} exp(-t beta B) p,
//   kick_damp: p <- exp(-tA) p - t phi1(-tA) grad V,
// evaluated by Chebyshev expansions on [0, L] (chebyshev.hpp), L an upper bound of
// lambda_max (spectral_bound.hpp): only products with K and solves with M, never a
// dense matrix. Coefficients are cached per sub-step length t (a run uses two or three).
// Thermal noise (the OU flow of damp, covariance kT (M - E M E^T), E = exp(-tA)): with
// A = C M^{-1} and A^T = M^{-1} C, M - E M E^T = (I - e^{-2tA}) M = 2t phi1(-2tA) C, so with
// C = R R^T (a sparse Cholesky factor, once per run) a noise factor is
//   N = psi(A) R,  psi(x) = sqrt(2t phi1(-2tx)) = sqrt((1 - e^{-2tx}) / x)
// (N N^T = psi(A) C psi(A)^T = psi(A)^2 C, as f(A) C = C f(A)^T). psi is analytic near [0, inf)
// (its branch points are at x = +-i pi k / t, k >= 1) and bounded by sqrt(2t), so its Chebyshev
// series in B converges like exp's (degree equal for t beta L <~ 1, about 1.7x for 10^2 .. 10^4),
// with no branch point at x = 0: the symmetric factor L (I - e^{-2tS})^{1/2} (S = L^{-1} C L^{-T})
// has one there, where polynomial or Lanczos approximations converge only like the square root of
// S's condition number (alpha = 0, a 200-DOF chain: Lanczos needs all 200 iterations for 1e-10
// where this series needs 9 products; tests/test_thermal_structure.py). R needs C positive
// definite: alpha > 0 or K positive definite (a supported structure); with alpha = 0 and a
// singular K there is no noise factor and a temperature is refused.
// solve_shifted (rks with a diagonally implicit tableau) is
//   (I + cA)^{-1} x = M ((1 + c alpha) M + c beta K)^{-1} x,
// one sparse Cholesky factorisation per distinct c (per run: h a_ii, and the last step's).
// A small structure (n <= the dense limit, kMaxDenseDim unless the caller says otherwise) has its
// modes instead: with M = L L^T and L^{-1} K L^{-T} = V Lambda V^T, every function of A is
// f(A) = L V f(alpha + beta Lambda) V^T L^{-1}, so a flow is one n x n product with a matrix made
// once per sub-step length, exact, where the Chebyshev sum costs its degree in products with K and
// solves with M (a 10-storey frame: 430 ns a step of 3s, most of it there). The noise keeps its
// Chebyshev series in either case (the same draws give the same noise).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "raydamp/damping/chebyshev.hpp"
#include "raydamp/mass/sparse_mass.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/system/small_dense.hpp"
#include "raydamp/thread_scratch.hpp"

namespace raydamp {

template <class Mass>
class SparseRayleighDamping {
 public:
  // The noise N xi is within this of the exact one, relative, in the M^{-1} norm (the kinetic
  // energy's): the noise series leaves out at most kNoiseTolerance / sqrt(1 + 2 t rho) of max psi,
  // and max psi / min psi <= sqrt(1 + 2 t rho) on [alpha, rho] (rho = rate_bound()).
  static constexpr double kNoiseTolerance = 1e-10;

  // A small structure's modes: A = from_modes diag(rates) to_modes.
  struct Modes {
    Eigen::MatrixXd from_modes;  // L V
    Eigen::MatrixXd to_modes;    // V^T L^{-1}
    Eigen::VectorXd lambda;      // the eigenvalues of K M^{-1} (squared circular frequencies)
    Eigen::VectorXd rates;       // alpha + beta lambda, those of A
    Eigen::MatrixXd a;           // A itself (rate())

    // f(A) = from_modes diag(f(rates)) to_modes.
    template <class F>
    Eigen::MatrixXd function(F f) const {
      Eigen::VectorXd d(rates.size());
      for (Eigen::Index i = 0; i < rates.size(); ++i) d[i] = f(rates[i]);
      return from_modes * d.asDiagonal() * to_modes;
    }
  };

  // The flows of one sub-step length t: Chebyshev series in the variable of B's spectrum, or,
  // for a small structure, the matrices themselves (its Chebyshev series then made only on request).
  struct Series {
    double t = 0.0;
    Eigen::MatrixXd exp_matrix;     // exp(-tA) (a small structure)
    Eigen::MatrixXd t_phi1_matrix;  // t phi1(-tA) (a small structure)
    mutable std::once_flag chebyshev_once;
    mutable ChebyshevSeries exp;     // exp(-t (alpha + beta lambda))
    mutable ChebyshevSeries t_phi1;  // t phi1(-t (alpha + beta lambda))
    // psi(alpha + beta lambda) of the noise factor, made at the first noisy flow of this length.
    mutable std::once_flag noise_once;
    mutable ChebyshevSeries noise;
  };
  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();
    std::shared_ptr<const Series> series;
    double noise_scale = 0.0;  // beta = 0: sqrt(1 - e^{-2 alpha t}), N = noise_scale M^{1/2}
  };

  // bound: an upper bound of the spectrum of B (the caller estimates it once). dense_limit: the largest n
  // whose flows are dense (the modes); a test sets 0 to compare against the Chebyshev flows.
  SparseRayleighDamping(double alpha, double beta, std::shared_ptr<const SparseRowMajor> stiffness, Mass mass,
                        double bound, int dense_limit = kMaxDenseDim)
      : alpha_(alpha), beta_(beta), bound_(bound > 0.0 ? bound : 1.0), k_(std::move(stiffness)),
        mass_(std::move(mass)), caches_(std::make_shared<Caches>()) {
    if (!(alpha >= 0.0) || !std::isfinite(alpha)) throw std::invalid_argument("alpha: must be finite and >= 0");
    if (!(beta >= 0.0) || !std::isfinite(beta)) throw std::invalid_argument("beta: must be finite and >= 0");
    if (mass_.size() <= std::min(dense_limit, kMaxDenseDim)) modes_ = make_modes();
  }

  // Whether the flows are dense (a small structure).
  bool dense() const { return modes_ != nullptr; }
  // The modes of a dense one (null otherwise).
  const Modes* modes() const { return modes_.get(); }

  double alpha() const { return alpha_; }
  double beta() const { return beta_; }
  double spectral_bound() const { return bound_; }           // L >= lambda_max(K M^{-1})
  double rate_bound() const { return alpha_ + beta_ * bound_; }  // >= the spectral radius of A

  Factors factors(double t) const { return {t, series(t), std::sqrt(std::max(0.0, -std::expm1(-2.0 * alpha_ * t)))}; }

  std::shared_ptr<const Series> series(double t) const {
    {
      std::lock_guard<std::mutex> lock(caches_->mutex);
      if (auto cached = find_series(t)) return cached;
    }
    // Made outside the lock, which every run of the model shares: a kink-located run asks for a new length at
    // every yield or unloading, and two threads' runs then waited on each other's modal products.
    auto fresh = std::make_shared<Series>();
    fresh->t = t;
    if (modes_) {
      fresh->exp_matrix = modes_->function([t](double r) { return std::exp(-t * r); });
      fresh->t_phi1_matrix = modes_->function([t](double r) { return t * phi1(-t * r); });
    } else {
      make_chebyshev(*fresh);
    }
    std::shared_ptr<const Series> made = std::move(fresh);
    std::lock_guard<std::mutex> lock(caches_->mutex);
    if (auto cached = find_series(t)) return cached;  // made by another run meanwhile: the same numbers
    if (caches_->series.size() >= kCachedLengths) caches_->series.erase(caches_->series.begin());
    caches_->series.push_back(made);
    return made;
  }

  // The series of length t with its Chebyshev series made (a small structure's are made here, on request:
  // chebyshev_degrees, the default method's choice).
  std::shared_ptr<const Series> chebyshev(double t) const {
    std::shared_ptr<const Series> s = series(t);
    make_chebyshev(*s);
    return s;
  }

  // p <- exp(-tA) p.
  template <class Q, class P>
  void decay(const Q&, const Factors& f, P& p) const {
    Eigen::VectorXd& y = thread_scratch(kScratchSum, p.size());
    if (modes_) y.noalias() = f.series->exp_matrix.lazyProduct(p);  // inline loops, no gemv call: a few DOF
    else apply(f.series->exp, p, y);
    p = y;
  }

  // p <- exp(-tA) p - t phi1(-tA) g.
  template <class Q, class G, class P>
  void decay_affine(const Q&, const Factors& f, const G& g, P& p) const {
    Eigen::VectorXd& y = thread_scratch(kScratchSum, p.size());
    if (modes_) {
      y.noalias() = f.series->exp_matrix.lazyProduct(p);
      y.noalias() -= f.series->t_phi1_matrix.lazyProduct(g);
      p = y;
      return;
    }
    Eigen::VectorXd& z = thread_scratch(kScratchSum2, p.size());
    apply(f.series->exp, p, y);
    apply(f.series->t_phi1, g, z);
    p = y - z;
  }

  // Thermal noise: with alpha M damping alone (beta = 0) A = alpha I, so the OU flow's noise is
  // sqrt(kT (1 - e^{-2 alpha t})) M^{1/2} xi (a root of M: sqrt of a lumped one, the Cholesky factor of a
  // consistent one). With beta K, N xi = psi(A) R xi (the header's comment), which needs C = alpha M + beta K
  // positive definite; has_noise() factorises C on its first call (check_temperature's, before a run).
  bool has_noise() const { return beta_ == 0.0 || noise_root() != nullptr; }
  template <class Q, class M, class X, class P>
  void add_noise(const Q&, const Factors& f, const M& mass, double sigma, const X& xi, P& p) const {
    if (beta_ == 0.0) {
      mass.add_root_product(sigma * f.noise_scale, xi, p);
      return;
    }
    const SparseCholesky* root = noise_root();
    if (!root) throw std::invalid_argument(kNoNoise);
    Eigen::VectorXd& y = thread_scratch(kScratchSum, p.size());
    y.setZero();
    root->add_root_product(1.0, xi, y);  // R xi, covariance C
    Eigen::VectorXd& z = thread_scratch(kScratchSum2, p.size());
    apply(noise_series(*f.series), y, z);
    p += sigma * z;
  }

  // The Chebyshev series of psi for the length of s (made once per length).
  const ChebyshevSeries& noise_series(const Series& s) const {
    std::call_once(s.noise_once, [&] {
      const double half = 0.5 * bound_, a = alpha_, b = beta_, t = s.t;
      // 2t phi1(-2tx) = (1 - e^{-2tx}) / x, at most 2t, at x = alpha + beta lambda in [alpha, rho].
      auto psi = [=](double y) { return std::sqrt(2.0 * t * phi1(-2.0 * t * (a + b * half * (1.0 + y)))); };
      const double tolerance = std::min(kChebyshevTolerance, kNoiseTolerance / std::sqrt(1.0 + 2.0 * t * rate_bound()));
      s.noise = chebyshev_series(psi, "thermal noise", tolerance);
    });
    return s.noise;
  }

  static constexpr const char* kNoNoise =
      "temperature: a LinearStructure with beta K damping and alpha = 0 has thermal noise only for a positive "
      "definite K (a supported structure; the noise factor is a Cholesky factor of C = beta K); add alpha M "
      "damping or supports";

  // out = A p = alpha p + beta K M^{-1} p (out must not alias p).
  template <class Q, class P, class O>
  void rate(const Q&, const P& p, O& out) const {
    if (modes_) {
      out.noalias() = modes_->a * p;
      return;
    }
    Eigen::VectorXd& v = thread_scratch(kScratchProduct, p.size());
    mass_.velocity(p, v);
    out.noalias() = *k_ * v;
    out = beta_ * out + alpha_ * p;
  }

  // x <- (I + cA)^{-1} x.
  template <class Q, class X>
  void solve_shifted(const Q&, double c, X& x) const {
    if (beta_ == 0.0) {
      x /= 1.0 + c * alpha_;
      return;
    }
    if (modes_) {
      Eigen::VectorXd& y = thread_scratch(kScratchProduct, x.size());
      y.noalias() = modes_->to_modes * x;
      y.array() /= 1.0 + c * modes_->rates.array();
      x.noalias() = modes_->from_modes * y;
      return;
    }
    const auto chol = shifted(c);
    Eigen::VectorXd& y = thread_scratch(kScratchProduct, x.size());
    chol->solve(x, y);
    mass_.multiply(y, x);
  }

 private:
  static constexpr std::size_t kCachedLengths = 16, kCachedShifts = 4;
  struct Caches {
    std::mutex mutex;
    std::vector<std::shared_ptr<const Series>> series;
    std::vector<std::pair<double, std::shared_ptr<const SparseCholesky>>> shifted;
    std::once_flag root_once;
    std::unique_ptr<const SparseCholesky> root;  // C = R R^T (beta > 0 and C positive definite), else null
  };

  // The cached series of length t, or null; the caller holds caches_->mutex.
  std::shared_ptr<const Series> find_series(double t) const {
    for (const auto& s : caches_->series)
      if (s->t == t) return s;
    return nullptr;
  }

  // The Chebyshev series of s's length, once (the caller holds no lock: chebyshev_series may take a while).
  void make_chebyshev(const Series& s) const {
    std::call_once(s.chebyshev_once, [&] {
      const double t = s.t;
      // lambda = L (1 + y) / 2 maps [-1, 1] onto [0, L].
      const double half = 0.5 * bound_, a = alpha_, b = beta_;
      auto rate = [=](double y) { return a + b * half * (1.0 + y); };
      // The degree needed is about 4.8 sqrt(t beta L) (4789 at t beta L = 1e6), so past 4 sqrt(t beta L) > the
      // bound the series below would refuse anyway, after O(N^2) work at every doubling (0.4 s each): refuse at
      // once. advise's bisection of stability limits meets this refusal dozens of times.
      if (t > 0.0 && 4.0 * std::sqrt(t * b * bound_) > kMaxChebyshevDegree) detail::refuse_degree("damping flow");
      s.exp = chebyshev_series([&](double y) { return std::exp(-t * rate(y)); }, "damping flow");
      s.t_phi1 = chebyshev_series([&](double y) { return t * phi1(-t * rate(y)); }, "kick+damp flow");
    });
  }

  // The modes of M^{-1} K, from dense copies of M and K (n <= kMaxDenseDim).
  std::shared_ptr<const Modes> make_modes() const {
    const Eigen::MatrixXd m = Eigen::MatrixXd(mass_.matrix()), k = Eigen::MatrixXd(SparseColMajor(*k_));
    const Eigen::Index n = m.rows();
    Eigen::LLT<Eigen::MatrixXd> llt(m);
    if (llt.info() != Eigen::Success) throw std::invalid_argument("M: must be positive definite");
    const Eigen::MatrixXd lower = llt.matrixL();
    const Eigen::MatrixXd lower_inverse = llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));
    const Eigen::MatrixXd s = lower_inverse * k * lower_inverse.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (s + s.transpose()));
    if (eig.info() != Eigen::Success) throw std::invalid_argument("K: the eigendecomposition of M^{-1} K failed");
    auto modes = std::make_shared<Modes>();
    modes->from_modes = lower * eig.eigenvectors();
    modes->to_modes = eig.eigenvectors().transpose() * lower_inverse;
    modes->lambda = eig.eigenvalues();
    modes->rates = (alpha_ + beta_ * modes->lambda.array()).matrix();
    modes->a = modes->from_modes * modes->rates.asDiagonal() * modes->to_modes;
    return modes;
  }

  // R, C = alpha M + beta K = R R^T, factorised on the first call; null when C is not positive definite.
  const SparseCholesky* noise_root() const {
    std::call_once(caches_->root_once, [&] {
      const SparseColMajor c = alpha_ * mass_.matrix() + beta_ * SparseColMajor(*k_);
      try {
        caches_->root = std::make_unique<const SparseCholesky>(c, "C");
      } catch (const std::invalid_argument&) {
        caches_->root.reset();
      }
    });
    return caches_->root.get();
  }

  // y = sum_k c_k T_k(Y) x with B x = K M^{-1} x.
  template <class X>
  void apply(const ChebyshevSeries& s, const X& x, Eigen::VectorXd& y) const {
    const Eigen::Index n = x.size();
    auto apply_b = [&](const Eigen::VectorXd& in, Eigen::VectorXd& out) {
      Eigen::VectorXd& v = thread_scratch(kScratchProduct, n);
      mass_.velocity(in, v);
      out.noalias() = *k_ * v;
    };
    chebyshev_apply(s, bound_, apply_b, x, y, thread_scratch(kScratchT0, n), thread_scratch(kScratchT1, n),
                    thread_scratch(kScratchT2, n));
  }

  std::shared_ptr<const SparseCholesky> shifted(double c) const {
    std::lock_guard<std::mutex> lock(caches_->mutex);
    for (const auto& [key, chol] : caches_->shifted)
      if (key == c) return chol;
    const SparseColMajor a = (1.0 + c * alpha_) * mass_.matrix() + (c * beta_) * SparseColMajor(*k_);
    auto made = std::make_shared<const SparseCholesky>(a, "M + c (alpha M + beta K)");
    if (caches_->shifted.size() >= kCachedShifts) caches_->shifted.erase(caches_->shifted.begin());
    caches_->shifted.emplace_back(c, made);
    return made;
  }

  double alpha_, beta_, bound_;
  std::shared_ptr<const SparseRowMajor> k_;
  Mass mass_;
  std::shared_ptr<Caches> caches_;
  std::shared_ptr<const Modes> modes_;  // a small structure's (null: the Chebyshev flows)
};

}  // namespace raydamp
