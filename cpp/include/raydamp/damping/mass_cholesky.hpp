// M = L L^T, for the damping kinds whose operator A = eps D M^{-1} is not a
// multiple of I. With S = eps L^{-1} D L^{-T} (symmetric, PSD when D is),
// A = L S L^{-1}, so every function of A is L f(S) L^{-1}: a symmetric
// eigendecomposition gives the exact flows whatever M is.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <stdexcept>

namespace raydamp {

struct MassCholesky {
  Eigen::MatrixXd lower, lower_inverse, inverse;  // L, L^{-1}, M^{-1}

  template <int = 0>  // instantiated only where used: see raydamp.hpp
  explicit MassCholesky(const Eigen::MatrixXd& mass) {
    Eigen::LLT<Eigen::MatrixXd> llt(mass);
    if (llt.info() != Eigen::Success) throw std::invalid_argument("mass must be symmetric positive definite");
    const auto n = mass.rows();
    lower = llt.matrixL();
    lower_inverse = llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));
    inverse = lower_inverse.transpose() * lower_inverse;
  }
};

}  // namespace raydamp
