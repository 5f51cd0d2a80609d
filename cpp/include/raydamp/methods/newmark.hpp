// Newmark's average acceleration on a structure with hysteretic springs: one whole step per table (one
// Flow), which only its own stepper runs (implicit/newmark.hpp), and only on a raydamp Structure with
// springs (catalogue.hpp's with_method_for refuses every other kind, naming the method).
#pragma once

#include <array>

#include "raydamp/methods/splitting.hpp"

namespace raydamp {

class NewmarkStepper;  // implicit/newmark.hpp

// gamma = 1/2, beta = 1/4 (OpenSees' `integrator Newmark 0.5 0.25`, the default the issue compares with):
// the trapezoidal rule on q' = v and on p' = f(t) - C v - grad V(q), each step's q found by Newton's
// iteration on the springs' consistent tangent. Order 2; not symmetric in the composition's sense (the
// springs commit once per step), so it is never composed.
struct Newmark {
  static constexpr const char* name = "newmark";
  static constexpr std::array<Stage, 1> stages = {{{Flow::linear_implicit, 1.0}}};
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
  static constexpr bool composable = false;
  using Stepper = NewmarkStepper;
};

}  // namespace raydamp
