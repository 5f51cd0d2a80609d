// The floor of a constrained step's cost (benchmarks/bench_constraints.py): the least work any RATTLE step
// adds to the free step of the same system. Whatever the method, a step that ends on g(q) = 0 with p tangent
// at a new q must evaluate g at that q at least once, take at least one solve for the multiplier of SHAKE's
// impulse (with a matrix already factored, the previous step's), form G(q) and factor G M^{-1} G^T there at
// least once, and take one solve for the projection of p, with the products by G, G^T and M^{-1} each of
// those solves needs. Timed here with exactly that and nothing more: one chord iteration, no convergence test,
// no residual kept. Not a method (it does not converge the constraint): a lower bound on what one costs.
#pragma once

#include <Eigen/Core>
#include <chrono>

#include "raydamp/constraints/constraint_set.hpp"
#include "raydamp/constraints/rattle.hpp"

namespace raydamp::constraints {

// ns per step of that least work over `steps` steps of length h from (q, p) on the constraints (q stays
// on them: each step's correction is a rounding-sized one). Its own scratch, not the thread's.
inline double least_work_ns(const ConstraintSet& set, Eigen::VectorXd q, Eigen::VectorXd p, double h, long steps) {
  ConstraintWork w;
  w.prepare(set);
  // The previous step's G and factor of G M^{-1} G^T, in G1 and A: a step's Newton solve takes them.
  set.jacobian(w.G1.data(), q.data());
  set.normal.form(w.G1.data(), w.G1.data(), w.A.data(), true);
  if (!set.normal.factor(w.A.data())) return -1.0;
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < steps; ++i) {
    set.values(w.g.data(), q.data());  // g at the drift's end, once
    w.mu = w.g.head(set.k);             // one Newton solve, the previous factor's
    solve(set, w.A, w.mu, w);
    w.u.setZero();
    minus_Gt(set, w.G1, w.mu, -1.0, w.u);
    inverse_mass_times(set, w.u, w.v);
    q -= w.v;
    minus_Gt(set, w.G1, w.mu, 1.0 / h, p);
    set.jacobian(w.G.data(), q.data());  // G and the factor of G M^{-1} G^T at the new q, once
    set.normal.form(w.G.data(), w.G.data(), w.S.data(), true);
    set.normal.factor(w.S.data());
    inverse_mass_times(set, p, w.v);  // one projection
    times_G(set, w.G, w.v, w.mu);
    solve(set, w.S, w.mu, w);
    minus_Gt(set, w.G, w.mu, 1.0, p);
    w.G.swap(w.G1);  // the next step's Newton solve takes this step's factor
    w.S.swap(w.A);
  }
  const std::chrono::duration<double, std::nano> elapsed = std::chrono::steady_clock::now() - start;
  return q.allFinite() && p.allFinite() ? elapsed.count() / static_cast<double>(steps) : -1.0;
}

}  // namespace raydamp::constraints
