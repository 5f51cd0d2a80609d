// Dashpots: D(q) = sum_i c_i grad g_i(q) grad g_i(q)^T, each resisting the rate of
// change of a function g_i(q) (a spring's length, an angle, a coordinate). PSD by
// construction. The gradients come from one compiled function writing k rows of n.
// - One dashpot: A = eps D M^{-1} = u w^T with u = eps c grad g, w = M^{-1} grad g has
//   rank one and the single nonzero eigenvalue a = w.u, so
//     exp(-tA) = I - t phi1(-ta) u w^T,   t phi1(-tA) = t I - t^2 phi2(-ta) u w^T
//   (closed form, exact for a = 0 too). The elastic pendulum is one dashpot on |q|.
// - Several dashpots need not commute: the exact flow of their sum from the
//   eigendecomposition of S = eps L^{-1} D(q) L^{-T} at the frozen q (n <= kMaxDenseDim).
#pragma once

#include <Eigen/Eigenvalues>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/damping/decay_factors.hpp"
#include "raydamp/damping/mass_cholesky.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/system/compiled_function.hpp"
#include "raydamp/system/small_dense.hpp"

namespace raydamp {

class DamperDamping {
 public:
  // Nothing depends on t alone (A depends on q): the factors carry only t.
  using Factors = DecayFactors;

  DamperDamping(const Eigen::MatrixXd& mass, double eps, std::vector<double> coefficients, CompiledFunction gradients)
      : eps_(eps), c_(std::move(coefficients)), gradients_(gradients), n_(static_cast<int>(mass.rows())) {
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
  }

  Factors factors(double t) const { Factors f; f.t = t; return f; }

  template <class Q, class P>
  void decay(const Q& q, const Factors& f, P& p) const {
    Buffer g;
    evaluate(q, g);
    if (c_.size() == 1) {
      const Rank1 r = rank1(g);
      p -= (f.t * phi1(-f.t * r.a) * r.w.dot(p)) * r.u;
      return;
    }
    SmallVector zero = SmallVector::Zero(n_);
    modal(g, f.t, p, zero, p);
  }

  template <class Q, class G, class P>
  void decay_affine(const Q& q, const Factors& f, const G& grad_v, P& p) const {
    Buffer g;
    evaluate(q, g);
    const double t = f.t;
    if (c_.size() == 1) {
      const Rank1 r = rank1(g);
      const double x = -t * r.a;
      p += (t * t * phi2(x) * r.w.dot(grad_v) - t * phi1(x) * r.w.dot(p)) * r.u - t * grad_v;
      return;
    }
    modal(g, t, p, grad_v, p);
  }

  // out = A p = eps sum_i c_i grad g_i (grad g_i . M^{-1} p).
  template <class Q, class P, class O>
  void rate(const Q& q, const P& p, O& out) const {
    Buffer g;
    evaluate(q, g);
    SmallVector v = inverse_ * p;
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
    evaluate(q, g);
    if (c_.size() == 1) {
      const Rank1 r = rank1(g);
      x -= (c * r.w.dot(x) / (1.0 + c * r.a)) * r.u;
      return;
    }
    SmallVector lambda;
    SmallMatrix vectors;
    eigen(g, lambda, vectors);
    const SmallVector lx = lower_inverse_ * x;
    SmallVector y = vectors.transpose() * lx;
    y.array() /= 1.0 + c * lambda.array();
    const SmallVector vy = vectors * y;
    x.noalias() = lower_ * vy;
  }

  int dampers() const { return static_cast<int>(c_.size()); }

 private:
  using Buffer = std::array<double, kMaxDenseDim * kMaxDampers>;  // k rows of n gradient entries
  struct Rank1 {
    SmallVector u, w;
    double a;
  };

  template <class Q>
  void evaluate(const Q& q, Buffer& g) const { gradients_(g.data(), q.data()); }

  Eigen::Map<const Eigen::VectorXd> row(const Buffer& g, std::size_t i) const {
    return Eigen::Map<const Eigen::VectorXd>(g.data() + i * n_, n_);
  }

  Rank1 rank1(const Buffer& g) const {
    const auto grad = row(g, 0);
    Rank1 r;
    r.u = (eps_ * c_[0]) * grad;
    r.w = inverse_ * grad;
    r.a = r.w.dot(r.u);
    return r;
  }

  // S = eps sum_i c_i (L^{-1} grad g_i)(L^{-1} grad g_i)^T = V diag(lambda) V^T.
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

  // out = exp(-tA) p - t phi1(-tA) grad_v, through the modes of S.
  template <class P, class G, class O>
  void modal(const Buffer& g, double t, const P& p, const G& grad_v, O& out) const {
    SmallVector lambda;
    SmallMatrix vectors;
    eigen(g, lambda, vectors);
    const SmallVector lp = lower_inverse_ * p, lg = lower_inverse_ * grad_v;
    SmallVector y = vectors.transpose() * lp;
    const SmallVector z = vectors.transpose() * lg;
    for (int i = 0; i < n_; ++i) {
      const double x = -t * lambda[i];
      y[i] = std::exp(x) * y[i] - t * phi1(x) * z[i];
    }
    const SmallVector vy = vectors * y;
    out.noalias() = lower_ * vy;
  }

  double eps_;
  std::vector<double> c_;
  CompiledFunction gradients_;
  int n_;
  SmallMatrix lower_, lower_inverse_, inverse_;  // L, L^{-1}, M^{-1} (M = L L^T)
};

}  // namespace raydamp
