// Scratch vectors for the sub-flows, sized once before the step loop so that a
// step never allocates (Dynamic-size models included).
#pragma once

#include <utility>
#include <vector>

#include "raydamp/damping/decay_factors.hpp"
#include "raydamp/load.hpp"
#include "raydamp/random/philox.hpp"
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
  // For the last t each exact damping flow ran for, and the damp's t before that: a merged 3s
  // run damps for h/2 at the ends of each block of steps and for h between its steps.
  Factors damp_factors, kick_damp_factors, previous_damp_factors;
  // The load and the clock it reads: t, advanced by the drifts (flows/exact.hpp) and set
  // by the step loop at each step it starts from scratch. load_work: W_f = int f . M^{-1} p dt.
  const Load* load = nullptr;
  double time = 0.0, load_work = 0.0;
  // Thermal noise (temperature kT > 0): each exact damping flow becomes its Ornstein-Uhlenbeck flow,
  // sigma = sqrt(kT), its normal numbers drawn into xi from this run's stream.
  double sigma = 0.0;
  NormalStream noise;
  Vector<Dim> xi;

  Workspace(int n, int stages)
      : v(fresh(n)), g(fresh(n)), f(fresh(n)), stage_q(fresh(n)), stage_p(fresh(n)), xi(fresh(n)) {
    for (int i = 0; i < stages; ++i) {  // each its own fresh vector (a copy of one would write it)
      kq.push_back(fresh(n));
      kp.push_back(fresh(n));
    }
  }

  // Every flow writes a scratch vector before reading it. A Dynamic one is left
  // unwritten here: a lattice of 10^6 sites whose drift and kick need no scratch
  // then never touches (never faults in) those pages.
  static Vector<Dim> fresh(int n) {
    if constexpr (Dim == Eigen::Dynamic) return Vector<Dim>(n);
    else return Vector<Dim>::Zero(n);
  }
};

// The workspace a Model's step loop needs.
template <class Model>
using damping_factors_t = decltype(std::declval<const Model&>().damping.factors(0.0));
template <class Model>
using WorkspaceFor = Workspace<Model::dim, damping_factors_t<Model>>;

}  // namespace raydamp
