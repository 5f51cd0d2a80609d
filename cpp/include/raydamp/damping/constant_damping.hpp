// A constant dissipation tensor D (diagonal or full, symmetric PSD) with any
// constant mass: A = eps D M^{-1} = L S L^{-1}, S = eps L^{-1} D L^{-T} = V diag(lambda) V^T.
// A does not depend on q, so exp(-tA) and t phi1(-tA) are formed once per
// sub-step length (the Factors below, cached in the Workspace) and each flow is a
// matrix-vector product. Rayleigh damping D = alpha M + beta K of a small model is
// this kind. For n <= kMaxDenseDim.
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "raydamp/damping/mass_cholesky.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/system/small_dense.hpp"

namespace raydamp {

struct ConstantDamping {
  SmallMatrix a;            // A = eps D M^{-1}: the damping force is -A p
  SmallMatrix from_modes;   // L V
  SmallMatrix to_modes;     // V^T L^{-1}
  SmallVector lambda;       // eigenvalues of S (those of A), >= 0

  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();  // the time they are for
    SmallMatrix expm1;   // exp(-tA) - I: a flow adds expm1 p to p (isotropic_damping.hpp says why)
    SmallMatrix t_phi1;  // t phi1(-tA)
    SmallMatrix noise;   // N with N N^T = M - E M^T E^T = L V (I - e^{-2t Lambda}) V^T L^T: the OU flow's noise factor
    mutable SmallVector scratch;  // per workspace, so flows of one run never allocate
  };

  template <int = 0>  // instantiated only where used: see raydamp.hpp
  ConstantDamping(const Eigen::MatrixXd& mass, const Eigen::MatrixXd& d, double eps) {
    const auto n = mass.rows();
    if (n > kMaxDenseDim)
      throw std::invalid_argument("damping: a constant matrix D is supported up to n = " +
                                  std::to_string(kMaxDenseDim) + " coordinates (this system has " +
                                  std::to_string(n) + ")");
    const MassCholesky chol(mass);
    const Eigen::MatrixXd s = eps * chol.lower_inverse * d * chol.lower_inverse.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (s + s.transpose()));
    if (eig.info() != Eigen::Success) throw std::invalid_argument("damping: eigendecomposition of D failed");
    // D is checked PSD before this; eigenvalues at -1e-16 are rounding, not anti-damping.
    lambda = eig.eigenvalues().cwiseMax(0.0);
    from_modes = chol.lower * eig.eigenvectors();
    to_modes = eig.eigenvectors().transpose() * chol.lower_inverse;
    a = eps * d * chol.inverse;
  }

  // The largest eigenvalue of A (the amplification guard's rho).
  double spectral_radius() const { return lambda.size() ? lambda.maxCoeff() : 0.0; }

  template <int = 0>  // instantiated only where used: see raydamp.hpp
  Factors factors(double t) const {
    Factors f;
    f.t = t;
    const auto n = lambda.size();
    SmallVector e1(n), p1(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      e1[i] = std::expm1(-t * lambda[i]);
      p1[i] = t * phi1(-t * lambda[i]);
    }
    f.expm1 = from_modes * e1.asDiagonal() * to_modes;
    SmallVector s(n);
    for (Eigen::Index i = 0; i < n; ++i) s[i] = std::sqrt(std::max(0.0, -std::expm1(-2.0 * t * lambda[i])));
    f.noise = from_modes * s.asDiagonal();
    f.t_phi1 = from_modes * p1.asDiagonal() * to_modes;
    f.scratch.resize(n);
    return f;
  }

  template <class Q, class P>
  void decay(const Q&, const Factors& f, P& p) const {
    f.scratch.noalias() = f.expm1 * p;
    p += f.scratch;
  }

  template <class Q, class G, class P>
  void decay_affine(const Q&, const Factors& f, const G& g, P& p) const {
    f.scratch.noalias() = f.expm1 * p;
    f.scratch.noalias() -= f.t_phi1 * g;
    p += f.scratch;
  }

  // p += sigma N xi: the noise of the exact OU flow (the mass is in N already).
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q&, const Factors& f, const Mass&, double sigma, const X& xi, P& p) const {
    f.scratch.noalias() = f.noise * xi;
    p += sigma * f.scratch;
  }

  template <class Q, class P, class O>
  void rate(const Q&, const P& p, O& out) const { out.noalias() = a * p; }

  // x <- (I + c A)^{-1} x = L V (I + c Lambda)^{-1} V^T L^{-1} x.
  template <class Q, class X>
  void solve_shifted(const Q&, double c, X& x) const {
    SmallVector y = to_modes * x;
    y.array() /= 1.0 + c * lambda.array();
    x.noalias() = from_modes * y;
  }
};

}  // namespace raydamp
