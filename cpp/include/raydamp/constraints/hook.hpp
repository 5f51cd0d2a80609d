// The constrained-model capability as the step loop sees it: a model with a `constraints` member runs
// constraints::flow (constraints/rattle.hpp, included where such a model is bound) for each sub-flow.
// Only the trait and the declaration live here, so the step loop of every other model compiles as before.
#pragma once

#include <type_traits>
#include <utility>

#include "raydamp/methods/splitting.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

template <class M, class = void>
struct has_constraints : std::false_type {};
template <class M>
struct has_constraints<M, std::void_t<decltype(std::declval<const M&>().constraints)>> : std::true_type {};

namespace constraints {
template <Flow F, class Model, class Tab, int Dim, class WS>
void flow(const Model& model, const Tab& tab, State<Dim>& z, double t, WS& ws);
}  // namespace constraints

}  // namespace raydamp
