// The exact sub-flows of paper section 3 (q frozen wherever p moves). Each maps
// the state in place over time t.
#pragma once

#include <type_traits>
#include <utility>

#include "raydamp/state.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp::flows {

// A model may do a drift or a kick itself in one pass (model.drift(q, p, t),
// model.kick(q, p, t)): a large lattice then reads and writes its state once per
// sub-flow instead of going through the v or g scratch vector.
template <class M, class = void>
struct has_drift : std::false_type {};
template <class M>
struct has_drift<M, std::void_t<decltype(std::declval<const M&>().drift(
                        std::declval<typename M::Vec&>(), std::declval<typename M::Vec&>(), 0.0))>>
    : std::true_type {};
template <class M, class = void>
struct has_kick : std::false_type {};
template <class M>
struct has_kick<M, std::void_t<decltype(std::declval<const M&>().kick(
                       std::declval<const typename M::Vec&>(), std::declval<typename M::Vec&>(), 0.0))>>
    : std::true_type {};

// And the exact kick+damp flow in one pass, model.kick_damp(q, p, factors, g) (g: scratch
// it may use), where the damping's factors allow it (a lattice's site friction).
template <class M, class = void>
struct has_kick_damp : std::false_type {};
template <class M>
struct has_kick_damp<M, std::void_t<decltype(std::declval<const M&>().kick_damp(
                            std::declval<const typename M::Vec&>(), std::declval<typename M::Vec&>(),
                            std::declval<const damping_factors_t<M>&>(), std::declval<typename M::Vec&>()))>>
    : std::true_type {};

// exp(t X_T): q <- q + t M^{-1} p, and the clock: t is the coordinate the drift advances
// with unit speed, so that a load seen by the kicks is f at the time the drifts left.
template <class Model, int Dim, class WS>
inline void drift(const Model& model, State<Dim>& z, double t, WS& ws) {
  if constexpr (has_drift<Model>::value) {
    model.drift(z.q, z.p, t);
  } else {
    model.mass.velocity(z.p, ws.v);
    z.q += t * ws.v;
  }
  if (load_of(ws)) ws.time += t;  // only a load reads the clock: no store per drift without one
}

// p += c f(time). A fixed-size state lives in registers in the flattened step loop as long as
// no out-of-line call sees its address: the load (out of line, load.hpp) writes ws.f, and the
// sum is inlined code (the damped pendulum's 3s: 15.9 -> x ns/step). A heap state is added to in place.
template <int Dim, class WS>
inline void add_load(Vector<Dim>& p, double c, WS& ws) {
  if constexpr (Dim == Eigen::Dynamic) {
    ws.load->add(ws.time, c, p.data());
  } else {
    ws.f.setZero();
    ws.load->add(ws.time, c, ws.f.data());
    p += ws.f;
  }
}

// exp(t X_V): p <- p - t (grad V(q) - f(time)), time frozen.
template <class Model, int Dim, class WS>
inline void kick(const Model& model, State<Dim>& z, double t, WS& ws) {
  if constexpr (has_kick<Model>::value) {
    model.kick(z.q, z.p, t);
  } else {
    model.gradient(z.q, ws.g);
    z.p -= t * ws.g;
  }
  if (load_of(ws)) add_load(z.p, t, ws);
}

// ws.g <- grad V(q) - f(time): the force of a kick, with the load.
template <class Model, int Dim, class WS>
inline void loaded_gradient(const Model& model, const Vector<Dim>& q, double time, WS& ws) {
  model.gradient(q, ws.g);
  if (load_of(ws)) ws.load->add(time, -1.0, ws.g.data());
}

// Whether a damping kind has the noise of its exact Ornstein-Uhlenbeck flow (add_noise).
template <class Model, class = void>
struct has_thermal_noise : std::false_type {};
template <class Model>
struct has_thermal_noise<Model, std::void_t<decltype(std::declval<const Model&>().damping.add_noise(
                                    std::declval<const typename Model::Vec&>(),
                                    std::declval<const Model&>().damping.factors(0.0), std::declval<const Model&>().mass,
                                    0.0, std::declval<const typename Model::Vec&>(),
                                    std::declval<typename Model::Vec&>()))>> : std::true_type {};

// The normal numbers one OU flow of the damping draws: one per coordinate, or the kind's noise_count(n)
// where its noise has lower rank (a radial damping, one dashpot: one number along a direction).
template <class Damping, class = void>
struct has_noise_count : std::false_type {};
template <class Damping>
struct has_noise_count<Damping, std::void_t<decltype(std::declval<const Damping&>().noise_count(Eigen::Index(0)))>>
    : std::true_type {};
template <class Damping>
inline Eigen::Index noise_count(const Damping& damping, Eigen::Index n) {
  if constexpr (has_noise_count<Damping>::value) return damping.noise_count(n);
  else return n;
}

// p += the noise of the OU flow over the factors' time: Gaussian with covariance kT (M - E M E^T),
// E = exp(-t eps D M^{-1}) at the frozen q (fluctuation-dissipation). Independent of the flow's
// deterministic part, so it is the same for the damping flow and the affine kick-damp flow.
template <class Model, class WS, class F>
RAYDAMP_OUT_OF_LINE void noise_increment(const Model& model, const F& factors, WS& ws) {
  ws.draw_noise(noise_count(model.damping, ws.xi.size()));
  ws.stage_p.setZero();
  model.damping.add_noise(ws.stage_q, factors, model.mass, ws.sigma, ws.xi, ws.stage_p);
}

template <class Model, int Dim, class WS, class F>
inline void thermal_noise(const Model& model, State<Dim>& z, const F& factors, WS& ws) {
  if constexpr (has_thermal_noise<Model>::value) {
    if constexpr (Dim == Eigen::Dynamic) {  // a heap state: in place
      ws.draw_noise(noise_count(model.damping, ws.xi.size()));
      model.damping.add_noise(z.q, factors, model.mass, ws.sigma, ws.xi, z.p);
    } else {  // out of line on copies, so that the call never sees the state's address (see add_load)
      ws.stage_q = z.q;
      noise_increment(model, factors, ws);
      z.p += ws.stage_p;
    }
  }
}

// The damping's factors for a flow of length t, computed once per length (the last few kept).
template <class Model, class WS>
inline const typename WS::Factors& damp_factors(const Model& model, double t, WS& ws) {
  return ws.factors.get(t, model.damping);
}

// exp(t eps Y): p <- exp(-t eps D(q) M^{-1}) p (and, at a temperature, the OU flow's noise).
template <class Model, int Dim, class WS>
inline void damp(const Model& model, State<Dim>& z, double t, WS& ws) {
  const typename WS::Factors& factors = damp_factors(model, t, ws);
  model.damping.decay(z.q, factors, z.p);
  if (noisy(ws)) thermal_noise(model, z, factors, ws);
}

// exp(t (X_V + eps Y)): the exact solution of the affine ODE p' = -grad V(q) + f - A p
// (q and the load's time frozen), p(t) = e^{-tA} p - t phi1(-tA) (grad V(q) - f).
template <class Model, int Dim, class WS>
inline void kick_damp_body(const Model& model, State<Dim>& z, double t, WS& ws) {
  auto factors = [&]() -> const typename WS::Factors& { return damp_factors(model, t, ws); };
  if constexpr (has_kick_damp<Model>::value) {
    if (!load_of(ws) && !noisy(ws)) {  // a load enters through phi1, noise after: the general path below
      model.kick_damp(z.q, z.p, factors(), ws.g);
      return;
    }
  }
  loaded_gradient(model, z.q, ws.time, ws);
  // The factors after the gradient, not before: the damped pendulum's 2s then keeps q in a register
  // into sin (12.4 ns/step; 14.9 with the factors' test first).
  model.damping.decay_affine(z.q, factors(), ws.g, z.p);
  if (noisy(ws)) thermal_noise(model, z, factors(), ws);
}

// A model whose step loop is not flattened (a compiled System: its step is calls into compiled functions)
// keeps kick_damp a call of its own, as GCC chose before the load and noise hooks made it inline it into
// the step loop: the System's 2s step took 39 ns inlined, 36 ns out of line (bench_system.py).
template <class Model, class = void>
struct kick_damp_out_of_line : std::false_type {};
template <class Model>
struct kick_damp_out_of_line<Model, std::void_t<decltype(Model::flatten_step_loop)>>
    : std::bool_constant<!Model::flatten_step_loop> {};

template <class Model, int Dim, class WS>
RAYDAMP_OUT_OF_LINE void kick_damp_call(const Model& model, State<Dim>& z, double t, WS& ws) {
  kick_damp_body(model, z, t, ws);
}

template <class Model, int Dim, class WS>
inline void kick_damp(const Model& model, State<Dim>& z, double t, WS& ws) {
  if constexpr (kick_damp_out_of_line<Model>::value) kick_damp_call(model, z, t, ws);
  else kick_damp_body(model, z, t, ws);
}

}  // namespace raydamp::flows
