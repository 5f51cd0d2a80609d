// Vectors and matrices for the dense damping kinds of compiled systems, with their
// storage on the stack (Eigen's MaxRows/MaxCols), so that the exact damping flows
// allocate nothing per step. These kinds are for small n: systems written as
// expressions (a chain of a few masses, a molecule, an orbit); structures with
// thousands of coordinates need the sparse kinds, not an n x n eigendecomposition.
#pragma once

#include <Eigen/Core>

namespace raydamp {

inline constexpr int kMaxDenseDim = 32;  // n for a constant-matrix or multi-damper D(q)
inline constexpr int kMaxDampers = 32;   // dashpots in one system

using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDenseDim, 1>;
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDenseDim, kMaxDenseDim>;

// out = A x - B y (B, y optional) for small dense column-major A, B: column by column, each an axpy over
// contiguous memory that the compiler vectorises. At a few DOF Eigen's gemv call, or its coefficient-wise
// lazy product (row by row: strided), costs more than the arithmetic (a 10-storey frame's 3s step: 300 ns
// with the lazy product). out must alias neither x nor y; x, y and out contiguous.
template <class X, class Y, class Out>
inline void small_product(const Eigen::MatrixXd& a, const X& x, const Eigen::MatrixXd* b, const Y* y, Out& out) {
  const Eigen::Index rows = a.rows(), cols = a.cols();
  const double* ax = x.data();
  double* o = out.data();
  const double* ac = a.data();
  for (Eigen::Index i = 0; i < rows; ++i) o[i] = ac[i] * ax[0];
  for (Eigen::Index j = 1; j < cols; ++j) {
    const double xj = ax[j];
    const double* col = ac + j * rows;
    for (Eigen::Index i = 0; i < rows; ++i) o[i] += col[i] * xj;
  }
  if (!b) return;
  const double* by = y->data();
  const double* bc = b->data();
  for (Eigen::Index j = 0; j < cols; ++j) {
    const double yj = by[j];
    const double* col = bc + j * rows;
    for (Eigen::Index i = 0; i < rows; ++i) o[i] -= col[i] * yj;
  }
}

template <class X, class Out>
inline void small_product(const Eigen::MatrixXd& a, const X& x, Out& out) {
  small_product(a, x, static_cast<const Eigen::MatrixXd*>(nullptr), static_cast<const X*>(nullptr), out);
}

}  // namespace raydamp
