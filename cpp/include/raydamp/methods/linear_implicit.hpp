// Implicit methods on the whole of a linear structure's system
//   M q'' + C q' + K q = f,  C = alpha M + beta K  (q' = M^{-1} p),
// the Gauss (Gauss-Legendre collocation) Runge-Kutta methods: A-stable, symmetric,
// symplectic when undamped, exact on quadratic invariants. On a linear system with
// constant f a step of the s-stage method is y1 = y0 + h Q(hA)^{-1} (A y0 + b),
// Q the denominator of the (s, s) Pade approximant of exp, and each step is sparse
// solves with M + c C + c^2 K for c = h / (a root of Q): the steps themselves are
// implicit/linear_implicit_step.hpp. A table here is one whole step (one Flow),
// which only that stepper runs, and only on a LinearStructure.
#pragma once

#include <array>

#include "raydamp/methods/splitting.hpp"

namespace raydamp {

template <class Method>
class LinearImplicitStepper;  // implicit/linear_implicit_step.hpp

// Implicit midpoint (Gauss, 1 stage, order 2). Q(z) = 1 - z/2: one real solve
// with M + (h/2) C + (h^2/4) K per step. For a linear structure it is Newmark's
// average acceleration (gamma = 1/2, beta = 1/4; the trapezoidal rule) with the load
// sampled at t + h/2, and it balances energy exactly over a step:
// H(z1) - H(z0) = -h vbar^T C vbar + h f^T vbar (H without the load's potential).
struct ImplicitMidpoint {
  static constexpr const char* name = "midpoint";
  static constexpr std::array<Stage, 1> stages = {{{Flow::linear_implicit, 1.0}}};
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
  static constexpr bool integrates_work = true;  // W over a step is exactly h vbar^T C vbar
  static constexpr bool composable = true;      // symmetric, order 2: a composition's base
  using Stepper = LinearImplicitStepper<ImplicitMidpoint>;
};

// The 2-stage Gauss method (order 4). Q(z) = 1 - z/2 + z^2/12 has the complex roots
// mu, conj(mu) = 3 +- i sqrt(3): one complex symmetric solve with
// M + c C + c^2 K, c = h / mu, per step.
struct Gauss4 {
  static constexpr const char* name = "gauss4";
  static constexpr std::array<Stage, 1> stages = {{{Flow::linear_implicit, 1.0}}};
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 4;
  static constexpr bool integrates_work = true;  // the Gauss quadrature of the stage velocities: exact too
  static constexpr bool composable = false;     // already order 4 (the compositions raise order 2)
  using Stepper = LinearImplicitStepper<Gauss4>;
};

}  // namespace raydamp
