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
// symmetric tables, not the exact projected flow. Dashpots (D(q) = sum c_i grad g_i grad g_i^T) take the
// exact flow of P eps D M^{-1} instead (projected_dampers.hpp); rks's Runge-Kutta step of kick+damp stays
// the free one, then the projection.
//
// The drift's Newton starts from the last drift's impulse where that drift was as long (the tables' drifts
// of one step and the next: the impulse changes by O(h) relative between them, so the first residual is O(h)
// smaller than from zero; 2.85 -> 2.16 iterations per drift on bench_constraints.py's 100-link chain), and
// iterates as SHAKE's chord iteration, with S = G(q0) M^{-1} G(q0)^T factored at q0
// (where the previous sub-flows left it, so usually already factored). Its contraction per iteration is
// about cond(S) |q - q0| / l, small for a pendulum's step but not for a long chain's (a 100-link cable at
// h = 1e-3 diverged): when an iteration reduces the residual less than kSlowContraction, the matrix is
// refreshed to Newton's own, G(q) M^{-1} G(q0)^T at the current iterate, and from then on at every iterate
// (with cond(S) ~ k^2 on a chain, a matrix kept from an earlier iterate diverges again); an iteration that
// raised the residual is taken back and redone half as long; and the next drift starts with Newton's matrix. Every matrix is G M^{-1} G^T of a band found once from the pattern
// (band_lu.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "raydamp/constraints/constraint_set.hpp"
#include "raydamp/constraints/hook.hpp"
#include "raydamp/damping/damper_damping.hpp"
#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/flows/exact.hpp"
#include "raydamp/flows/runge_kutta.hpp"
#include "raydamp/methods/splitting.hpp"

namespace raydamp {

namespace constraints {

// When an iteration reduces the residual by less than this factor, the Newton matrix is refreshed.
inline constexpr double kSlowContraction = 1.0 / 16;

// out = G x (k), from the non-zeros in G.
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

// v = M^{-1} x by M^{-1}'s non-zeros (ConstraintSet::analyse).
template <class X>
inline void inverse_mass_times(const ConstraintSet& set, const X& x, Eigen::VectorXd& v) {
  if (set.inverse_diagonal.size() != 0) {
    v = set.inverse_diagonal.cwiseProduct(x);
    return;
  }
  v.setZero();
  for (const InverseMassEntry& m : set.inverse_mass) v[m.i] += m.value * x[m.j];
}

// x <- matrix^{-1} x, x in the constraints' order (the band's order inside).
inline void solve(const ConstraintSet& set, const Eigen::VectorXd& matrix, Eigen::VectorXd& x, ConstraintWork& w) {
  if (set.normal.given_order) return set.normal.solve(matrix.data(), x.data());
  const std::vector<int>& position = set.normal.position;
  for (int a = 0; a < set.k; ++a) w.x[position[a]] = x[a];
  set.normal.solve(matrix.data(), w.x.data());
  for (int a = 0; a < set.k; ++a) x[a] = w.x[position[a]];
}

// G(q) and the factor of S = G M^{-1} G^T, at q. False if S is not positive definite (G has lost rank: two
// constraints became dependent) or anything is not finite.
template <class Model, class Q>
bool factor_at(const Model& model, const Q& q, ConstraintWork& w) {
  const ConstraintSet& set = model.constraints;
  set.jacobian(w.G.data(), q.data());
  set.normal.form(w.G.data(), w.G.data(), w.S.data(), true);
  ++w.factorisations;
  w.at_q = q;
  w.last_t = std::numeric_limits<double>::quiet_NaN();  // q moved: no warm start from the last drift
  w.valid = set.normal.factor(w.S.data());
  return w.valid;
}

template <class Model, class Q>
bool factored_at(const Model& model, const Q& q, ConstraintWork& w) {
  if (w.valid && w.at_q == q) return true;
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
  if (!factored_at(model, z.q, w)) {
    if (z.all_finite()) fail(z, w, 0, 0.0, 0.0, 0, true);  // else blown up elsewhere: the step loop reports it
    return;
  }
  const ConstraintSet& set = model.constraints;
  inverse_mass_times(set, z.p, w.v);
  times_G(set, w.G, w.v, w.mu);
  solve(set, w.S, w.mu, w);
  minus_Gt(set, w.G, w.mu, 1.0, z.p);
  if (measure && w.track) {  // in squares: one square root per flow
    inverse_mass_times(set, z.p, w.v);
    times_G(set, w.G, w.v, w.mu);
    const double speed2 = w.v.squaredNorm();
    double worst = 0.0;
    for (int a = 0; a < set.k; ++a) {
      double row2 = 0.0;
      for (int e = set.row_start[a]; e < set.row_start[a + 1]; ++e) row2 += w.G[e] * w.G[e];
      if (speed2 > 0.0 && row2 > 0.0) worst = std::max(worst, w.mu[a] * w.mu[a] / (row2 * speed2));
    }
    w.max_velocity_residual = std::max(w.max_velocity_residual, std::sqrt(worst));
  }
}

// SHAKE then RATTLE's projection over time t (see the file's comment).
template <class Model, int Dim, class WS>
void drift(const Model& model, State<Dim>& z, double t, WS& ws) {
  const ConstraintSet& set = model.constraints;
  ConstraintWork& w = constraint_work(set);
  if (!z.all_finite()) return;  // blown up elsewhere: the step loop reports it as it is
  if (!factored_at(model, z.q, w)) return fail(z, w, 0, 0.0, 0.0, 0, true);
  ++w.drifts;
  flows::drift(model, z, t, ws);
  // The last drift's impulse as Newton's start where this drift is as long and starts where it ended (the
  // next step's drift of the same fraction): its residual is then O(h) smaller than from zero.
  const bool warm = w.last_t == t;
  if (warm) {
    w.lambda = w.lambda_last;
    w.u.setZero();
    minus_Gt(set, w.G, w.lambda, -1.0, w.u);
    inverse_mass_times(set, w.u, w.v);
    z.q -= w.v;
  } else {
    w.lambda.setZero();
  }
  const double q_size = z.q.template lpNorm<Eigen::Infinity>();
  const Eigen::VectorXd* matrix = &w.S;  // SHAKE's chord at q0 until an iteration is slow
  const bool newton = w.newton_next;      // the last drift needed Newton's matrix: take it from the start
  w.newton_next = false;
  double previous_ratio = std::numeric_limits<double>::infinity(), step = 1.0;
  int previous_worst = 0, it = 0;
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
    const bool worse = !finite || worst_ratio > previous_ratio;
    if (worse && it > 0) {  // the last increment overshot: back to the iterate before it, and half as far
      z.q = w.q_back;
      w.lambda = w.lambda_back;
      w.g = w.g_back;
      worst = previous_worst, worst_ratio = previous_ratio, finite = true;
      step *= 0.5;
    } else {
      step = 1.0;
    }
    if (!finite || it == set.max_iterations)
      return fail(z, w, worst, std::abs(w.g[worst]), set.tol * w.g[set.k + worst], it);
    if (it == 0 ? newton : matrix == &w.A || worst_ratio > kSlowContraction * previous_ratio) {
      // Newton's matrix at this iterate (the increment moves q along M^{-1} G(q0)^T).
      set.jacobian(w.G1.data(), z.q.data());
      set.normal.form(w.G1.data(), w.G.data(), w.A.data(), false);
      ++w.refreshes;
      if (it > 0) w.newton_next = true;
      // Not symmetric: a negative pivot is a pivot. Where it cannot be factored, SHAKE's chord goes on.
      matrix = set.normal.factor(w.A.data(), false) ? &w.A : &w.S;
    }
    w.q_back = z.q;
    w.lambda_back = w.lambda;
    w.g_back = w.g;
    previous_ratio = worst_ratio, previous_worst = worst;
    ++w.iterations;
    // L += step matrix^{-1} g(q); q -= M^{-1} G(q0)^T (that increment).
    w.mu = step * w.g.head(set.k);
    solve(set, *matrix, w.mu, w);
    w.lambda += w.mu;
    w.u.setZero();
    minus_Gt(set, w.G, w.mu, -1.0, w.u);
    inverse_mass_times(set, w.u, w.v);
    z.q -= w.v;
    // A correction at the rounding of q cannot reduce g further: g is then as small as doubles allow.
    if (w.v.template lpNorm<Eigen::Infinity>() <= 8 * std::numeric_limits<double>::epsilon() * q_size) {
      evaluated_here = false;
      break;
    }
  }
  if ((it > 0 || warm) && t != 0.0) minus_Gt(set, w.G, w.lambda, 1.0 / t, z.p);
  if (w.track) {
    if (!evaluated_here) set.values(w.g.data(), z.q.data());
    for (int a = 0; a < set.k; ++a)
      if (w.g[set.k + a] > 0.0) w.max_residual = std::max(w.max_residual, std::abs(w.g[a]) / w.g[set.k + a]);
  }
  project(model, z, w, true);
  // Kept for the next drift only while q stays here (factor_at forgets it: a new run's or member's q).
  w.lambda_last = w.lambda;
  w.last_t = t;
}

// The multipliers lambda of the continuous equations p' = F - G^T lambda at a state (q, p) on the
// constraints, F = -grad V(q) + f(t) - eps D M^{-1} p: differentiating G M^{-1} p = 0 along the flow gives
//   (G M^{-1} G^T) lambda = G M^{-1} F + (v^T Hess g_i(q) v)_i,  v = M^{-1} p.
// After a run, per saved row (the bindings): as accurate as the saved state. Allocates (not in a step).
// False where G M^{-1} G^T is singular.
template <class Model>
bool multipliers(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& p, double time,
                 const Load* load, double* out) {
  const ConstraintSet& set = model.constraints;
  ConstraintWork& w = constraint_work(set);
  if (!factor_at(model, q, w)) return false;
  const int n = set.n;
  Eigen::VectorXd force(n), rate(n), velocity(n), both(2 * n), curvature(set.k);
  model.gradient(q, force);
  if (load) load->add(time, -1.0, force.data());
  model.damping.rate(q, p, rate);
  force = -(force + rate);
  model.mass.velocity(force, w.v);
  times_G(set, w.G, w.v, w.mu);
  model.mass.velocity(p, velocity);
  both << q, velocity;
  set.curvature(curvature.data(), both.data());
  w.mu += curvature;
  solve(set, w.S, w.mu, w);
  for (int a = 0; a < set.k; ++a) out[a] = w.mu[a];
  return true;
}

// Dashpots' damp and kick+damp: their exact flow on the tangent space (projected_dampers.hpp, which the
// bindings of a constrained model include).
template <class Model, int Dim, class WS>
void projected_damper_flow(const Model& model, State<Dim>& z, double t, WS& ws, bool with_kick);

// Sub-flow F of a constrained model: the constrained drift, or the free sub-flow then the projection
// (for dashpots, the damp and kick+damp of the projected operator).
// The Runge-Kutta sub-flows that move q (rksb's drift+damp, rk's whole field) are refused before a run
// (the model has no free drift: catalogue.hpp, require_applicable) and never reach here.
template <Flow F, class Model, class Tab, int Dim, class WS>
void flow(const Model& model, const Tab& tab, State<Dim>& z, double t, WS& ws) {
  constexpr bool dashpots = std::is_same_v<std::decay_t<decltype(model.damping)>, DamperDamping>;
  if constexpr (F == Flow::drift) {
    constraints::drift(model, z, t, ws);
    return;
  } else if constexpr (dashpots && (F == Flow::damp || F == Flow::kick_damp)) {
    projected_damper_flow(model, z, t, ws, F == Flow::kick_damp);
    return;
  } else if constexpr (F == Flow::kick) {
    flows::kick(model, z, t, ws);
  } else if constexpr (F == Flow::damp) {
    flows::damp(model, z, t, ws);
    // D = c M: the flow scales p, and a tangent p stays tangent; only its noise needs the projection.
    if constexpr (std::is_same_v<std::decay_t<decltype(model.damping)>, IsotropicDamping>)
      if (!noisy(ws)) return;
  } else if constexpr (F == Flow::kick_damp) {
    flows::kick_damp(model, z, t, ws);
  } else if constexpr (F == Flow::kick_damp_rk) {
    flows::kick_damp_rk(model, tab, z, t, ws);
  } else {
    throw std::logic_error("constraints: a Runge-Kutta sub-flow that moves q has no constrained form");
  }
  project(model, z, constraint_work(model.constraints));
}

}  // namespace constraints
}  // namespace raydamp
