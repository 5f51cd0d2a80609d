// One Runge-Kutta step of a given tableau on three vector fields:
// - kick_damp_rk: p' = -grad V(q) - A(q) p with q frozen (the inner step of rks,
//   paper Algorithm RKS). The field is affine in p, so a diagonally implicit
//   stage is one solve with I + h a_ii A and no Newton iteration.
// - drift_damp_rk: q' = M^{-1} p, p' = -A(q) p (the inner step of the paper's
//   counter-example RKS-B, end of section 5); explicit tableaux only.
// - full_rk: the whole system, the classical baseline; explicit tableaux only.
#pragma once

#include "raydamp/flows/exact.hpp"
#include "raydamp/methods/butcher_tableau.hpp"
#include "raydamp/state.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp::flows {

// Written for the damping part only: with K_i = -g + D_i, row sums c_i and weights
// summing to one (both checked when the tableau is built) give
//   P_i = p - h c_i g + h sum_j a_ij D_j,   p_new = p - h g + h sum_i b_i D_i,
// the same method re-associated. At eps = 0 every D_i is exactly zero, so rks
// is Stormer-Verlet to the last bit, whatever the tableau.
// Tab is a ButcherTableau or a FixedTableau<S> (same accessors, stage count known
// to the compiler, so the stage loops unroll).
template <class Model, class Tab, int Dim, class WS>
inline void kick_damp_rk(const Model& model, const Tab& tab, State<Dim>& z, double h, WS& ws) {
  const int s = tab.stages();
  loaded_gradient(model, z.q, ws.time, ws);  // constant over the stages: q and the load's time are frozen
  for (int i = 0; i < s; ++i) {
    // At c_i = 0 (an explicit tableau's first stage) P_i is p itself; writing
    // p - 0 g would make the stage wait for grad V (a square root and a division).
    if (tab.c(i) != 0.0) ws.stage_p = z.p - (h * tab.c(i)) * ws.g;
    else ws.stage_p = z.p;
    for (int j = 0; j < i; ++j)
      if (tab.a(i, j) != 0.0) ws.stage_p += (h * tab.a(i, j)) * ws.kp[j];
    if (tab.a(i, i) != 0.0) {
      // D_i = -A (P_i + h a_ii D_i)  <=>  (I + h a_ii A) D_i = -A P_i.
      model.damping.rate(z.q, ws.stage_p, ws.kp[i]);
      ws.kp[i] = -ws.kp[i];
      model.damping.solve_shifted(z.q, h * tab.a(i, i), ws.kp[i]);
    } else {
      model.damping.rate(z.q, ws.stage_p, ws.kp[i]);
      ws.kp[i] = -ws.kp[i];
    }
  }
  z.p -= h * ws.g;
  for (int i = 0; i < s; ++i) z.p += (h * tab.b(i)) * ws.kp[i];
}

namespace detail {

// Generic explicit Runge-Kutta step of (q, p)' = field(q, p); field(i, q, p, dq, dp)
// writes the slopes of stage i.
template <class Tab, class Field, int Dim, class WS>
inline void explicit_rk(const Tab& tab, State<Dim>& z, double h, WS& ws, Field field) {
  const int s = tab.stages();
  for (int i = 0; i < s; ++i) {
    ws.stage_q = z.q;
    ws.stage_p = z.p;
    for (int j = 0; j < i; ++j) {
      const double ha = h * tab.a(i, j);
      if (ha == 0.0) continue;
      ws.stage_q += ha * ws.kq[j];
      ws.stage_p += ha * ws.kp[j];
    }
    field(i, ws.stage_q, ws.stage_p, ws.kq[i], ws.kp[i]);
  }
  // Sum the weighted slopes before scaling by h: with equal slopes (rksb at
  // eps = 0) Heun's 1/2 + 1/2 then adds exactly one h v, as the drift does.
  ws.v = tab.b(0) * ws.kq[0];
  ws.f = tab.b(0) * ws.kp[0];
  for (int i = 1; i < s; ++i) {
    ws.v += tab.b(i) * ws.kq[i];
    ws.f += tab.b(i) * ws.kp[i];
  }
  z.q += h * ws.v;
  z.p += h * ws.f;
}

}  // namespace detail

template <class Model, class Tab, int Dim, class WS>
inline void drift_damp_rk(const Model& model, const Tab& tab, State<Dim>& z, double h, WS& ws) {
  detail::explicit_rk(tab, z, h, ws, [&](int, const Vector<Dim>& q, const Vector<Dim>& p, Vector<Dim>& dq, Vector<Dim>& dp) {
    model.mass.velocity(p, dq);
    model.damping.rate(q, p, dp);
    dp = -dp;
  });
  if (load_of(ws)) ws.time += h;  // a drift of the clock as of q
}

// The load at the stage times t + c_i h.
template <class Model, class Tab, int Dim, class WS>
inline void full_rk(const Model& model, const Tab& tab, State<Dim>& z, double h, WS& ws) {
  const double t0 = ws.time;
  detail::explicit_rk(tab, z, h, ws, [&](int i, const Vector<Dim>& q, const Vector<Dim>& p, Vector<Dim>& dq, Vector<Dim>& dp) {
    model.mass.velocity(p, dq);
    model.gradient(q, ws.g);
    model.damping.rate(q, p, dp);
    // The damping work W' = v . A p (and the load's W_f' = f . v) are integrated as more
    // components of the system, by the same tableau, so their quadrature has the method's order.
    if (ws.track_work) ws.work += h * tab.b(i) * dq.dot(dp);
    dp = -dp - ws.g;
    if (load_of(ws)) {
      const double t = t0 + tab.c(i) * h;
      ws.load->add(t, 1.0, dp.data());
      if (ws.track_work) ws.load_work += h * tab.b(i) * ws.load->dot(t, dq.data());
    }
  });
  if (load_of(ws)) ws.time = t0 + h;
}

}  // namespace raydamp::flows
