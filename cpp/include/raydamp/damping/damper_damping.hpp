// Dashpots: D(q) = sum_i c_i grad g_i(q) grad g_i(q)^T, each resisting the rate of
// change of a function g_i(q) (a spring's length, an angle, a coordinate). PSD by
// construction. The gradients come from one compiled function writing k rows of n.
// - One dashpot: A = eps D M^{-1} = u w^T with u = eps c grad g, w = M^{-1} grad g has
//   rank one and the single nonzero eigenvalue eps c a, a = grad g^T M^{-1} grad g, so
//     exp(-tA) = I - t phi1(-t eps c a) u w^T,
//     t phi1(-tA) = t I - t^2 phi2(-t eps c a) u w^T
//   (closed form, exact for a = 0 too). The elastic pendulum is one dashpot on |q|.
//   A dashpot on a distance (|q|, |q_i - q_j|) has a constant a (1/m, 1/m_i + 1/m_j):
//   python/raydamp/systems/system/dashpot_norm.py proves that symbolically and passes a, and
//   then phi1 and phi2 are taken once per sub-step length in factors(t), as the
//   built-in radial damping does, so a flow at a new q costs the gradient call and
//   two dot products (3s on the elastic pendulum: the dot w.grad g, the phi1 series
//   or expm1 and its division were a fifth of a step). Otherwise (norm NaN) they are
//   taken at every new q.
//   With a constant a, exp(-tA) p may also take a compiled projection P(q, u) =
//   grad g (grad g^T M^{-1} u) instead of the gradient: p - eps c t phi1(x) P(q, p).
//   Built symbolically (compile.py), P of a distance dashpot has no square root,
//   (q.u) q / |q|^2 as the built-in radial damping writes it, where the gradient
//   q / |q| puts a sqrt and a division on the step's serial chain (3s's damp on the
//   elastic pendulum as a System: benchmarks/bench_system.py). The affine flow keeps
//   the gradient: there the dashpot's call runs beside grad V's, where P(q, .) of a
//   combination with grad V would have to wait for it.
// - Several dashpots need not commute: the exact flow of their sum from the
//   eigendecomposition of S = eps L^{-1} D(q) L^{-T} at the frozen q (n <= kMaxDenseDim).
#pragma once

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/damping/mass_cholesky.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/system/compiled_function.hpp"
#include "raydamp/system/small_dense.hpp"

namespace raydamp {

class DamperDamping {
 public:
  // The dashpots at one q, with the functions of t A the flows of length t need.
  struct AtConfiguration {
    std::array<double, kMaxDenseDim> q;  // where they were evaluated (the cache key)
    bool valid = false;
    // One dashpot: A = u w^T with u = eps c grad g, w = M^{-1} grad g; x = -t eps c a
    // and the scalars k1 = eps c t phi1(x), k2 = eps c t^2 phi2(x) (the second only
    // for kick+damp, so computed when first needed), both times 1/m when M = m I
    // (then w = grad g / m is never formed). Constant a: x, k1 set once in factors(t),
    // k2 once when first needed; neither changes with q.
    // Plain arrays and Maps: no temporaries in the step loop.
    std::array<double, kMaxDenseDim> grad, w;
    double x = std::numeric_limits<double>::quiet_NaN(), k1 = 0.0, k2 = 0.0;
    double k1_projected = 0.0;  // eps c t phi1(x), for P (which has M^{-1} in it)
    bool has_k2 = false;
    // Several: exp(-tA) = L V diag(decay) V^T L^{-1}; t phi1(-tA) likewise with t_phi1s.
    SmallMatrix vectors;
    SmallVector decay, t_phi1s, rates;  // rates: the eigenvalues of S, for the noise
  };

  // What a workspace keeps per sub-flow length t: t, and the dashpots at the last q a
  // flow of that length saw. The sub-flow that ends a step and the one that starts the
  // next act at the same q (3s: damp h/2 | damp h/2; 2s: kick_damp h/2 | kick_damp h/2),
  // so the second reuses the gradients, phi1 and any eigendecomposition of the first.
  // Mutable: the flows take the factors by const reference, and this is a cache of
  // pure functions of (q, t), private to one workspace (one run, one thread).
  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();
    mutable AtConfiguration at;
  };

  // norm: a = grad g^T M^{-1} grad g of the one dashpot when it is the same at every
  // q (NaN: it varies, or several dashpots).
  // projection: P(q, u) of the one dashpot, (q, u) in, n out; used only with a constant norm.
  template <int = 0>  // instantiated only where used: see raydamp.hpp
  DamperDamping(const Eigen::MatrixXd& mass, double eps, std::vector<double> coefficients, CompiledFunction gradients,
                double norm = std::numeric_limits<double>::quiet_NaN(), CompiledFunction projection = {})
      : eps_(eps), c_(std::move(coefficients)), gradients_(gradients), n_(static_cast<int>(mass.rows())), norm_(norm),
        projection_(projection) {
    const int k = static_cast<int>(c_.size());
    if (k < 1 || k > kMaxDampers)
      throw std::invalid_argument("damping.dampers: between 1 and " + std::to_string(kMaxDampers) +
                                  " dashpots, got " + std::to_string(k));
    if (n_ > kMaxDenseDim)
      throw std::invalid_argument("damping.dampers: dashpots are supported up to n = " +
                                  std::to_string(kMaxDenseDim) + " coordinates (this system has " +
                                  std::to_string(n_) + ")");
    if (!gradients_) throw std::invalid_argument("damping.dampers: no compiled gradient");
    const MassCholesky chol(mass);
    lower_ = chol.lower;
    lower_inverse_ = chol.lower_inverse;
    inverse_ = chol.inverse;
    // M = m I (the common case: particles in Cartesian coordinates) makes M^{-1} g a scaling.
    const double m = mass(0, 0);
    scalar_inverse_ = mass.isApprox(m * Eigen::MatrixXd::Identity(n_, n_), 0.0) ? 1.0 / m : 0.0;
    eps_c_ = eps_ * c_[0];
    if (!std::isnan(norm_) && (k != 1 || !(norm_ >= 0.0) || !std::isfinite(norm_)))
      throw std::invalid_argument("damping.dampers: a constant norm needs one dashpot and a finite a >= 0, got " +
                                  std::to_string(norm_));
    if (projection_ && !constant_norm())
      throw std::invalid_argument("damping.dampers: a compiled projection needs one dashpot with a constant norm");
  }

  // The flows of length t. With a constant a, x and k1 of every q are known now; k2
  // only kick+damp needs, so decay_affine takes it when first asked (a composed 3s
  // changes t at every damping sub-flow, and then factors(t) runs each time).
  Factors factors(double t) const {
    Factors f;
    f.t = t;
    if (constant_norm()) {
      f.at.x = -t * eps_c_ * norm_;
      const double t_phi1 = t * phi1(f.at.x);
      f.at.k1 = scaled(t_phi1);
      f.at.k1_projected = eps_c_ * t_phi1;
    }
    return f;
  }

  bool constant_norm() const { return !std::isnan(norm_); }
  bool projects() const { return static_cast<bool>(projection_); }

  template <class Q, class P>
  void decay(const Q& q, const Factors& f, P& p) const {
    constexpr int N = P::RowsAtCompileTime;
    if (projection_) {
      std::array<double, kMaxDenseDim> pu;
      project<N>(q, p, pu);
      p -= f.at.k1_projected * map<N>(pu);
      return;
    }
    const AtConfiguration& at = evaluate(q, f);
    if (c_.size() == 1) {
      const auto grad = map<N>(at.grad);
      if (scalar_inverse_ != 0.0) p -= (at.k1 * grad.dot(p)) * grad;
      else p -= (at.k1 * map<N>(at.w).dot(p)) * grad;
      return;
    }
    modal_apply(at, p, static_cast<const P*>(nullptr), p);
  }

  template <class Q, class G, class P>
  void decay_affine(const Q& q, const Factors& f, const G& grad_v, P& p) const {
    constexpr int N = P::RowsAtCompileTime;
    AtConfiguration& at = evaluate(q, f);
    if (c_.size() == 1) {
      if (!at.has_k2) {
        at.k2 = scaled(f.t * f.t * phi2(at.x));
        at.has_k2 = true;
      }
      const auto grad = map<N>(at.grad);
      if (scalar_inverse_ != 0.0) p += (at.k2 * grad.dot(grad_v) - at.k1 * grad.dot(p)) * grad - f.t * grad_v;
      else p += (at.k2 * map<N>(at.w).dot(grad_v) - at.k1 * map<N>(at.w).dot(p)) * grad - f.t * grad_v;
      return;
    }
    modal_apply(at, p, &grad_v, p);
  }

  // p += sigma N xi, N N^T = M - E M E^T (E = exp(-tA) at the frozen q): the noise of the exact
  // Ornstein-Uhlenbeck flow. M - E M E^T = L (I - e^{-2tS}) L^T with S = L^{-1} eps D L^{-T}.
  // One dashpot: S = lambda v v^T, v = L^{-1} grad g / sqrt(a), lambda = eps c a, so
  //   M - E M E^T = (1 - e^{-2 t lambda}) / a grad g grad g^T = 2 t eps c phi1(-2 t lambda) grad g grad g^T,
  // one normal along grad g (exact at a = 0, where grad g = 0). Several: N = L V diag(sqrt(1 - e^{-2t lambda_i})) V^T,
  // the root symmetric in the modes: the eigensolver's V is defined up to the signs of its columns (and a rotation
  // within a repeated eigenvalue), and with N = L V diag(...) alone a rounding-level change of q could flip the
  // noise drawn (merged and unmerged steps of one run, 1e-16 apart, drew noise 1.6e-2 apart).
  Eigen::Index noise_count(Eigen::Index n) const { return c_.size() == 1 ? 1 : n; }
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q& q, const Factors& f, const Mass&, double sigma, const X& xi, P& p) const {
    constexpr int N = P::RowsAtCompileTime;
    const AtConfiguration& at = evaluate(q, f);
    if (c_.size() == 1) {
      const auto grad = map<N>(at.grad);
      const double a = scalar_inverse_ != 0.0 ? scalar_inverse_ * grad.squaredNorm() : map<N>(at.w).dot(grad);
      const double x = -2.0 * f.t * eps_c_ * a;
      p += (sigma * std::sqrt(2.0 * f.t * eps_c_ * phi1(x)) * xi[0]) * grad;
      return;
    }
    SmallVector y = at.vectors.transpose() * xi;
    for (int i = 0; i < n_; ++i) y[i] *= std::sqrt(-std::expm1(-2.0 * f.t * at.rates[i]));
    p += sigma * (lower_ * (at.vectors * y));
  }

  // out = A p = eps sum_i c_i grad g_i (grad g_i . M^{-1} p).
  template <class Q, class P, class O>
  void rate(const Q& q, const P& p, O& out) const {
    Buffer g;
    gradients_(g.data(), q.data());
    SmallVector v(n_);
    mass_inverse(p, v);
    out.setZero(n_);
    for (std::size_t i = 0; i < c_.size(); ++i) {
      const auto gi = row(g, i);
      out += (eps_ * c_[i] * gi.dot(v)) * gi;
    }
  }

  // x <- (I + c A)^{-1} x. Rank one: I - c u w^T / (1 + c a) (Sherman-Morrison).
  template <class Q, class X>
  void solve_shifted(const Q& q, double c, X& x) const {
    Buffer g;
    gradients_(g.data(), q.data());
    if (c_.size() == 1) {
      SmallVector u(n_), w(n_);
      const double a = rank_one(g, u, w);
      x -= (c * w.dot(x) / (1.0 + c * a)) * u;
      return;
    }
    SmallVector lambda(n_);
    SmallMatrix vectors(n_, n_);
    eigen(g, lambda, vectors);
    SmallVector y = vectors.transpose() * (lower_inverse_ * x);
    y.array() /= 1.0 + c * lambda.array();
    x.noalias() = lower_ * (vectors * y);
  }

  int dampers() const { return static_cast<int>(c_.size()); }

 private:
  using Buffer = std::array<double, kMaxDenseDim * kMaxDampers>;  // k rows of n gradient entries

  Eigen::Map<const Eigen::VectorXd> row(const Buffer& g, std::size_t i) const {
    return Eigen::Map<const Eigen::VectorXd>(g.data() + i * n_, n_);
  }

  // q == key, entry by entry (n is small here; a NaN q never matches, so re-evaluates).
  template <class Q>
  bool same(const std::array<double, kMaxDenseDim>& key, const Q& q) const {
    for (int i = 0; i < q.size(); ++i)
      if (key[i] != q[i]) return false;
    return true;
  }

  // a's first n entries as a vector of N rows (N: the state's size at compile time,
  // or Dynamic), so a fixed-size run gets unrolled arithmetic.
  template <int N = Eigen::Dynamic>
  Eigen::Map<const Eigen::Matrix<double, N, 1>> map(const std::array<double, kMaxDenseDim>& a) const {
    return Eigen::Map<const Eigen::Matrix<double, N, 1>>(a.data(), n_);
  }

  // eps c s, times 1/m when M = m I (the k1, k2 of AtConfiguration).
  double scaled(double s) const { return eps_c_ * s * (scalar_inverse_ != 0.0 ? scalar_inverse_ : 1.0); }

  // out = P(q, u), through stack buffers (the model is shared by the threads of an ensemble).
  template <int N, class Q, class U>
  void project(const Q& q, const U& u, std::array<double, kMaxDenseDim>& out) const {
    using Vec = Eigen::Matrix<double, N, 1>;
    std::array<double, 2 * kMaxDenseDim> in;
    Eigen::Map<Vec>(in.data(), n_) = q;  // Eigen copies: no calls to memmove
    Eigen::Map<Vec>(in.data() + n_, n_) = u;
    projection_(out.data(), in.data());
  }

  template <class P, class V>
  void mass_inverse(const P& p, V& v) const {
    if (scalar_inverse_ != 0.0) v = scalar_inverse_ * p;
    else v.noalias() = inverse_ * p;
  }

  // u = eps c grad g, w = M^{-1} grad g; returns a = w.u.
  double rank_one(const Buffer& g, SmallVector& u, SmallVector& w) const {
    const auto grad = row(g, 0);
    u = (eps_ * c_[0]) * grad;
    mass_inverse(grad, w);
    return w.dot(u);
  }

  // S = eps sum_i c_i (L^{-1} grad g_i)(L^{-1} grad g_i)^T = V diag(lambda) V^T.
  template <int = 0>  // instantiated only where used: see raydamp.hpp
  void eigen(const Buffer& g, SmallVector& lambda, SmallMatrix& vectors) const {
    SmallMatrix s = SmallMatrix::Zero(n_, n_);
    for (std::size_t i = 0; i < c_.size(); ++i) {
      const SmallVector y = lower_inverse_ * row(g, i);
      s.noalias() += (eps_ * c_[i]) * y * y.transpose();
    }
    Eigen::SelfAdjointEigenSolver<SmallMatrix> eig(s);
    lambda = eig.eigenvalues().cwiseMax(0.0);  // PSD by construction; clip rounding
    vectors = eig.eigenvectors();
  }

  // The dashpots at q for flows of length f.t: from the cache when q is where the
  // last flow of this length left it.
  template <class Q>
  AtConfiguration& evaluate(const Q& q, const Factors& f) const {
    constexpr int N = Q::RowsAtCompileTime;
    using Vec = Eigen::Matrix<double, N, 1>;
    AtConfiguration& at = f.at;
    if (at.valid && same(at.q, q)) return at;
    Eigen::Map<Vec>(at.q.data(), n_) = q;  // an Eigen copy: no call to memmove
    at.valid = true;
    const double t = f.t;
    if (c_.size() == 1) {
      gradients_(at.grad.data(), q.data());
      const auto grad = map<N>(at.grad);
      auto w = Eigen::Map<Vec>(at.w.data(), n_);
      if (scalar_inverse_ == 0.0) w.noalias() = inverse_ * grad;
      if (constant_norm()) return at;  // x, k1 set by factors(t); k2 by decay_affine, once
      // phi1 at every new q, uncached: keeping it while x repeated cost more in the
      // compare's mispredicted branch than the 5-term series it saved (3s on the
      // elastic pendulum: 71 ns/step with the cache, 67 without).
      const double a = scalar_inverse_ != 0.0 ? scalar_inverse_ * grad.squaredNorm() : w.dot(grad);
      at.x = -t * eps_c_ * a;
      at.k1 = scaled(t * phi1(at.x));
      at.has_k2 = false;
      return at;
    }
    Buffer g;
    gradients_(g.data(), q.data());
    SmallVector lambda(n_);
    at.vectors.resize(n_, n_);
    eigen(g, lambda, at.vectors);
    at.decay.resize(n_);
    at.t_phi1s.resize(n_);
    at.rates = lambda;
    for (int i = 0; i < n_; ++i) {
      const double x = -t * lambda[i];
      at.decay[i] = std::exp(x);
      at.t_phi1s[i] = t * phi1(x);
    }
    return at;
  }

  // out = exp(-tA) p - t phi1(-tA) grad_v (grad_v null: the first term alone),
  // through the modes of S.
  template <class P, class G, class O>
  void modal_apply(const AtConfiguration& at, const P& p, const G* grad_v, O& out) const {
    SmallVector y = at.vectors.transpose() * (lower_inverse_ * p);
    y.array() *= at.decay.array();
    if (grad_v) {
      const SmallVector z = at.vectors.transpose() * (lower_inverse_ * (*grad_v));
      y.array() -= at.t_phi1s.array() * z.array();
    }
    out.noalias() = lower_ * (at.vectors * y);
  }

  double eps_;
  std::vector<double> c_;
  CompiledFunction gradients_;
  int n_;
  double norm_;                  // a of the one dashpot when constant, else NaN
  CompiledFunction projection_;  // P(q, u) of the one dashpot with a constant norm, or unset
  double scalar_inverse_ = 0.0;  // 1/m when M = m I, else 0
  double eps_c_ = 0.0;           // eps c of the first dashpot (the rank-one case)
  SmallMatrix lower_, lower_inverse_, inverse_;  // L, L^{-1}, M^{-1} (M = L L^T)
};

}  // namespace raydamp
