// One step of a method: its table of sub-flows, expanded at compile time, so the
// step is straight-line code with no branch on the table and no virtual call.
#pragma once

#include <cstddef>
#include <utility>

#include "raydamp/constraints/hook.hpp"
#include "raydamp/flows/exact.hpp"
#include "raydamp/flows/runge_kutta.hpp"
#include "raydamp/methods/splitting.hpp"

namespace raydamp {

template <Flow F, class Model, class Tab, int Dim, class WS>
inline void apply_flow(const Model& model, const Tab& tab, State<Dim>& z, double t, WS& ws) {
  if constexpr (has_constraints<Model>::value) constraints::flow<F>(model, tab, z, t, ws);  // RATTLE's sub-flows
  else if constexpr (F == Flow::drift) flows::drift(model, z, t, ws);
  else if constexpr (F == Flow::kick) flows::kick(model, z, t, ws);
  else if constexpr (F == Flow::damp) flows::damp(model, z, t, ws);
  else if constexpr (F == Flow::kick_damp) flows::kick_damp(model, z, t, ws);
  else if constexpr (F == Flow::kick_damp_rk) flows::kick_damp_rk(model, tab, z, t, ws);
  else if constexpr (F == Flow::drift_damp_rk) flows::drift_damp_rk(model, tab, z, t, ws);
  else flows::full_rk(model, tab, z, t, ws);
}

template <class Method, class Model, class Tab, int Dim, class WS, std::size_t... I>
inline void step_stages(const Model& model, const Tab& tab, State<Dim>& z, double h, WS& ws,
                        std::index_sequence<I...>) {
  (apply_flow<Method::stages[I].flow>(model, tab, z, Method::stages[I].fraction * h, ws), ...);
}

// z <- Phi^h(z) for Method (tab, a ButcherTableau or FixedTableau, is ignored by
// methods without a Runge-Kutta stage).
template <class Method, class Model, class Tab, int Dim, class WS>
inline void step(const Model& model, const Tab& tab, State<Dim>& z, double h, WS& ws) {
  step_stages<Method>(model, tab, z, h, ws, std::make_index_sequence<Method::stages.size()>{});
}

}  // namespace raydamp
