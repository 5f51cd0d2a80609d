// What a run is asked (RunSpec, Control) and what it gives back (RunResult, Trajectory).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "raydamp/events/types.hpp"
#include "raydamp/load.hpp"
#include "raydamp/record/envelope_types.hpp"
#include "raydamp/state.hpp"
#include "raydamp/status.hpp"

namespace raydamp {

class LinearImplicitFactors;  // implicit/linear_implicit_factors.hpp

// The divergence test's default factor (record/divergence.hpp): a run is diverged once its energy has
// gained more than this many times everything its start, its load and its temperature can give it.
inline constexpr double kDefaultDivergence = 1e6;

struct RunSpec {
  double h = 0.1;
  long n_steps = 0;
  double h_last = 0.1;   // size of the final step (lands exactly on t_end)
  long save_every = 1;
  bool track_work = false;  // record W(t) = eps int qdot^T D qdot dt at the saved points
  // Merge the last sub-flow of a step with the first of the next between steps
  // that save nothing (see composed_step.hpp); false runs every step whole (tests).
  bool merge_steps = true;
  // The coordinates whose q and p each saved point keeps (empty: all). A large
  // lattice saves a few sites and the scalar diagnostics, not n numbers per row.
  std::vector<int> save_dofs{};
  // A time-dependent load f(t) (load.hpp), or none; with track_work its work W_f is recorded too.
  const Load* load = nullptr;
  // Thermal noise: temperature kT > 0 turns every damping flow into its exact Ornstein-Uhlenbeck flow,
  // its normal numbers from the Philox stream (seed, stream) (random/philox.hpp).
  double temperature = 0.0;
  std::uint64_t seed = 0, stream = 0;
  // A run whose coordinates are the lanes of independent members (the pendulum ensemble's lanes):
  // coordinate i draws its own stream, stream + i, so that lane i's noise is member i's single run's.
  bool stream_per_coordinate = false;
  // The linear implicit methods' factorisations, made beforehand and shared read-only (an
  // ensemble's members: implicit/linear_implicit_factors.hpp); null: the run makes its own.
  std::shared_ptr<const LinearImplicitFactors> implicit_factors{};
  // The divergence test's factor G (record/divergence.hpp); 0 turns the test off.
  double divergence = kDefaultDivergence;
  // Events to locate (events/watcher.hpp), or none; and whether to keep what dense output needs at
  // every step end. Either runs whole steps (merges_steps), so that every step has an end to read.
  const EventSet* events = nullptr;
  bool dense = false;
  // Peaks to take at every step's end (record/envelope.hpp), or none; steps then run whole.
  const EnvelopeSpec* envelope = nullptr;
  // Screened events (affine, of q and t) on a model of fixed size without springs, envelope or noise are
  // screened a block at a time, from the steps' ends stored as the block runs (events/watcher.hpp); false
  // screens each step inside the loop instead (tests compare the two: the same events, bit for bit).
  bool batch_screens = true;
};

struct Control {
  const std::atomic<bool>* cancel = nullptr;         // set from another thread to stop
  std::function<void(long done, long total)> progress;  // called between blocks, a bounded number of times
  long max_progress_calls = 100;
};

// Saved points, row-major: t[k], q[k*n + i], p[k*n + i], energy[k], momentum[k*m + j]
// (n: the saved coordinates, all of them or RunSpec::save_dofs).
struct Trajectory {
  int n = 0, n_momenta = 0;
  std::vector<double> t, q, p, energy, momentum, work;  // work: empty unless tracked
  std::vector<double> load_work;  // W_f = int f . M^{-1} p dt; empty unless tracked with a load
  // A structure's springs (the core's order), [k*n_springs + s] of row k: spring_force, sigma_s from the
  // material state of that row; spring_deformation, d_s; with work tracked, spring_work, each spring's
  // hysteretic work (record/spring_work.hpp). Empty for a model without springs.
  int n_springs = 0;
  std::vector<double> spring_force, spring_deformation, spring_work;
  long rows() const { return static_cast<long>(t.size()); }
};

struct RunResult {
  Status status = Status::completed;
  long steps = 0;          // steps taken whose result is finite
  long failed_step = -1;   // 1-based index of the step whose result was not finite, or after which it diverged
  std::string message;
  // max over every step of max_j |J_j(t) - J_j(0) e^{-a t}|: the distance of the momentum maps from
  // the law the exact flow follows, a = momentum_decay_rate(model) (0: conserved; see run_steps).
  double max_momentum_drift = 0.0;
  Trajectory trajectory;
  EventLog events;    // empty unless RunSpec::events
  DenseRecord dense;  // empty unless RunSpec::dense
  EnvelopeRecord envelope;  // empty unless RunSpec::envelope
};

template <class Model, int Dim>
double energy(const Model& model, const State<Dim>& z) {
  return model.mass.kinetic(z.p) + model.potential(z.q);
}

}  // namespace raydamp
