// The mass kinds of a sparse linear structure (models/linear_structure.hpp):
// - LumpedMass: diagonal M (row-sum lumping), M^{-1} p elementwise;
// - ConsistentMass: a sparse SPD M (the finite-element mass), factorised once by a
//   sparse Cholesky factorisation; M^{-1} p is two triangular solves.
// Both copy cheaply (the factorisation is shared), so the damping kind keeps its own.
#pragma once

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "raydamp/thread_scratch.hpp"

namespace raydamp {

using SparseColMajor = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using SparseRowMajor = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

// A = L L^T of a sparse SPD matrix (fill-reducing AMD ordering). solve() applies the
// permutations and the triangular solves itself, into a separate output: Eigen's own
// solve() permutes in place, which allocates a mask of n bools on every call.
class SparseCholesky {
 public:
  SparseCholesky(const SparseColMajor& a, const std::string& argument) {
    if (a.rows() != a.cols()) throw std::invalid_argument(argument + ": must be square");
    llt_.compute(a);
    if (llt_.info() != Eigen::Success)
      throw std::invalid_argument(argument + ": must be positive definite (its sparse Cholesky factorisation fails)");
  }

  // out = A^{-1} x; out must not alias x.
  template <class X, class Out>
  void solve(const X& x, Out& out) const {
    out.noalias() = llt_.permutationP() * x;
    llt_.matrixL().solveInPlace(out);
    llt_.matrixU().solveInPlace(out);
    Eigen::VectorXd& tmp = thread_scratch(kScratchSolve, out.size());
    tmp.noalias() = llt_.permutationPinv() * out;
    out = tmp;
  }

  Eigen::Index nonzeros() const { return llt_.matrixL().nestedExpression().nonZeros(); }

  // out += c P^{-1} L x: with A = P^{-1} L L^T P^{-T}, noise of covariance c^2 A from a standard normal x.
  template <class X, class Out>
  void add_root_product(double c, const X& x, Out& out) const {
    Eigen::VectorXd& y = thread_scratch(kScratchSolve, x.size());
    y.noalias() = llt_.matrixL() * x;
    Eigen::VectorXd& z = thread_scratch(kScratchProduct, x.size());
    z.noalias() = llt_.permutationPinv() * y;
    out += c * z;
  }

 private:
  Eigen::SimplicialLLT<SparseColMajor, Eigen::Lower, Eigen::AMDOrdering<int>> llt_;
};

struct LumpedMass {
  static constexpr const char* kind = "lumped";
  Eigen::VectorXd m, inverse;  // the diagonal of M and its reciprocals

  Eigen::VectorXd root;  // sqrt(M[i, i]): thermal noise

  explicit LumpedMass(const Eigen::VectorXd& diagonal, const std::string& argument = "M") : m(diagonal) {
    if (diagonal.size() == 0) throw std::invalid_argument(argument + ": empty");
    for (Eigen::Index i = 0; i < diagonal.size(); ++i)
      if (!(diagonal[i] > 0.0) || !std::isfinite(diagonal[i]))
        throw std::invalid_argument(argument + ": a lumped (diagonal) mass needs every M[i, i] > 0 and finite; M[" +
                                    std::to_string(i) + ", " + std::to_string(i) + "] = " + std::to_string(diagonal[i]));
    inverse = m.cwiseInverse();
    root = m.cwiseSqrt();
  }

  // p += c M^{1/2} x.
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const { p += c * root.cwiseProduct(x); }

  Eigen::Index size() const { return m.size(); }
  template <class P, class V>
  void velocity(const P& p, V& v) const { v = inverse.cwiseProduct(p); }
  template <class X, class O>
  void multiply(const X& x, O& out) const { out = m.cwiseProduct(x); }
  template <class P>
  double kinetic(const P& p) const { return 0.5 * p.cwiseAbs2().dot(inverse); }
  SparseColMajor matrix() const {
    SparseColMajor a(m.size(), m.size());
    a.reserve(Eigen::VectorXi::Ones(m.size()));
    for (Eigen::Index i = 0; i < m.size(); ++i) a.insert(i, i) = m[i];
    a.makeCompressed();
    return a;
  }
};

struct ConsistentMass {
  static constexpr const char* kind = "consistent";
  std::shared_ptr<const SparseRowMajor> m;
  std::shared_ptr<const SparseCholesky> cholesky;

  explicit ConsistentMass(const SparseColMajor& mass, const std::string& argument = "M")
      : m(std::make_shared<const SparseRowMajor>(mass)),
        cholesky(std::make_shared<const SparseCholesky>(mass, argument)) {}

  Eigen::Index size() const { return m->rows(); }
  template <class P, class V>
  void velocity(const P& p, V& v) const { cholesky->solve(p, v); }
  template <class X, class O>
  void multiply(const X& x, O& out) const { out.noalias() = *m * x; }
  template <class P>
  double kinetic(const P& p) const {
    Eigen::VectorXd& v = thread_scratch(kScratchProduct, p.size());
    cholesky->solve(p, v);
    return 0.5 * p.dot(v);
  }
  SparseColMajor matrix() const { return SparseColMajor(*m); }

  // p += c L x, L L^T = M (the Cholesky factor, permuted back).
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const { cholesky->add_root_product(c, x, p); }
};

}  // namespace raydamp
