// The exact sub-flows of paper section 3 (q frozen wherever p moves). Each maps
// the state in place over time t.
#pragma once

#include "raydamp/state.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp::flows {

// exp(t X_T): q <- q + t M^{-1} p.
template <class Model, int Dim, class DF>
inline void drift(const Model& model, State<Dim>& z, double t, Workspace<Dim, DF>& ws) {
  model.mass.velocity(z.p, ws.v);
  z.q += t * ws.v;
}

// exp(t X_V): p <- p - t grad V(q).
template <class Model, int Dim, class DF>
inline void kick(const Model& model, State<Dim>& z, double t, Workspace<Dim, DF>& ws) {
  model.gradient(z.q, ws.g);
  z.p -= t * ws.g;
}

// exp(t eps Y): p <- exp(-t eps D(q) M^{-1}) p.
template <class Model, int Dim, class DF>
inline void damp(const Model& model, State<Dim>& z, double t, Workspace<Dim, DF>& ws) {
  if (ws.damp_factors.t != t) ws.damp_factors = model.damping.factors(t);
  model.damping.decay(z.q, ws.damp_factors, z.p);
}

// exp(t (X_V + eps Y)): the exact solution of the affine ODE p' = -grad V(q) - A p,
// p(t) = e^{-tA} p - t phi1(-tA) grad V(q).
template <class Model, int Dim, class DF>
inline void kick_damp(const Model& model, State<Dim>& z, double t, Workspace<Dim, DF>& ws) {
  model.gradient(z.q, ws.g);
  if (ws.kick_damp_factors.t != t) ws.kick_damp_factors = model.damping.factors(t);
  model.damping.decay_affine(z.q, ws.kick_damp_factors, ws.g, z.p);
}

}  // namespace raydamp::flows
