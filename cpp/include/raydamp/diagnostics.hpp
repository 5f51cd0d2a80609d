// Quantities the step loop and the analysis read off a state: dissipated power and
// the modified Hamiltonian of Stormer-Verlet.
#pragma once

#include <type_traits>
#include <utility>

#include "raydamp/state.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp {

// eps d_q(qdot, qdot) = eps qdot^T D(q) qdot, the rate of energy loss of the exact
// flow (paper equation exact_energy_dissipation_rate). With v = M^{-1} p and
// A p = eps D M^{-1} p it is v . (A p), so it needs no model function of its own.
// A model whose damping touches few coordinates (a lattice with a few dashpots) may
// give the power itself, model.dissipated_power(q, p), without two passes over n.
template <class M, class = void>
struct has_dissipated_power : std::false_type {};
template <class M>
struct has_dissipated_power<M, std::void_t<decltype(std::declval<const M&>().dissipated_power(
                                   std::declval<const typename M::Vec&>(), std::declval<const typename M::Vec&>()))>>
    : std::true_type {};

template <class Model, int Dim, class WS>
double dissipated_power(const Model& model, const State<Dim>& z, WS& ws) {
  if constexpr (has_dissipated_power<Model>::value) return model.dissipated_power(z.q, z.p);
  model.mass.velocity(z.p, ws.v);
  model.damping.rate(z.q, z.p, ws.f);
  return ws.v.dot(ws.f);
}

// The modified Hamiltonian of the drift-kick-drift Stormer-Verlet step
// exp(h/2 X_T) exp(h X_V) exp(h/2 X_T), truncated after h^2 (paper Lemma 4.4 in the
// LaTeX source gives its form). The symmetric BCH formula
//   log(e^{X/2} e^{Y} e^{X/2}) = X + Y - 1/24 [X,[X,Y]] - 1/12 [Y,[X,Y]] + ...
// with X = h X_T, Y = h X_V, and {T,{T,V}} = v^T V''(q) v, {V,{V,T}} = grad V^T M^{-1} grad V
// (v = M^{-1} p) gives
//   H_h = T + V + h^2 ( grad V^T M^{-1} grad V / 12 - v^T V''(q) v / 24 ) + O(h^4).
// (For the harmonic oscillator this is the invariant (1 - h^2/4) p^2/2 + q^2/2 up to
// a factor 1 + O(h^2); the tests check the O(h^4) conservation numerically.)
template <class Model, int Dim, class WS>
double modified_energy_sv(const Model& model, const State<Dim>& z, double h, WS& ws) {
  model.gradient(z.q, ws.g);
  model.mass.velocity(ws.g, ws.f);
  const double force_term = ws.g.dot(ws.f);
  model.mass.velocity(z.p, ws.v);
  model.hessian_product(z.q, ws.v, ws.f);
  const double curvature_term = ws.v.dot(ws.f);
  return model.mass.kinetic(z.p) + model.potential(z.q) + h * h * (force_term / 12.0 - curvature_term / 24.0);
}

}  // namespace raydamp
