// The methods raydamp offers, by name, with what each needs and the order it has.
// Python and the service read this catalogue instead of writing it again.
#pragma once

#include <algorithm>
#include <utility>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/materials/commit.hpp"
#include "raydamp/methods/butcher_tableau.hpp"
#include "raydamp/methods/composition.hpp"
#include "raydamp/methods/linear_implicit.hpp"
#include "raydamp/methods/newmark.hpp"
#include "raydamp/methods/splitting.hpp"
#include "raydamp/methods/user_tableaux.hpp"

namespace raydamp {

struct MethodEntry {
  std::string name;
  std::string description;
  std::string table;  // the stage table it runs: the Method type's name
  TableauUse tableau_use;
  int splitting_order;
  std::string default_tableau;  // "" when the method has no Runge-Kutta stage
  bool tableau_fixed;           // heun and rk4 are one tableau each
  bool ignores_damping;         // sv: applying it to a damped model would silently drop eps
  bool symmetric_table;         // its table can be composed (with a symmetric tableau, if it takes one)
  bool linear_implicit = false;  // an implicit step of a LinearStructure's whole system, for that kind only
  bool free_drift_in_rk = false;  // a Runge-Kutta stage steps the kinetic part as q' = M^{-1} p (rksb, rk)
  bool springs_only = false;      // a nonlinear implicit step of a Structure with springs (newmark), that kind only
  int table_stages = 0;           // sub-flows of its stage table (0: an implicit method's own step)
};

template <class Method>
constexpr bool steps_free_drift_in_rk() {
  for (const Stage& s : Method::stages)
    if (s.flow == Flow::drift_damp_rk || s.flow == Flow::full_rk) return true;
  return false;
}

// An entry whose table, tableau use and order come from the Method type itself.
template <class Method>
MethodEntry entry(std::string name, std::string description, std::string default_tableau = "",
                  bool tableau_fixed = false, bool ignores_damping = false) {
  MethodEntry e{std::move(name),    std::move(description), Method::name,    Method::tableau,
                Method::splitting_order, std::move(default_tableau), tableau_fixed, ignores_damping,
                is_mergeable<Method>(), false, steps_free_drift_in_rk<Method>()};
  e.table_stages = static_cast<int>(Method::stages.size());
  return e;
}

// The implicit methods of a linear structure's whole system (methods/linear_implicit.hpp).
template <class Method>
MethodEntry linear_implicit_entry(std::string name, std::string description) {
  return {std::move(name), std::move(description), Method::name, Method::tableau, Method::splitting_order, "",
          false, false, Method::composable, true};
}

inline const std::vector<MethodEntry>& method_entries() {
  static const std::vector<MethodEntry> entries{
      entry<StormerVerlet>("sv", "Stormer-Verlet: drift h/2, kick h, drift h/2 (ignores damping; the eps = 0 reference)",
                           "", false, true),
      entry<ThreeTermSplitting>(
          "3s", "three-term splitting (paper Algorithm 3S): damp h/2, drift h/2, kick h, drift h/2, damp h/2"),
      entry<Baoab>("baoab",
                   "BAOAB: kick h/2, drift h/2, damp h, drift h/2, kick h/2 (at a temperature: the exact OU damping "
                   "flow in the middle, the Langevin standard)"),
      entry<TwoTermSplitting>("2s", "two-term splitting (paper Algorithm 2S): drift h/2, exact kick+damp h, drift h/2"),
      entry<RungeKuttaSplitting>(
          "rks", "Runge-Kutta splitting (paper Algorithm RKS): drift h/2, one RK step of kick+damp, drift h/2", "heun"),
      entry<RungeKuttaSplittingB>("rksb",
                                  "the paper's counter-example RKS-B: kick h/2, one RK step of drift+damp, kick h/2 "
                                  "(not momentum-conserving)",
                                  "heun"),
      entry<RungeKutta>("heun", "Heun's method on the whole system (the paper's baseline)", "heun", true),
      entry<RungeKutta>("rk4", "classical fourth-order Runge-Kutta on the whole system", "rk4", true),
      entry<RungeKutta>("rk", "any explicit Runge-Kutta tableau on the whole system (ours by name, or your own)",
                        "rk4"),
      linear_implicit_entry<ImplicitMidpoint>(
          "midpoint",
          "implicit midpoint rule on the whole linear system M q'' + C q' + K q = f (LinearStructure only): "
          "unconditionally stable, one sparse solve with M + (h/2) C + (h^2/4) K per step; Newmark average "
          "acceleration for free vibration; symplectic when undamped; exact discrete energy balance "
          "H(z1) - H(z0) = -h vbar^T C vbar + h f^T vbar"),
      linear_implicit_entry<Gauss4>(
          "gauss4",
          "2-stage Gauss method on the whole linear system (LinearStructure only): order 4, A-stable, "
          "symplectic when undamped, exact energy balance (Gauss quadrature of the stage velocities); one "
          "complex sparse solve with M + c C + c^2 K (c = h / (3 + i sqrt 3)) per step"),
      {"newmark",
       "Newmark average acceleration (gamma = 1/2, beta = 1/4) on a Structure with springs (that kind only), as "
       "OpenSees runs it: the trapezoidal rule on the spring forces, Newton's iteration on their consistent "
       "tangent per step (one sparse solve with M + (h/2) C + (h^2/4) K0 per iteration, the yielded springs by a "
       "low-rank correction); a step that does not converge ends the run, status not_converged",
       Newmark::name, Newmark::tableau, Newmark::splitting_order, "", false, false, Newmark::composable, false,
       false, true},
  };
  return entries;
}

inline std::string known_methods() {
  std::string known;
  for (auto& m : method_entries()) known += (known.empty() ? "" : ", ") + m.name;
  return known;
}

inline const MethodEntry& method_entry(const std::string& name) {
  for (auto& m : method_entries())
    if (m.name == name) return m;
  throw std::invalid_argument("method: unknown method '" + name + "' (known: " + known_methods() + ")");
}

// The tableau a run of `method` uses when asked for `tableau` ("" = the default);
// refuses, naming the argument, a tableau the method cannot use.
inline const ButcherTableau& resolve_tableau(const MethodEntry& method, const std::string& tableau) {
  if (method.tableau_use == TableauUse::none) {
    if (!tableau.empty())
      throw std::invalid_argument("tableau: method '" + method.name + "' has no Runge-Kutta stage, so it takes no tableau");
    return builtin_tableau("euler");  // unused by the step
  }
  if (method.tableau_fixed && !tableau.empty() && tableau != method.default_tableau)
    throw std::invalid_argument("tableau: method '" + method.name + "' is the tableau '" + method.default_tableau +
                                "'; for another tableau on the whole system there is no separate method yet");
  const ButcherTableau& tab = tableau_named(tableau.empty() ? method.default_tableau : tableau);
  const bool users = tab.name().rfind("custom-", 0) == 0;
  const std::string which = users ? "the given tableau" : "'" + tab.name() + "'";
  if (method.tableau_use == TableauUse::explicit_only && !tab.is_explicit())
    throw std::invalid_argument("tableau: method '" + method.name + "' needs an explicit tableau (a_ij = 0 for "
                                "j >= i); " + which + " is implicit");
  if (tab.kind() == TableauKind::implicit)
    throw std::invalid_argument("tableau: " + which + " is fully implicit (a_ij != 0 above the diagonal): its "
                                "stages would be one coupled nonlinear system per step; rks solves diagonally "
                                "implicit stages one at a time, each a linear solve in p");
  return tab;
}

// A method that would silently compute something else refuses: sv has no damping
// sub-flow, so on a damped model it would integrate the undamped system.
inline void require_applicable(const MethodEntry& method, double eps) {
  if (method.ignores_damping && eps != 0.0)
    throw std::invalid_argument("method: '" + method.name + "' ignores damping and this model has eps = " +
                                std::to_string(eps) + " > 0; use 3s, 2s or rks, which are '" + method.name +
                                "' when eps = 0");
}

// A model whose drift is another exact flow than q += t M^{-1} p (models/kepler.hpp: the Kepler
// flow) says so with `static constexpr bool free_drift = false`. A method that steps the kinetic
// part inside a Runge-Kutta stage, or the whole system implicitly, would then integrate another
// system, and refuses.
template <class Model, class = void>
struct has_free_drift : std::true_type {};
template <class Model>
struct has_free_drift<Model, std::void_t<decltype(Model::free_drift)>> : std::bool_constant<Model::free_drift> {};

inline std::invalid_argument free_drift_refusal(const std::string& method, const char* model) {
  return std::invalid_argument("method: '" + method + "' steps the kinetic energy as a free drift (q' = M^{-1} p) "
                               "inside a Runge-Kutta or implicit stage, and this model's drift is the exact flow of " +
                               std::string(model) + "; use sv, 3s, 2s, baoab or rks");
}

template <class Model>
void require_applicable(const MethodEntry& method, const Model& model) {
  require_applicable(method, model.eps);
  if constexpr (!has_free_drift<Model>::value) {
    if (method.free_drift_in_rk || method.linear_implicit) throw free_drift_refusal(method.name, Model::name);
  }
}

inline int method_order(const MethodEntry& method, const ButcherTableau& tab) {
  if (method.tableau_use == TableauUse::none) return method.splitting_order;
  return std::min(method.splitting_order, tab.order());
}

// Whether (method, tableau) is a symmetric step of order 2, the base a composition
// raises to its order: a symmetric table whose Runge-Kutta sub-flow, if any, is
// itself symmetric (implicit midpoint; no explicit tableau is).
inline bool is_composable(const MethodEntry& method, const ButcherTableau& tab) {
  if (!method.symmetric_table) return false;
  if (method.tableau_use != TableauUse::none && !tab.is_symmetric()) return false;
  return method_order(method, tab) == 2;
}

// The composition a run of (method, tableau) uses when asked for `composition`
// ("" = none); refuses, naming the argument, a base that is not symmetric.
inline const Composition& resolve_composition(const MethodEntry& method, const ButcherTableau& tab,
                                              const std::string& composition) {
  const Composition& c = builtin_composition(composition);
  if (c.is_table() && (method.table_stages != 3 || !is_composable(method, tab)))
    throw std::invalid_argument("composition: '" + c.name() + "' is a near-integrable table of a symmetric base "
                                "drift, kick, drift (sv, 2s, or rks with tableau='midpoint'), and method '" +
                                method.name + "' is not one");
  if (c.stages() == 1 || is_composable(method, tab)) return c;
  std::string base = "'" + method.name + "'";
  if (method.tableau_use != TableauUse::none) base += " with tableau '" + tab.name() + "'";
  throw std::invalid_argument("composition: '" + c.name() + "' composes a symmetric order-2 step, and method " + base +
                              " is not one; use sv, 3s, 2s, rks with tableau='midpoint', or midpoint (a "
                              "LinearStructure)");
}

// The order of a run: the composition's, over a symmetric order-2 base.
inline int method_order(const MethodEntry& method, const ButcherTableau& tab, const Composition& composition) {
  return composition.stages() == 1 ? method_order(method, tab) : composition.order();
}

namespace detail {

template <class F, class Method, class... Rest>
decltype(auto) with_table(const std::string& table, F& f) {
  if (table == Method::name) return f(Method{});
  if constexpr (sizeof...(Rest) > 0) return with_table<F, Rest...>(table, f);
  else throw std::logic_error("catalogue: no stage table named '" + table + "'");
}

}  // namespace detail

// A model that is one linear system M q'' + C q' + K q = f as a whole says so with
// `static constexpr bool linear_system = true` (models/linear_structure.hpp); only such a
// model runs the implicit methods, which step that whole system at once.
template <class Model, class = void>
struct is_linear_system : std::false_type {};
template <class Model>
struct is_linear_system<Model, std::void_t<decltype(Model::linear_system)>>
    : std::bool_constant<Model::linear_system> {};

// Calls f(MethodType{}) for the method named `name` on a model of type Model: the one place a
// name becomes a type. An implicit method on a model that is not a linear system is refused,
// naming the method.
template <class Model, class F>
decltype(auto) with_method_for(const std::string& name, F&& f) {
  const MethodEntry& entry = method_entry(name);
  if (entry.springs_only) {
    if constexpr (has_materials_v<Model>) {
      return detail::with_table<F, Newmark>(entry.table, f);
    } else {
      throw std::invalid_argument("method: '" + name + "' is Newton's iteration on the springs of a raydamp.Structure "
                                  "and runs only that kind; for this model use 3s, 2s or rks (or 'midpoint', the "
                                  "same average acceleration, on a LinearStructure)");
    }
  }
  if constexpr (!has_free_drift<Model>::value) {
    // rksb, rk and the implicit methods are refused for such a model (require_applicable, which every
    // caller runs first): not instantiated for it either, which saves their compile time.
    if (entry.free_drift_in_rk || entry.linear_implicit) throw free_drift_refusal(name, Model::name);
    return detail::with_table<F, StormerVerlet, ThreeTermSplitting, Baoab, TwoTermSplitting, RungeKuttaSplitting>(
        entry.table, f);
  } else {
    if (!entry.linear_implicit)
      return detail::with_table<F, StormerVerlet, ThreeTermSplitting, Baoab, TwoTermSplitting, RungeKuttaSplitting,
                                RungeKuttaSplittingB, RungeKutta>(entry.table, f);
    if constexpr (is_linear_system<Model>::value) {
      return detail::with_table<F, Gauss4, ImplicitMidpoint>(entry.table, f);
    } else {
      throw std::invalid_argument("method: '" + name + "' is an implicit step of a linear structure's whole system "
                                  "M q'' + C q' + K q = f, and runs only a raydamp.LinearStructure; for this model "
                                  "use 3s, 2s or rks");
    }
  }
}

// with_method_for on no model: the explicit tables, for a caller that reads a table or runs a
// model of its own (the implicit methods are refused).
template <class F>
decltype(auto) with_method(const std::string& name, F&& f) {
  return with_method_for<void>(name, std::forward<F>(f));
}

}  // namespace raydamp
