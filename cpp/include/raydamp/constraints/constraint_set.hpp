// Holonomic constraints g(q) = 0 of a user's system (python/raydamp/systems/system/constraints.py): the
// k constraint functions and their scales, and the structural non-zeros of their Jacobian G(q) (k x n),
// compiled at run time from the expressions like the potential. One set per system; a new system is new
// data, never new C++.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "raydamp/constraints/band_lu.hpp"
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
  // (q, v) -> (v^T Hess g_i(q) v)_i: the constraints' curvature along v, for the multipliers.
  CompiledFunction curvature;
  std::vector<int> rows, cols;
  std::vector<int> row_start;  // entries of row a: row_start[a] .. row_start[a + 1]
  double tol = 1e-12;
  int max_iterations = 50;
  // G M^{-1} G^T's pattern, band and order, from G's pattern and M^{-1}'s (analyse(), by the model that
  // knows its mass kind); and which set this is, for the per-thread scratch (ConstraintWork::at_q's cache).
  constraints::NormalPattern normal;
  std::uint64_t id = 0;

  ConstraintSet() = default;
  ConstraintSet(int k_, int n_, CompiledFunction values_, CompiledFunction jacobian_, CompiledFunction curvature_,
                std::vector<int> rows_, std::vector<int> cols_, double tol_, int max_iterations_)
      : k(k_), n(n_), values(values_), jacobian(jacobian_), curvature(curvature_), rows(std::move(rows_)),
        cols(std::move(cols_)), tol(tol_), max_iterations(max_iterations_) {
    if (k < 1) throw std::invalid_argument("constraints: a constrained system needs at least one constraint");
    if (k >= n) throw std::invalid_argument("constraints: " + std::to_string(k) + " constraints on " +
                                            std::to_string(n) + " coordinates leave no motion");
    if (!values || !jacobian || !curvature) throw std::invalid_argument("constraints: not compiled");
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
    static std::atomic<std::uint64_t> sets{0};
    id = ++sets;
  }

  // M^{-1} for the solve's own products, by its non-zeros: a diagonal one (a scalar mass, or masses per
  // coordinate given as a dense M) as a vector, so that a product costs O(n), not a dense n x n one.
  Eigen::VectorXd inverse_diagonal;  // empty unless M^{-1} is diagonal
  std::vector<constraints::InverseMassEntry> inverse_mass;

  void analyse(const std::vector<constraints::InverseMassEntry>& entries) {
    normal = constraints::NormalPattern(k, rows, cols, n, entries);
    inverse_mass.clear();
    bool diagonal = true;
    for (const auto& e : entries)
      if (e.value != 0.0) inverse_mass.push_back(e), diagonal = diagonal && e.i == e.j;
    inverse_diagonal.resize(0);
    if (diagonal) {
      inverse_diagonal = Eigen::VectorXd::Zero(n);
      for (const auto& e : inverse_mass) inverse_diagonal[e.i] = e.value;
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

// The scratch of the constraint solves: sized before the first step (again only when a run's sizes
// differ), so the step loop never allocates. One per thread: runs on different threads never share one.
// It keeps G and the factor of S = G M^{-1} G^T at the last q they were formed at, for the flows that
// follow a drift at the same q (a kick, a damp), and the next drift's start. Matrices in band storage
// (NormalPattern), vectors of constraints in the constraints' order unless named band order.
struct ConstraintWork {
  std::uint64_t owner = 0;        // the ConstraintSet's id it is sized and cached for
  bool valid = false;
  Eigen::VectorXd at_q;           // the q that G and S belong to
  Eigen::VectorXd G, G1;          // G's non-zeros at at_q; at a Newton iterate
  Eigen::VectorXd S, A;           // factored: S = G M^{-1} G^T at at_q; the Newton matrix G1 M^{-1} G^T
  Eigen::VectorXd g;              // 2k: constraints then scales
  Eigen::VectorXd lambda, mu, x;  // k; x in band order
  Eigen::VectorXd u, v;           // n
  Eigen::VectorXd q_back, g_back, lambda_back;  // the Newton iterate before the last increment
  bool newton_next = false;       // the last drift took Newton's matrix
  Eigen::VectorXd lambda_last;    // the last drift's impulse and its length, while q is where it ended
  double last_t = std::numeric_limits<double>::quiet_NaN();
  ConstraintFailure failure;
  double max_residual = 0.0;      // max_i |g_i| / s_i after the drifts of the run
  double max_velocity_residual = 0.0;  // max_i |(G M^{-1} p)_i| / (|G_i| |M^{-1} p|) after the drifts
  bool track = false;             // whether the run's flows update the two maxima above
  // What the solves did over the run (benchmarks/bench_constraints.py prints them).
  long drifts = 0, iterations = 0, refreshes = 0, factorisations = 0;

  void prepare(const ConstraintSet& set) {
    const int n = set.n, k = set.k;
    at_q.resize(n);
    u.resize(n);
    v.resize(n);
    q_back.resize(n);
    g_back.resize(2 * k);
    lambda_back.resize(k);
    lambda_last.setZero(k);
    last_t = std::numeric_limits<double>::quiet_NaN();
    newton_next = false;
    G.resize(set.nonzeros());
    G1.resize(set.nonzeros());
    S.resize(set.normal.size());
    A.resize(set.normal.size());
    g.resize(2 * k);
    lambda.resize(k);
    mu.resize(k);
    x.resize(k);
    owner = set.id;
    valid = false;
    failure = ConstraintFailure{};
    max_residual = max_velocity_residual = 0.0;
    drifts = iterations = refreshes = factorisations = 0;
  }
};

inline ConstraintWork& constraint_work() {
  thread_local ConstraintWork work;
  return work;
}

// The thread's scratch, made ready for `set` if it was last used for another (an ensemble's worker
// threads: a single run's bindings prepare it before the run, to read its residuals after).
inline ConstraintWork& constraint_work(const ConstraintSet& set) {
  ConstraintWork& work = constraint_work();
  if (work.owner != set.id) work.prepare(set);
  return work;
}

}  // namespace raydamp
