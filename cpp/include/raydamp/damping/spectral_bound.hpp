// An upper bound of the spectrum of M^{-1} K (the squared circular frequencies of a
// linear structure; the same as that of K M^{-1}), for the Chebyshev interval.
// Lanczos on M^{-1} K, which is self-adjoint in the M inner product: its largest
// Ritz value theta converges to lambda_max from below, and an eigenvalue lies within
// the residual |beta_k s_k| of it. The bound is (theta + residual) times a safety
// margin; a slight underestimate costs little anyway, since the Chebyshev series of
// an entire function also converges just outside [0, L]. A lumped M adds the
// Gershgorin bound max_i sum_j |K_ij| / m_i, which is rigorous, and the smaller wins.
#pragma once

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <vector>

namespace raydamp {

inline constexpr int kLanczosSteps = 60;
inline constexpr double kSpectralMargin = 1.05;

// mass: velocity(p, v) = M^{-1} p and multiply(x, out) = M x.
template <class Mass, class Stiffness>
double lanczos_upper_bound(const Stiffness& k, const Mass& mass, int steps = kLanczosSteps) {
  const Eigen::Index n = k.rows();
  Eigen::VectorXd v(n), v_prev = Eigen::VectorXd::Zero(n), w(n), kv(n), mw(n);
  // A start with a component along every mode: all ones plus an irregular part.
  for (Eigen::Index i = 0; i < n; ++i) v[i] = 1.0 + 0.5 * std::sin(1.0 + 7.0 * i);
  mass.multiply(v, mw);
  v /= std::sqrt(v.dot(mw));
  std::vector<double> diagonal, off;
  double beta = 0.0;
  for (int j = 0; j < std::min<Eigen::Index>(steps, n); ++j) {
    kv.noalias() = k * v;
    const double a = v.dot(kv);  // <v, M^{-1} K v>_M
    mass.velocity(kv, w);
    w -= a * v + beta * v_prev;
    diagonal.push_back(a);
    mass.multiply(w, mw);
    beta = std::sqrt(std::max(0.0, w.dot(mw)));
    off.push_back(beta);
    if (beta <= 1e-14 * std::max(std::abs(a), 1e-300)) break;  // an invariant subspace: exact
    v_prev.swap(v);
    v = w / beta;
  }
  const Eigen::Index m = static_cast<Eigen::Index>(diagonal.size());
  Eigen::VectorXd d = Eigen::Map<Eigen::VectorXd>(diagonal.data(), m);
  Eigen::VectorXd e = m > 1 ? Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(off.data(), m - 1)) : Eigen::VectorXd(0);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> tri;
  tri.computeFromTridiagonal(d, e, Eigen::ComputeEigenvectors);
  const double theta = tri.eigenvalues()[m - 1];
  const double residual = std::abs(off[m - 1] * tri.eigenvectors()(m - 1, m - 1));
  return kSpectralMargin * (std::max(theta, 0.0) + residual);
}

// max_i sum_j |K_ij| / m_i: every eigenvalue of M^{-1} K lies in a Gershgorin disc of it.
template <class Stiffness>
double gershgorin_bound(const Stiffness& k, const Eigen::VectorXd& lumped_mass) {
  Eigen::VectorXd row = Eigen::VectorXd::Zero(k.rows());
  for (Eigen::Index outer = 0; outer < k.outerSize(); ++outer)
    for (typename Stiffness::InnerIterator it(k, outer); it; ++it) row[it.row()] += std::abs(it.value());
  return (row.array() / lumped_mass.array()).maxCoeff();
}

}  // namespace raydamp
