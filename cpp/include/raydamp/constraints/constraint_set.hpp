// Holonomic constraints g(q) = 0 of a user's system (python/raydamp/systems/system/constraints.py): the
// k constraint functions and their scales, and the structural non-zeros of their Jacobian G(q) (k x n),
// compiled at run time from the expressions like the potential. One set per system; a new system is new
// data, never new C++.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "raydamp/system/compiled_function.hpp"

namespace raydamp {

struct ConstraintSet {
  int k = 0;  // constraints
  int n = 0;  // coordinates
  // q -> (g_1 .. g_k, s_1 .. s_k): each constraint and its scale s_i, the sum of the absolute values of
  // its top-level terms at q (x^2 + y^2 - l^2: x^2 + y^2 + l^2, about 2 l^2), so that |g_i| <= tol s_i
  // is a tolerance relative to the constraint's own size (|r - l| <= tol l for a rod written that way).
  CompiledFunction values;
  // q -> G's structural non-zeros, row by row: entry e is dg_{rows[e]} / dq_{cols[e]}.
  CompiledFunction jacobian;
  std::vector<int> rows, cols;
  std::vector<int> row_start;  // entries of row a: row_start[a] .. row_start[a + 1]
  double tol = 1e-12;
  int max_iterations = 50;

  ConstraintSet() = default;
  ConstraintSet(int k_, int n_, CompiledFunction values_, CompiledFunction jacobian_, std::vector<int> rows_,
                std::vector<int> cols_, double tol_, int max_iterations_)
      : k(k_), n(n_), values(values_), jacobian(jacobian_), rows(std::move(rows_)), cols(std::move(cols_)),
        tol(tol_), max_iterations(max_iterations_) {
    if (k < 1) throw std::invalid_argument("constraints: a constrained system needs at least one constraint");
    if (k >= n) throw std::invalid_argument("constraints: " + std::to_string(k) + " constraints on " +
                                            std::to_string(n) + " coordinates leave no motion");
    if (!values || !jacobian) throw std::invalid_argument("constraints: not compiled");
    if (rows.size() != cols.size()) throw std::invalid_argument("constraints: rows and cols differ in length");
    if (!(tol > 0.0) || !(tol < 1.0)) throw std::invalid_argument("constraint_tol: must be in (0, 1)");
    if (max_iterations < 1) throw std::invalid_argument("constraints: max_iterations must be >= 1");
    row_start.assign(k + 1, 0);
    for (std::size_t e = 0; e < rows.size(); ++e) {
      if (rows[e] < 0 || rows[e] >= k || cols[e] < 0 || cols[e] >= n || (e > 0 && rows[e] < rows[e - 1]))
        throw std::invalid_argument("constraints: the Jacobian's entries must be row by row, inside k x n");
      ++row_start[rows[e] + 1];
    }
    for (int a = 0; a < k; ++a) {
      if (row_start[a + 1] == 0)
        throw std::invalid_argument("constraints[" + std::to_string(a) + "]: depends on no coordinate");
      row_start[a + 1] += row_start[a];
    }
  }

  int nonzeros() const { return static_cast<int>(rows.size()); }
};

// Why a run's constraint solve stopped it: the constraint, its residual and the step's time (the step
// loop sees only a state that is no longer finite; the bindings then name the constraint).
struct ConstraintFailure {
  int constraint = -1;  // -1: none
  double residual = 0.0, allowed = 0.0;
  int iterations = 0;
  bool singular = false;  // G M^{-1} G^T lost rank (the constraints' gradients became dependent)
};

// The scratch of the constraint solves: sized before the first step (resized only when a run's sizes
// differ), so the step loop never allocates. One per thread: runs on different threads never share one.
// It caches G and the factor of S = G M^{-1} G^T at the last q it was formed at, for the flows that
// follow a drift at the same q (a kick, a damp), and the next drift's Newton matrix.
struct ConstraintWork {
  const ConstraintSet* owner = nullptr;
  bool valid = false;
  Eigen::VectorXd at_q;           // the q that G, W and the factor belong to
  Eigen::VectorXd G;              // nonzeros
  Eigen::MatrixXd W;              // n x k: M^{-1} G^T
  Eigen::MatrixXd S;              // k x k: G M^{-1} G^T
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd g;              // 2k: constraints then scales
  Eigen::VectorXd lambda, mu;     // k
  Eigen::VectorXd u, v;           // n
  ConstraintFailure failure;
  double max_residual = 0.0;      // max_i |g_i| / s_i after the drifts of the run
  double max_velocity_residual = 0.0;  // max_i |(G M^{-1} p)_i| / (|G_i| |M^{-1} p|) after the drifts
  bool track = false;             // whether the run's flows update the two maxima above

  void prepare(const ConstraintSet& set) {
    const int n = set.n, k = set.k;
    if (at_q.size() != n) {
      at_q.resize(n);
      u.resize(n);
      v.resize(n);
    }
    if (G.size() != set.nonzeros()) G.resize(set.nonzeros());
    if (W.rows() != n || W.cols() != k) W.resize(n, k);
    if (S.rows() != k) {
      S.resize(k, k);
      llt = Eigen::LLT<Eigen::MatrixXd>(k);
    }
    if (g.size() != 2 * k) {
      g.resize(2 * k);
      lambda.resize(k);
      mu.resize(k);
    }
    owner = &set;
    valid = false;
    failure = ConstraintFailure{};
    max_residual = max_velocity_residual = 0.0;
  }
};

inline ConstraintWork& constraint_work() {
  thread_local ConstraintWork work;
  return work;
}

}  // namespace raydamp
