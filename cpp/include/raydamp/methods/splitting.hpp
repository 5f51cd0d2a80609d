// Methods are data: a list of sub-flows, each with the fraction of h it runs for.
// The paper writes maps right to left; a table lists them in the order applied.
// Tables are built as palindromes from their first half (the mirror is derived,
// never typed twice) and validated at compile time.
#pragma once

#include <array>
#include <cstddef>
#include <type_traits>

namespace raydamp {

enum class Flow {
  drift,          // exp(t X_T), exact
  kick,           // exp(t X_V), exact
  damp,           // exp(t eps Y), exact
  kick_damp,      // exp(t (X_V + eps Y)), exact
  kick_damp_rk,   // Runge-Kutta step of X_V + eps Y (q frozen), tableau chosen at run time
  drift_damp_rk,  // explicit Runge-Kutta step of X_T + eps Y
  full_rk,        // explicit Runge-Kutta step of the whole field
  linear_implicit,  // implicit step of a linear structure's whole system (methods/linear_implicit.hpp)
};

inline constexpr int n_flows = 8;

inline constexpr const char* flow_name(Flow f) {
  switch (f) {
    case Flow::drift: return "drift";
    case Flow::kick: return "kick";
    case Flow::damp: return "damp";
    case Flow::kick_damp: return "kick_damp";
    case Flow::kick_damp_rk: return "kick_damp_rk";
    case Flow::drift_damp_rk: return "drift_damp_rk";
    case Flow::linear_implicit: return "linear_implicit";
    default: return "full_rk";
  }
}

struct Stage {
  Flow flow;
  double fraction;  // of the step size h
};

// A symmetric table from its first half plus the middle stage.
template <std::size_t N>
constexpr std::array<Stage, 2 * N - 1> palindrome(const std::array<Stage, N>& half) {
  std::array<Stage, 2 * N - 1> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = out[2 * N - 2 - i] = half[i];
  return out;
}

// Each sub-flow used must run for a total of exactly h: otherwise the method is
// not even consistent.
template <std::size_t N>
constexpr bool fractions_sum_to_one(const std::array<Stage, N>& stages) {
  for (int f = 0; f < n_flows; ++f) {
    double total = 0.0;
    bool used = false;
    for (const auto& s : stages)
      if (static_cast<int>(s.flow) == f) {
        total += s.fraction;
        used = true;
      }
    if (used && total != 1.0) return false;
  }
  return true;
}

template <std::size_t N>
constexpr bool is_symmetric(const std::array<Stage, N>& stages) {
  for (std::size_t i = 0; i < N; ++i)
    if (stages[i].flow != stages[N - 1 - i].flow || stages[i].fraction != stages[N - 1 - i].fraction) return false;
  return true;
}

enum class TableauUse { none, any_diagonally_implicit, explicit_only };

// Each method: its stages, whether it takes a Butcher tableau, and the highest
// order the splitting itself can reach (a symmetric splitting: 2).
struct StormerVerlet {
  static constexpr const char* name = "sv";
  static constexpr std::array<Stage, 3> stages = palindrome<2>({{{Flow::drift, 0.5}, {Flow::kick, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
};

struct ThreeTermSplitting {  // paper Algorithm 3S
  static constexpr const char* name = "3s";
  static constexpr std::array<Stage, 5> stages =
      palindrome<3>({{{Flow::damp, 0.5}, {Flow::drift, 0.5}, {Flow::kick, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
};

// BAOAB (Leimkuhler and Matthews): kick h/2, drift h/2, damp h, drift h/2, kick h/2. The same palindrome
// as 3s with the damping in the middle; at a temperature its damping flow is the exact OU flow, the
// molecular-dynamics standard (OpenMM's LangevinMiddleIntegrator), here with any damping kind.
struct Baoab {
  static constexpr const char* name = "baoab";
  static constexpr std::array<Stage, 5> stages =
      palindrome<3>({{{Flow::kick, 0.5}, {Flow::drift, 0.5}, {Flow::damp, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
};

struct TwoTermSplitting {  // paper Algorithm 2S
  static constexpr const char* name = "2s";
  static constexpr std::array<Stage, 3> stages = palindrome<2>({{{Flow::drift, 0.5}, {Flow::kick_damp, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::none;
  static constexpr int splitting_order = 2;
};

struct RungeKuttaSplitting {  // paper Algorithm RKS
  static constexpr const char* name = "rks";
  static constexpr std::array<Stage, 3> stages = palindrome<2>({{{Flow::drift, 0.5}, {Flow::kick_damp_rk, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::any_diagonally_implicit;
  static constexpr int splitting_order = 2;
};

struct RungeKuttaSplittingB {  // the counter-example RKS-B, end of paper section 5
  static constexpr const char* name = "rksb";
  static constexpr std::array<Stage, 3> stages = palindrome<2>({{{Flow::kick, 0.5}, {Flow::drift_damp_rk, 1.0}}});
  static constexpr TableauUse tableau = TableauUse::explicit_only;
  static constexpr int splitting_order = 2;
};

struct RungeKutta {  // a classical Runge-Kutta method on the whole system
  static constexpr const char* name = "rk";
  static constexpr std::array<Stage, 1> stages = {{{Flow::full_rk, 1.0}}};
  static constexpr TableauUse tableau = TableauUse::explicit_only;
  static constexpr int splitting_order = 1000;  // no splitting error: the tableau decides
  static constexpr bool integrates_work = true;  // full_rk integrates W with its own stages
};

// Methods whose steps accumulate the damping work themselves; for the others the
// step loop integrates W by the trapezoidal rule (order 2, their order).
template <class Method, class = void>
struct integrates_work : std::false_type {};
template <class Method>
struct integrates_work<Method, std::void_t<decltype(Method::integrates_work)>>
    : std::bool_constant<Method::integrates_work> {};

template <class Method>
constexpr bool uses_tableau() {
  for (const auto& stage : Method::stages)
    if (stage.flow == Flow::kick_damp_rk || stage.flow == Flow::drift_damp_rk || stage.flow == Flow::full_rk)
      return true;
  return false;
}

inline constexpr bool is_exact_flow(Flow f) {
  return f == Flow::drift || f == Flow::kick || f == Flow::damp || f == Flow::kick_damp;
}

// A table whose ends can be merged (composed_step.hpp): symmetric, at least three stages, and its end
// sub-flow an exact flow (a Runge-Kutta step for h1 then h2 is not the step for h1 + h2).
template <class Method>
constexpr bool is_mergeable() {
  constexpr std::size_t S = Method::stages.size();
  if constexpr (S < 3) return false;
  else return is_symmetric(Method::stages) && is_exact_flow(Method::stages[0].flow);
}

template <class Method>
constexpr bool valid_table() {
  return fractions_sum_to_one(Method::stages) && is_symmetric(Method::stages);
}
static_assert(valid_table<StormerVerlet>() && valid_table<ThreeTermSplitting>() && valid_table<TwoTermSplitting>() &&
              valid_table<RungeKuttaSplitting>() && valid_table<RungeKuttaSplittingB>() && valid_table<RungeKutta>());

// Whether a table can run at a temperature: only exact sub-flows (each damping flow then its exact
// OU flow) and at least one damping flow. Runge-Kutta sub-flows have no exact noise.
template <class Method>
constexpr bool takes_temperature() {
  bool damps = false;
  for (const auto& s : Method::stages) {
    if (s.flow == Flow::damp || s.flow == Flow::kick_damp) damps = true;
    else if (s.flow != Flow::drift && s.flow != Flow::kick) return false;
  }
  return damps;
}

}  // namespace raydamp
