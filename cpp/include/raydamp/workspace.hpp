// Scratch vectors for the sub-flows, sized once before the step loop so that a
// step never allocates (Dynamic-size models included).
#pragma once

#include <utility>
#include <vector>

#include "raydamp/damping/decay_factors.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

// Factors is what the model's damping kind caches per sub-flow length (its
// factors(t)); DecayFactors for the kinds with one scalar rate.
template <int Dim, class Factors = DecayFactors>
struct Workspace {
  Vector<Dim> v, g, f, stage_q, stage_p;
  std::vector<Vector<Dim>> kq, kp;  // Runge-Kutta stage derivatives
  bool track_work = false;  // accumulate the damping work W in `work`
  double work = 0.0;
  Factors damp_factors, kick_damp_factors;  // for the last t each exact damping flow ran for

  Workspace(int n, int stages)
      : v(Vector<Dim>::Zero(n)), g(Vector<Dim>::Zero(n)), f(Vector<Dim>::Zero(n)),
        stage_q(Vector<Dim>::Zero(n)), stage_p(Vector<Dim>::Zero(n)),
        kq(stages, Vector<Dim>::Zero(n)), kp(stages, Vector<Dim>::Zero(n)) {}
};

// The workspace a Model's step loop needs.
template <class Model>
using damping_factors_t = decltype(std::declval<const Model&>().damping.factors(0.0));
template <class Model>
using WorkspaceFor = Workspace<Model::dim, damping_factors_t<Model>>;

}  // namespace raydamp
