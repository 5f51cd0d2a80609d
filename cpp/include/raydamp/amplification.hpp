// The amplification guard of compositions. Every composition of order > 2 has a
// negative coefficient, so some damping sub-flow runs backward for a time
// tau < 0: exp(-tau A) with A = eps D(q) M^{-1} then multiplies the mode of A with
// eigenvalue lambda by e^{|tau| lambda}. For a strongly damped mode (|tau| rho
// large, rho the spectral radius of A) that is a large factor applied to the
// state and its errors, and the composition's error expansion (in powers of h
// times the field's size) no longer describes the step: a high order buys
// nothing and digits are lost. The guard computes the bound before a run,
//   max over the backward damping sub-flows the step loop runs of e^{|tau| rho}
// (for a Runge-Kutta damping sub-flow, |R(|tau| rho)| of its stability function
// where larger, and infinity past a pole), and refuses past kMaxAmplification.
// tau is the duration the loop really runs: where two damping sub-flows meet (3s's
// damp ending one stage and starting the next) that is their merged sum, so 3s's
// backward damping is (gamma_i + gamma_{i+1}) h / 2, not gamma_i h / 2.
// rho comes from the damping kind where it knows it: exactly (spectral_radius()), or
// as a guaranteed upper bound (rate_bound(): a linear structure's alpha + beta L), so
// the promised bound holds; otherwise from the eigenvalues of A at q0 for n <= 64,
// and by power iteration (an estimate from below, which no kind in the library
// reaches) beyond. For D(q) rho changes along the run, so the bound is a check of
// the set-up, not a guarantee for every step.
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "raydamp/composed_step.hpp"
#include "raydamp/methods/butcher_tableau.hpp"
#include "raydamp/methods/composition.hpp"

namespace raydamp {

// A backward damping sub-step may multiply a mode of p by at most this: one
// decimal digit of that mode.
inline constexpr double kMaxAmplification = 10.0;

// rho for the guard, and what it is (the guard's message says which).
struct DampingRate {
  double rho = 0.0;
  const char* what = "";
};

// A damping kind that knows the largest eigenvalue of A exactly (a lattice's blocks, A = a I,
// a rank-one projector, a constant D's eigendecomposition) says so with spectral_radius();
// one that knows a guaranteed upper bound (a sparse structure's alpha + beta L) with rate_bound().
template <class D, class = void>
struct has_spectral_radius : std::false_type {};
template <class D>
struct has_spectral_radius<D, std::void_t<decltype(std::declval<const D&>().spectral_radius())>> : std::true_type {};
template <class D, class = void>
struct has_rate_bound : std::false_type {};
template <class D>
struct has_rate_bound<D, std::void_t<decltype(std::declval<const D&>().rate_bound())>> : std::true_type {};

// The spectral radius of A = eps D(q) M^{-1} at q (or a guaranteed upper bound of it), from
// the damping kind, else from its rate(q, p) = A p: A is similar to the symmetric PSD
// eps L^{-1} D L^{-T}, so its eigenvalues are real and >= 0. Dense for small n; power
// iteration beyond.
template <class Model>
DampingRate damping_rate(const Model& model, const typename Model::Vec& q) {
  constexpr const char* exact = "the spectral radius of eps D M^{-1} at q0";
  if constexpr (has_spectral_radius<decltype(model.damping)>::value) {
    return {model.damping.spectral_radius(), exact};
  } else if constexpr (has_rate_bound<decltype(model.damping)>::value) {
    return {model.damping.rate_bound(), "a guaranteed upper bound of the spectral radius of eps D M^{-1}"};
  } else {
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
      return {rho, exact};
    }
    // Power iteration: converges to the largest eigenvalue (real, >= 0) from below, from a
    // start with a component along it; all-ones plus an irregular part makes that likely.
    constexpr const char* estimate = "the spectral radius of eps D M^{-1} at q0 estimated by power iteration";
    for (int i = 0; i < n; ++i) e[i] = 1.0 + 0.1 * std::sin(1.0 + i);
    double rho = 0.0;
    for (int k = 0; k < 200; ++k) {
      e /= e.norm();
      model.damping.rate(q, e, column);
      const double next = column.norm();
      e = column;
      if (next == 0.0 || std::abs(next - rho) <= 1e-6 * next) return {next, estimate};
      rho = next;
    }
    return {rho, estimate};
  }
}

template <class Model>
double damping_spectral_radius(const Model& model, const typename Model::Vec& q) {
  return damping_rate(model, q).rho;
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

inline constexpr bool is_damping_flow(Flow f) { return f != Flow::drift && f != Flow::kick; }
inline constexpr bool is_runge_kutta_flow(Flow f) {
  return f == Flow::kick_damp_rk || f == Flow::drift_damp_rk || f == Flow::full_rk;
}

// The backward damping sub-step of one step that amplifies most, as the step loop runs it.
struct BackwardStep {
  double factor = 1.0;       // its bound (1: no backward damping sub-step)
  Flow flow = Flow::damp;
  double duration = 0.0;     // tau < 0
  double exponent = 0.0;     // |tau| rho
  int stage = 0;             // the composition stage (from 0); a joint: the stage it ends
  double fraction = 0.0;     // tau = fraction gamma_stage h, or fraction (gamma_stage + gamma_stage+1) h
  bool joint = false;        // the merged end of stage and start of stage + 1
  bool stability = false;    // factor is |R(|tau| rho)| of the tableau (larger than e^{|tau| rho} there)
};

template <class Method>
BackwardStep worst_backward_step(const Composition& composition, const ButcherTableau& tab, double h, double rho) {
  BackwardStep worst;
  StepDurations<Method>(composition, h).for_each([&](Flow f, double tau, int stage, double fraction, bool joint) {
    if (!is_damping_flow(f) || tau >= 0.0) return;
    const double x = -tau * rho;
    double factor = std::exp(x);
    bool stability = false;
    if (is_runge_kutta_flow(f)) {
      const double r = stability_magnitude(tab, x);
      stability = r > factor;
      factor = std::max(factor, r);
    }
    if (factor > worst.factor) worst = {factor, f, tau, x, stage, fraction, joint, stability};
  });
  return worst;
}

// The bound for one step of size h with damping spectral radius rho.
template <class Method>
double amplification_bound(const Composition& composition, const ButcherTableau& tab, double h, double rho) {
  return worst_backward_step<Method>(composition, tab, h, rho).factor;
}

namespace detail {

// "gamma_3", "gamma_3/2", "(gamma_3 + gamma_4)/2", "0.25 gamma_3": the coefficient c of a
// sub-step of duration c h, in the composition's coefficients (counted from 1, as printed).
inline std::string coefficient_formula(const BackwardStep& w) {
  std::ostringstream c;
  const std::string g = "gamma_" + std::to_string(w.stage + 1);
  const std::string sum = w.joint ? "(" + g + " + gamma_" + std::to_string(w.stage + 2) + ")" : g;
  if (w.fraction == 1.0) c << sum;
  else if (w.fraction == 0.5) c << sum << "/2";
  else c << w.fraction << " " << sum;
  return c.str();
}

// The decimal text of a step at most h that passes: h rounded down (never to nearest, which
// suggested 1.13 for a limit of 1.127186, itself refused) at 6 significant figures, then more
// digits only if that text, read back, does not pass.
template <class Passes>
std::string passing_step(double h, Passes passes) {
  if (!(h > 0.0) || !std::isfinite(h)) return "0";
  for (int digits = 6; digits <= 17; ++digits) {
    const double scale = std::pow(10.0, std::floor(std::log10(h)) - (digits - 1));
    for (double units = std::floor(h / scale); units > 0.0; units -= 1.0) {
      std::ostringstream text;
      text << std::setprecision(digits) << units * scale;
      const double back = std::strtod(text.str().c_str(), nullptr);
      if (back <= h && back > 0.0 && passes(back)) return text.str();
      if (units < std::floor(h / scale) - 2.0) break;  // rounding is not the issue: try more digits
    }
  }
  std::ostringstream text;
  text << std::setprecision(17) << h;  // h passes: the bisection kept only passing steps
  return text.str();
}

}  // namespace detail

// Refuses (std::invalid_argument naming composition and h) a composed run whose
// bound at q0 passes kMaxAmplification. The message names the sub-step the bound
// comes from, its coefficient and the formula evaluated on it.
template <class Method, class Model>
void check_amplification(const Model& model, const typename Model::Vec& q0, const ButcherTableau& tab,
                         const Composition& composition, double h) {
  if constexpr (is_mergeable<Method>()) {
    // The base alone, and the near-integrable tables (every sub-step forward), run no damping backward: no
    // rate to estimate (for a large structure, a Lanczos run).
    if (composition.stages() == 1 || composition.is_table()) return;
    const DampingRate rate = damping_rate(model, q0);
    const double rho = rate.rho;
    const BackwardStep worst = worst_backward_step<Method>(composition, tab, h, rho);
    if (worst.factor <= kMaxAmplification) return;
    // The largest h that passes (the bound grows with h): bisection.
    double lo = 0.0, hi = h;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (amplification_bound<Method>(composition, tab, mid, rho) <= kMaxAmplification ? lo : hi) = mid;
    }
    const double c = worst.duration / h;
    std::ostringstream why;
    why.precision(3);
    why << "composition: '" << composition.name() << "' (order " << composition.order() << ") over '"
        << Method::name << "' with h = " << h << " runs the damping backward: its " << flow_name(worst.flow)
        << " sub-step ";
    if (worst.joint)
      why << "joining stages " << worst.stage + 1 << " and " << worst.stage + 2 << " (the end of one merged with "
          << "the start of the next)";
    else
      why << "in stage " << worst.stage + 1;
    why << " lasts c h with c = " << detail::coefficient_formula(worst) << " = " << std::setprecision(6) << c
        << std::setprecision(3);
    if (worst.joint)  // merged, it runs backward less than the most negative coefficient would alone
      why << " (not the composition's most negative coefficient, " << composition.min_gamma() << ": merged)";
    why << ", so it can amplify a damped mode by ";
    if (worst.stability)
      why << "|R(|c| h rho)| of tableau '" << tab.name() << "' = |R(" << std::setprecision(6) << worst.exponent << ")|";
    else
      why << "e^{|c| h rho} = e^{" << std::setprecision(6) << worst.exponent << "}";
    why << std::setprecision(3) << " = " << worst.factor << " with rho = " << std::setprecision(6) << rho << " ("
        << rate.what << ")" << std::setprecision(3) << ", past the limit " << kMaxAmplification
        << "; use the order-2 method (composition=None) or h <= "
        << detail::passing_step(lo, [&](double x) {
             return amplification_bound<Method>(composition, tab, x, rho) <= kMaxAmplification;
           });
    throw std::invalid_argument(why.str());
  }
}

}  // namespace raydamp
