// The sub-flows of a constrained model (a model with `constraints`, models/constrained_system.hpp): RATTLE
// as a splitting. A drift is SHAKE then RATTLE's projection: q1 = q0 + t M^{-1} (p0 - G(q0)^T L/t) with L
// solved by Newton so that g(q1) = 0 to the tolerance, p corrected by the same impulse, then p projected
// onto the tangent space at q1. Every other sub-flow (kick, damp, kick+damp, their Runge-Kutta step, with
// load and noise) runs as for the free model at the frozen q and is followed by the projection
//   p <- p - G^T mu,  (G M^{-1} G^T) mu = G M^{-1} p,
// the M-orthogonal projector P onto {p : G M^{-1} p = 0}. For D = c M (and any D with D M^{-1} a multiple
// of I, such as D = I with M = m I) the damping flow's operator commutes with P, so "exact flow, then
// project" is the exact flow of P eps D M^{-1} on the tangent space, and an OU flow's Gaussian, projected,
// has the covariance kT P M: the constrained Boltzmann law of p. For a general constant D it is the exact
// flow of the frozen-q operator eps D M^{-1} followed by the projection: consistent, order 2 in the
// symmetric tables, not the exact projected flow.
//
// The drift's Newton is SHAKE's simplified one: its matrix is S = G(q0) M^{-1} G(q0)^T, factored once at
// q0 (where the previous sub-flows left it, so usually already factored) and used for every iteration.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "raydamp/constraints/constraint_set.hpp"
#include "raydamp/constraints/hook.hpp"
#include "raydamp/flows/exact.hpp"
#include "raydamp/flows/runge_kutta.hpp"
#include "raydamp/methods/splitting.hpp"

namespace raydamp {

namespace constraints {

// out = G x (k), from the non-zeros in work.G.
template <class X>
inline void times_G(const ConstraintSet& set, const Eigen::VectorXd& G, const X& x, Eigen::VectorXd& out) {
  for (int a = 0; a < set.k; ++a) {
    double s = 0.0;
    for (int e = set.row_start[a]; e < set.row_start[a + 1]; ++e) s += G[e] * x[set.cols[e]];
    out[a] = s;
  }
}

// y -= c G^T x.
template <class Y>
inline void minus_Gt(const ConstraintSet& set, const Eigen::VectorXd& G, const Eigen::VectorXd& x, double c, Y& y) {
  for (int a = 0; a < set.k; ++a) {
    const double xa = c * x[a];
    for (int e = set.row_start[a]; e < set.row_start[a + 1]; ++e) y[set.cols[e]] -= G[e] * xa;
  }
}

// G(q), W = M^{-1} G^T and the factor of S = G W, at q. False if S is not positive definite (G has lost
// rank: two constraints became dependent) or anything is not finite.
template <class Model, class Q>
bool factor_at(const Model& model, const Q& q, ConstraintWork& w) {
  const ConstraintSet& set = model.constraints;
  set.jacobian(w.G.data(), q.data());
  for (int a = 0; a < set.k; ++a) {
    w.u.setZero();
    for (int e = set.row_start[a]; e < set.row_start[a + 1]; ++e) w.u[set.cols[e]] = w.G[e];
    model.mass.velocity(w.u, w.v);
    w.W.col(a) = w.v;
  }
  w.S.setZero();
  for (int e = 0; e < set.nonzeros(); ++e) w.S.row(set.rows[e]) += w.G[e] * w.W.row(set.cols[e]);
  w.llt.compute(w.S);
  w.at_q = q;
  w.valid = w.llt.info() == Eigen::Success && w.S.allFinite();
  return w.valid;
}

template <class Model, class Q>
bool factored_at(const Model& model, const Q& q, ConstraintWork& w) {
  if (w.valid && w.owner == &model.constraints && w.at_q == q) return true;
  return factor_at(model, q, w);
}

// The state becomes NaN, and the failure is kept for the bindings to name: the step loop sees a state
// that is not finite, replays its block to the failing step and keeps every row before it.
template <int Dim>
void fail(State<Dim>& z, ConstraintWork& w, int constraint, double residual, double allowed, int iterations,
          bool singular = false) {
  if (w.failure.constraint < 0) w.failure = ConstraintFailure{constraint, residual, allowed, iterations, singular};
  z.q.setConstant(std::numeric_limits<double>::quiet_NaN());
  z.p.setConstant(std::numeric_limits<double>::quiet_NaN());
  w.valid = false;
}

// p <- P(q) p: the M-orthogonal projection onto the tangent space at q; `measure`: and the largest
// |(G M^{-1} p)_i| / (|G_i| |M^{-1} p|) left after it, into the run's summary.
template <class Model, int Dim>
void project(const Model& model, State<Dim>& z, ConstraintWork& w, bool measure = false) {
  if (!z.all_finite()) return;  // blown up elsewhere: the step loop reports it as it is
  if (!factored_at(model, z.q, w)) {
    fail(z, w, 0, 0.0, 0.0, 0, true);
    return;
  }
  const ConstraintSet& set = model.constraints;
  model.mass.velocity(z.p, w.v);
  times_G(set, w.G, w.v, w.mu);
  w.llt.solveInPlace(w.mu);
  minus_Gt(set, w.G, w.mu, 1.0, z.p);
  if (measure && w.track) {
    model.mass.velocity(z.p, w.v);
    times_G(set, w.G, w.v, w.mu);
    const double speed = w.v.norm();
    for (int a = 0; a < set.k; ++a) {
      const double row = Eigen::Map<const Eigen::VectorXd>(w.G.data() + set.row_start[a],
                                                           set.row_start[a + 1] - set.row_start[a]).norm();
      if (speed > 0.0 && row > 0.0) w.max_velocity_residual = std::max(w.max_velocity_residual, std::abs(w.mu[a]) / (row * speed));
    }
  }
}

// SHAKE then RATTLE's projection over time t (see the file's comment).
template <class Model, int Dim, class WS>
void drift(const Model& model, State<Dim>& z, double t, WS& ws) {
  ConstraintWork& w = constraint_work();
  const ConstraintSet& set = model.constraints;
  if (!z.all_finite()) return;  // blown up elsewhere: the step loop reports it as it is
  if (!factored_at(model, z.q, w)) return fail(z, w, 0, 0.0, 0.0, 0, true);
  flows::drift(model, z, t, ws);
  w.lambda.setZero();
  const double q_size = z.q.template lpNorm<Eigen::Infinity>();
  int it = 0;
  bool evaluated_here = true;  // w.g holds g at the current q (else q moved by a last, rounding-sized step)
  for (;; ++it) {
    set.values(w.g.data(), z.q.data());
    int worst = 0;
    double worst_ratio = 0.0;
    bool finite = true;
    for (int a = 0; a < set.k; ++a) {
      const double allowed = set.tol * w.g[set.k + a];
      const double r = std::abs(w.g[a]);
      if (!std::isfinite(r)) finite = false;
      const double ratio = r / std::max(allowed, std::numeric_limits<double>::min());
      if (!(ratio <= worst_ratio)) worst_ratio = ratio, worst = a;
    }
    if (finite && worst_ratio <= 1.0) break;
    if (!finite || it == set.max_iterations)
      return fail(z, w, worst, std::abs(w.g[worst]), set.tol * w.g[set.k + worst], it);
    // L += S^{-1} g(q); q -= M^{-1} G(q0)^T (that increment).
    w.mu = w.g.head(set.k);
    w.llt.solveInPlace(w.mu);
    w.lambda += w.mu;
    w.v.noalias() = w.W * w.mu;
    z.q -= w.v;
    // A correction at the rounding of q cannot reduce g further: g is then as small as doubles allow.
    if (w.v.template lpNorm<Eigen::Infinity>() <= 8 * std::numeric_limits<double>::epsilon() * q_size) {
      evaluated_here = false;
      break;
    }
  }
  if (it > 0 && t != 0.0) minus_Gt(set, w.G, w.lambda, 1.0 / t, z.p);
  if (w.track) {
    if (!evaluated_here) set.values(w.g.data(), z.q.data());
    for (int a = 0; a < set.k; ++a)
      if (w.g[set.k + a] > 0.0) w.max_residual = std::max(w.max_residual, std::abs(w.g[a]) / w.g[set.k + a]);
  }
  project(model, z, w, true);
}

// Sub-flow F of a constrained model: the constrained drift, or the free sub-flow then the projection.
// The Runge-Kutta sub-flows that move q (rksb's drift+damp, rk's whole field) are refused before a run
// (the model has no free drift: catalogue.hpp, require_applicable) and never reach here.
template <Flow F, class Model, class Tab, int Dim, class WS>
void flow(const Model& model, const Tab& tab, State<Dim>& z, double t, WS& ws) {
  if constexpr (F == Flow::drift) {
    constraints::drift(model, z, t, ws);
    return;
  } else if constexpr (F == Flow::kick) {
    flows::kick(model, z, t, ws);
  } else if constexpr (F == Flow::damp) {
    flows::damp(model, z, t, ws);
  } else if constexpr (F == Flow::kick_damp) {
    flows::kick_damp(model, z, t, ws);
  } else if constexpr (F == Flow::kick_damp_rk) {
    flows::kick_damp_rk(model, tab, z, t, ws);
  } else {
    throw std::logic_error("constraints: a Runge-Kutta sub-flow that moves q has no constrained form");
  }
  project(model, z, constraint_work());
}

}  // namespace constraints
}  // namespace raydamp
