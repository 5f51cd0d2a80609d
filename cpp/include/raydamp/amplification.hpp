// The amplification guard of compositions. Every composition of order > 2 has a
// negative coefficient, so some damping sub-flow runs backward for a time
// tau < 0: exp(-tau A) with A = eps D(q) M^{-1} then multiplies the mode of A with
// eigenvalue lambda by e^{|tau| lambda}. For a strongly damped mode (|tau| rho
// large, rho the spectral radius of A) that is a large factor applied to the
// state and its errors, and the composition's error expansion (in powers of h
// times the field's size) no longer describes the step: a high order buys
// nothing and digits are lost. The guard computes the bound before a run,
//   max over backward damping sub-flows of e^{|tau| rho}
// (for a Runge-Kutta damping sub-flow, |R(|tau| rho)| of its stability function
// where larger, and infinity past a pole), and refuses past kMaxAmplification.
// rho is taken at q0; for D(q) it changes along the run, so the bound is a check
// of the set-up, not a guarantee for every step.
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "raydamp/composed_step.hpp"
#include "raydamp/methods/butcher_tableau.hpp"
#include "raydamp/methods/composition.hpp"

namespace raydamp {

// A backward damping sub-step may multiply a mode of p by at most this: one
// decimal digit of that mode.
inline constexpr double kMaxAmplification = 10.0;

// The spectral radius of A = eps D(q) M^{-1} at q, from the damping kind's own
// rate(q, p) = A p: A is similar to the symmetric PSD eps L^{-1} D L^{-T}, so its
// eigenvalues are real and >= 0. Dense for small n; power iteration beyond.
template <class D, class = void>
struct has_spectral_radius : std::false_type {};
template <class D>
struct has_spectral_radius<D, std::void_t<decltype(std::declval<const D&>().spectral_radius())>> : std::true_type {};

template <class Model>
double damping_spectral_radius(const Model& model, const typename Model::Vec& q) {
  // A damping kind that knows its eigenvalues (a lattice's blocks) says so directly.
  if constexpr (has_spectral_radius<decltype(model.damping)>::value) return model.damping.spectral_radius();
  const int n = model.size();
  typename Model::Vec e = Model::Vec::Zero(n), column = Model::Vec::Zero(n);
  if (n <= 64) {
    Eigen::MatrixXd a(n, n);
    for (int j = 0; j < n; ++j) {
      e.setZero();
      e[j] = 1.0;
      model.damping.rate(q, e, column);
      for (int i = 0; i < n; ++i) a(i, j) = column[i];
    }
    Eigen::EigenSolver<Eigen::MatrixXd> eig(a, false);
    double rho = 0.0;
    for (int i = 0; i < n; ++i) rho = std::max(rho, std::abs(eig.eigenvalues()[i]));
    return rho;
  }
  // Power iteration: converges to the largest eigenvalue (real, >= 0) from a start
  // with a component along it; all-ones plus an irregular part makes that likely.
  for (int i = 0; i < n; ++i) e[i] = 1.0 + 0.1 * std::sin(1.0 + i);
  double rho = 0.0;
  for (int k = 0; k < 200; ++k) {
    e /= e.norm();
    model.damping.rate(q, e, column);
    const double next = column.norm();
    e = column;
    if (next == 0.0 || std::abs(next - rho) <= 1e-6 * next) return next;
    rho = next;
  }
  return rho;
}

// |R(z)| of a Runge-Kutta tableau, R(z) = 1 + z b^T (I - z A)^{-1} 1, for the
// backward damping flow p' = -lambda p over tau < 0 (z = |tau| lambda > 0);
// infinity at or past a pole of a diagonally implicit stage (1 - z a_ii <= 0).
inline double stability_magnitude(const ButcherTableau& tab, double z) {
  const int s = tab.stages();
  std::vector<double> k(s);  // stage values Y_i of y' = y from y = 1, scaled by z
  double r = 1.0;
  for (int i = 0; i < s; ++i) {
    double rhs = 1.0;
    for (int j = 0; j < i; ++j) rhs += z * tab.a(i, j) * k[j];
    const double denominator = 1.0 - z * tab.a(i, i);
    if (denominator <= 0.0) return std::numeric_limits<double>::infinity();
    k[i] = rhs / denominator;
    r += z * tab.b(i) * k[i];
  }
  return std::abs(r);
}

inline bool is_damping_flow(Flow f) { return f != Flow::drift && f != Flow::kick; }

// The bound for one step of size h with damping spectral radius rho.
template <class Method>
double amplification_bound(const Composition& composition, const ButcherTableau& tab, double h, double rho) {
  double bound = 1.0;
  StepDurations<Method>(composition, h).for_each([&](Flow f, double tau) {
    if (!is_damping_flow(f) || tau >= 0.0) return;
    const double x = -tau * rho;
    double factor = std::exp(x);
    if (f == Flow::kick_damp_rk || f == Flow::drift_damp_rk || f == Flow::full_rk)
      factor = std::max(factor, stability_magnitude(tab, x));
    bound = std::max(bound, factor);
  });
  return bound;
}

// Refuses (std::invalid_argument naming composition and h) a composed run whose
// bound at q0 passes kMaxAmplification.
template <class Method, class Model>
void check_amplification(const Model& model, const typename Model::Vec& q0, const ButcherTableau& tab,
                         const Composition& composition, double h) {
  if constexpr (is_mergeable<Method>()) {
    if (composition.stages() == 1) return;
    const double rho = damping_spectral_radius(model, q0);
    const double bound = amplification_bound<Method>(composition, tab, h, rho);
    if (bound <= kMaxAmplification) return;
    // The largest h that passes (the bound grows with h): bisection.
    double lo = 0.0, hi = h;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (amplification_bound<Method>(composition, tab, mid, rho) <= kMaxAmplification ? lo : hi) = mid;
    }
    std::ostringstream why;
    why.precision(3);
    why << "composition: '" << composition.name() << "' (order " << composition.order() << ") over '"
        << Method::name << "' with h = " << h << " runs the damping backward (coefficient "
        << composition.min_gamma() << "), amplifying a damped mode by up to " << bound
        << " per backward sub-step (bound e^{|gamma h| rho} with rho = " << rho
        << ", the spectral radius of eps D M^{-1} at q0), past the limit " << kMaxAmplification
        << "; use the order-2 method (composition=None) or h <= " << lo;
    throw std::invalid_argument(why.str());
  }
}

}  // namespace raydamp
