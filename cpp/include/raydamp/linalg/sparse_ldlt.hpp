// A = P^T L D L^T P of a sparse symmetric matrix (transpose, not conjugate
// transpose): real symmetric positive definite, or complex symmetric with a
// positive definite real part (the stage matrix of the 2-stage Gauss method,
// implicit/linear_implicit_step.hpp), where elimination without pivoting is stable.
// Eigen's SimplicialLDLT and CHOLMOD factor Hermitian matrices (L D L^H), which a
// complex symmetric matrix is not; this is the up-looking algorithm of Davis'
// LDL (T. A. Davis, "Algorithm 849: a concise sparse Cholesky factorization
// package", ACM TOMS 31(4), 2005) written for either scalar.
//
// The analysis (fill-reducing AMD ordering, elimination tree, column counts of L)
// depends only on the pattern, so one SparsePattern serves every factorisation of
// M + c C + c^2 K for any c. solve() works in caller-owned buffers and allocates nothing.
#pragma once

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>
#include <complex>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace raydamp {

// The symbolic analysis of a symmetric n x n pattern: the permutation, the
// elimination tree and the column pointers of L.
class SparsePattern {
 public:
  // `pattern`: any matrix with the (symmetric) pattern of the matrices to factorise,
  // both triangles stored.
  explicit SparsePattern(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& pattern) : n_(pattern.rows()) {
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
    Eigen::AMDOrdering<int>()(pattern, inverse);
    permutation_ = inverse.inverse();  // row i of A goes to row permutation_(i) of P A P^T
    // The upper triangle of P A P^T, column by column: its rows above the diagonal
    // drive the up-looking elimination.
    const Eigen::SparseMatrix<double, Eigen::ColMajor, int> upper_ = permuted_upper(pattern);
    parent_.assign(n_, -1);
    std::vector<int> flag(n_), count(n_, 0);
    for (int k = 0; k < n_; ++k) {
      flag[k] = k;
      for (Index p = upper_.outerIndexPtr()[k]; p < upper_.outerIndexPtr()[k + 1]; ++p) {
        int i = upper_.innerIndexPtr()[p];
        // Row k of L has a nonzero in every column on the tree path from i up to k.
        for (; i < k && flag[i] != k; i = parent_[i]) {
          if (parent_[i] == -1) parent_[i] = k;
          ++count[i];
          flag[i] = k;
        }
      }
    }
    column_start_.assign(n_ + 1, 0);
    for (int k = 0; k < n_; ++k) column_start_[k + 1] = column_start_[k] + count[k];
  }

  using Index = Eigen::Index;
  int size() const { return static_cast<int>(n_); }
  Index factor_nonzeros() const { return column_start_.back(); }

  // The upper triangle of P A P^T for a matrix A with (a subset of) this pattern.
  // (By hand: Eigen's selfadjointView would conjugate a complex entry that the
  // permutation moves across the diagonal.)
  template <class Scalar>
  Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int> permuted_upper(
      const Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int>& a) const {
    const int* perm = permutation_.indices().data();
    std::vector<Eigen::Triplet<Scalar, int>> entries;
    entries.reserve(a.nonZeros());
    for (Index j = 0; j < a.outerSize(); ++j)
      for (typename Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int>::InnerIterator it(a, j); it; ++it) {
        if (it.row() > j) continue;  // the upper triangle is read
        const int pi = perm[it.row()], pj = perm[j];
        entries.emplace_back(std::min(pi, pj), std::max(pi, pj), it.value());
      }
    Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int> out(n_, n_);
    out.setFromTriplets(entries.begin(), entries.end());
    return out;
  }

  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>& permutation() const { return permutation_; }
  const std::vector<int>& parent() const { return parent_; }
  const std::vector<Index>& column_start() const { return column_start_; }

 private:
  Index n_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  std::vector<int> parent_;
  std::vector<Index> column_start_;
};

template <class Scalar>
class SparseLDLT {
 public:
  using Index = Eigen::Index;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  using Matrix = Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int>;

  // Factorises a (symmetric, both triangles or the upper one stored; its pattern
  // within the analysed one). `what` names the matrix in the error of a zero pivot.
  SparseLDLT(std::shared_ptr<const SparsePattern> pattern, const Matrix& a, const std::string& what)
      : pattern_(std::move(pattern)) {
    const int n = pattern_->size();
    if (a.rows() != n || a.cols() != n) throw std::invalid_argument(what + ": not the analysed size");
    const Matrix c = pattern_->permuted_upper(a);
    const std::vector<int>& parent = pattern_->parent();
    const std::vector<Index>& start = pattern_->column_start();
    rows_.resize(start.back());
    values_.resize(start.back());
    diagonal_.resize(n);
    std::vector<Scalar> y(n, Scalar(0));
    std::vector<int> flag(n), pattern_stack(n), filled(n, 0);
    for (int k = 0; k < n; ++k) {
      // Row k of L: solve L(0:k, 0:k) D y = A(0:k, k) on the rows its tree path reaches.
      int top = n;
      flag[k] = k;
      for (Index p = c.outerIndexPtr()[k]; p < c.outerIndexPtr()[k + 1]; ++p) {
        int i = c.innerIndexPtr()[p];
        y[i] += c.valuePtr()[p];
        int len = 0;
        for (; i < k && flag[i] != k; i = parent[i]) {
          pattern_stack[len++] = i;
          flag[i] = k;
        }
        while (len > 0) pattern_stack[--top] = pattern_stack[--len];
      }
      Scalar d = y[k];
      y[k] = Scalar(0);
      for (; top < n; ++top) {
        const int i = pattern_stack[top];
        const Scalar yi = y[i];
        y[i] = Scalar(0);
        const Index end = start[i] + filled[i];
        for (Index p = start[i]; p < end; ++p) y[rows_[p]] -= values_[p] * yi;
        const Scalar l_ki = yi / diagonal_[i];
        d -= l_ki * yi;
        rows_[end] = k;
        values_[end] = l_ki;
        ++filled[i];
      }
      if (d == Scalar(0)) throw std::invalid_argument(what + ": singular (a zero pivot in its LDL^T factorisation)");
      diagonal_[k] = d;
    }
    inverse_diagonal_ = diagonal_.cwiseInverse();
  }

  // Whether every pivot is positive: for a real matrix, that it is positive definite.
  bool positive_pivots() const {
    if constexpr (std::is_same_v<Scalar, double>) return (diagonal_.array() > 0.0).all();
    else return false;
  }

  // x = A^{-1} b, through `work` (size n); x must not alias b. No allocation.
  template <class B, class X>
  void solve(const B& b, X& x, Vector& work) const {
    const int n = pattern_->size();
    const int* perm = pattern_->permutation().indices().data();
    for (int i = 0; i < n; ++i) work[perm[i]] = b[i];
    const Index* start = pattern_->column_start().data();
    const int* rows = rows_.data();
    const Scalar* values = values_.data();
    for (int j = 0; j < n; ++j) {  // L y = P b
      const Scalar yj = work[j];
      for (Index p = start[j]; p < start[j + 1]; ++p) work[rows[p]] -= values[p] * yj;
    }
    work.array() *= inverse_diagonal_.array();
    for (int j = n - 1; j >= 0; --j) {  // L^T z = D^{-1} y
      // A long column (a 2-D mesh's) in four partial sums: one would chain every multiply-add on the
      // previous one's latency. (A short one, a beam's or a chain's, is faster without.)
      Scalar s0 = work[j], s1(0), s2(0), s3(0);
      Index p = start[j];
      const Index end = start[j + 1];
      for (; end - p >= 8 && p + 4 <= end; p += 4) {
        s0 -= values[p] * work[rows[p]];
        s1 -= values[p + 1] * work[rows[p + 1]];
        s2 -= values[p + 2] * work[rows[p + 2]];
        s3 -= values[p + 3] * work[rows[p + 3]];
      }
      for (; p < end; ++p) s0 -= values[p] * work[rows[p]];
      work[j] = (s0 + s1) + (s2 + s3);
    }
    for (int i = 0; i < n; ++i) x[i] = work[perm[i]];
  }

  const Vector& diagonal() const { return diagonal_; }
  Index nonzeros() const { return static_cast<Index>(values_.size()); }

 private:
  std::shared_ptr<const SparsePattern> pattern_;
  std::vector<int> rows_;
  std::vector<Scalar> values_;
  Vector diagonal_, inverse_diagonal_;
};

}  // namespace raydamp
