// Scratch vectors for the sub-flows, sized once before the step loop so that a
// step never allocates (Dynamic-size models included).
#pragma once

#include <utility>
#include <vector>

#include "raydamp/damping/decay_factors.hpp"
#include "raydamp/damping/factors_cache.hpp"
#include "raydamp/load.hpp"
#include "raydamp/random/philox.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

// Factors is what the model's damping kind caches per sub-flow length (its
// factors(t)); DecayFactors for the kinds with one scalar rate.
template <int Dim, class F = DecayFactors>
struct Workspace {
  using Factors = F;
  // Whether this run may have a load or noise: known only at run time here; see Unhooked.
  static constexpr bool hooked = true;
  Vector<Dim> v, g, f, stage_q, stage_p;
  std::vector<Vector<Dim>> kq, kp;  // Runge-Kutta stage derivatives
  bool track_work = false;  // accumulate the damping work W in `work`
  double work = 0.0;
  // The damping's factors of the last few sub-flow lengths the exact damp and kick+damp flows ran for.
  FactorsCache<Factors> factors;
  // The load and the clock it reads: t, advanced by the drifts (flows/exact.hpp) and set
  // by the step loop at each step it starts from scratch. load_work: W_f = int f . M^{-1} p dt.
  const Load* load = nullptr;
  double time = 0.0, load_work = 0.0;
  // Thermal noise (temperature kT > 0): each exact damping flow becomes its Ornstein-Uhlenbeck flow,
  // sigma = sqrt(kT), its normal numbers drawn into xi from this run's stream.
  double sigma = 0.0;
  NormalStream noise;
  Vector<Dim> xi;
  // Or one stream per coordinate (RunSpec::stream_per_coordinate: lanes of independent members).
  std::vector<NormalStream> lane_noise;

  // xi <- standard normal numbers, from the run's stream or each coordinate's own; the first `count` of
  // them only where the damping's noise needs fewer than one per coordinate (noise_count, flows/exact.hpp).
  void draw_noise(Eigen::Index count = -1) {
    if (lane_noise.empty()) {
      if (count < 0 || count == xi.size()) {
        noise.fill(xi);
      } else {
        auto head = xi.head(count);
        noise.fill(head);
      }
    } else {
      for (std::size_t i = 0; i < lane_noise.size(); ++i) xi[static_cast<Eigen::Index>(i)] = lane_noise[i].next();
    }
  }
  // The streams' state at a checkpoint, and back: a replayed block draws the same numbers. The
  // buffer is sized at the first save, before any step, so a block's save allocates nothing.
  void save_noise() {
    saved_noise_ = noise.state();
    saved_lane_noise_.resize(lane_noise.size());
    for (std::size_t i = 0; i < lane_noise.size(); ++i) saved_lane_noise_[i] = lane_noise[i].state();
  }
  void restore_noise() {
    noise.restore(saved_noise_);
    for (std::size_t i = 0; i < lane_noise.size(); ++i) lane_noise[i].restore(saved_lane_noise_[i]);
  }

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

 private:
  NormalStream::State saved_noise_;
  std::vector<NormalStream::State> saved_lane_noise_;
};

// The same workspace, for a run the step loop knows has no load and no temperature: the flows
// compile without their hooks (load_of, noisy below). The flattened loop of a small model is
// instantiated with it too, because the hooks' tests, the clock's stores and their code moved the
// loop's layout: the damped pendulum's 2s took 12.4 ns/step without them and 14.9-17.3 with.
template <class W>
struct Unhooked : W {
  using W::W;
  static constexpr bool hooked = false;
};

// The load a flow applies, and whether it adds noise (constants in an Unhooked workspace).
template <class WS>
inline const Load* load_of(const WS& ws) {
  if constexpr (WS::hooked) return ws.load;
  else return nullptr;
}
template <class WS>
inline bool noisy(const WS& ws) {
  if constexpr (WS::hooked) return ws.sigma > 0.0;
  else return false;
}

// The workspace a Model's step loop needs.
template <class Model>
using damping_factors_t = decltype(std::declval<const Model&>().damping.factors(0.0));
template <class Model>
using WorkspaceFor = Workspace<Model::dim, damping_factors_t<Model>>;

}  // namespace raydamp
