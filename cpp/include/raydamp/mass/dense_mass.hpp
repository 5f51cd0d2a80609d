// A constant symmetric positive definite mass matrix M (diagonal or full): the
// mass of a system in generalised coordinates where M does not depend on q (the
// paper needs such coordinates so that the drift exp(t X_T) is explicit).
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <stdexcept>

namespace raydamp {

struct DenseMass {
  Eigen::MatrixXd m;        // M
  Eigen::MatrixXd inverse;  // M^{-1}, formed once: the drift is one product with it
  Eigen::MatrixXd lower;    // L with L L^T = M (Cholesky): a root of M for thermal noise

  // Refuses (naming `argument`) an M that is not symmetric positive definite.
  template <int = 0>  // instantiated only where used: see raydamp.hpp
  explicit DenseMass(const Eigen::MatrixXd& mass, const char* argument = "mass") : m(mass) {
    const auto n = mass.rows();
    if (n == 0 || mass.cols() != n || !mass.allFinite())
      throw std::invalid_argument(std::string(argument) + " must be a finite square matrix");
    if (!mass.isApprox(mass.transpose(), 1e-12))
      throw std::invalid_argument(std::string(argument) + " must be symmetric");
    Eigen::LLT<Eigen::MatrixXd> llt(mass);
    if (llt.info() != Eigen::Success)
      throw std::invalid_argument(std::string(argument) + " must be positive definite (its Cholesky factorisation fails)");
    inverse = llt.solve(Eigen::MatrixXd::Identity(n, n));
    lower = llt.matrixL();
    inverse = 0.5 * (inverse + inverse.transpose()).eval();  // exactly symmetric, so T(p) is a quadratic form
  }

  // p += c L x (L L^T = M: the noise c L x has covariance c^2 M).
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const {
    for (Eigen::Index j = 0; j < x.size(); ++j) p += (c * x[j]) * lower.col(j);
  }

  // v = M^{-1} p.
  template <class P, class V>
  void velocity(const P& p, V& v) const { v.noalias() = inverse * p; }

  // T(p) = 1/2 p^T M^{-1} p, without a temporary vector.
  template <class P>
  double kinetic(const P& p) const {
    double sum = 0.0;
    for (Eigen::Index j = 0; j < p.size(); ++j) sum += p[j] * inverse.col(j).dot(p);
    return 0.5 * sum;
  }
};

}  // namespace raydamp
