// The dashpots of a constrained system, D(q) = sum_i c_i grad g_i(q) grad g_i(q)^T, as their flow on the
// constraint's tangent space needs them (projected_dampers.hpp): the operator eps L^{-1} D(q) L^{-T} in the
// mass-weighted momenta y = L^{-1} p (M = L L^T), and L. Data made once when the model is built; unset for
// a system without dashpots.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <vector>

#include "raydamp/system/compiled_function.hpp"
#include "raydamp/system/small_dense.hpp"

namespace raydamp::constraints {

struct Dashpots {
  CompiledFunction gradients;  // q -> the k rows grad g_i(q), n entries each
  std::vector<double> eps_c;   // eps c_i
  SmallMatrix lower, lower_inverse;

  Dashpots() = default;
  Dashpots(const Eigen::MatrixXd& mass, double eps, const std::vector<double>& c, CompiledFunction gradients_)
      : gradients(gradients_) {
    const auto n = mass.rows();
    if (n > kMaxDenseDim || static_cast<int>(c.size()) > kMaxDampers || c.empty() || !gradients)
      throw std::invalid_argument("damping.dampers: dashpots with constraints need 1 to 32 dashpots on n <= 32");
    Eigen::LLT<Eigen::MatrixXd> llt(mass);
    if (llt.info() != Eigen::Success) throw std::invalid_argument("mass must be symmetric positive definite");
    lower = llt.matrixL();
    lower_inverse = llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));
    for (double ci : c) eps_c.push_back(eps * ci);
  }

  // s = eps L^{-1} D(q) L^{-T}.
  template <class Q>
  void mass_weighted(const Q& q, SmallMatrix& s) const {
    const int n = static_cast<int>(lower.rows());
    std::array<double, kMaxDenseDim * kMaxDampers> g;
    gradients(g.data(), q.data());
    s.setZero(n, n);
    SmallVector y(n);
    for (std::size_t i = 0; i < eps_c.size(); ++i) {
      y.noalias() = lower_inverse * Eigen::Map<const Eigen::VectorXd>(g.data() + i * n, n);
      s.noalias() += eps_c[i] * y * y.transpose();
    }
  }
};

}  // namespace raydamp::constraints
