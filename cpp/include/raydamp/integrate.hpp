// The one step loop: fixed steps of any method on any model. The loop advances, checks
// (finite, not diverged: record/divergence.hpp) and cancels; a recorder observes the steps
// and keeps the rows (record/recorder.hpp); a checkpoint holds what a replay needs.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/concepts.hpp"
#include "raydamp/diagnostics.hpp"
#include "raydamp/amplification.hpp"
#include "raydamp/composed_step.hpp"
#include "raydamp/step.hpp"
#include "raydamp/events/watcher.hpp"
#include "raydamp/math/flush_subnormals.hpp"
#include "raydamp/materials/commit.hpp"
#include "raydamp/materials/kinks.hpp"
#include "raydamp/record/divergence.hpp"
#include "raydamp/record/envelope.hpp"
#include "raydamp/record/model_view.hpp"
#include "raydamp/record/recorder.hpp"
#include "raydamp/record/save_grid.hpp"
#include "raydamp/run_types.hpp"

#ifndef RAYDAMP_FLATTEN
#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_FLATTEN __attribute__((flatten, noinline))
#else
#define RAYDAMP_FLATTEN
#endif
#endif

namespace raydamp {

// Whether the step loop of Model is flattened (run_block_flat). Flattening pays where
// a step is a few dozen nanoseconds of register work that a call would interrupt: a
// built-in model of fixed size, or one that says so (the ensemble's pendulum lanes).
// A model of run-time size (a System, a lattice, a sparse structure) spends its step
// in loops over n, sparse products and compiled functions, where a call costs nothing
// measurable; flattened, every inlined copy of those loops costs compile time (the
// two linear-structure kinds: 193 s of compiler to 43 s). A model may say no
// (flatten_step_loop = false; compiled systems of fixed n do).
template <class Model, class = void>
struct flattens_step_loop : std::bool_constant<Model::dim != Eigen::Dynamic> {};
template <class Model>
struct flattens_step_loop<Model, std::void_t<decltype(Model::flatten_step_loop)>>
    : std::bool_constant<Model::flatten_step_loop> {};

// The law the momentum maps J = p . xi(q) a model lists follow under its exact flow:
// J(t) = J(0) e^{-a t}. A damping kind with A = eps D M^{-1} = a I (D = c M) gives a as
// momentum_decay_rate(): the Hamiltonian part conserves J and the damping scales p. Every
// other kind gives a = 0: the momentum maps a model lists are those of symmetries of V and
// of D (the elastic pendulum's J3 under radial damping, a chain's total momentum with
// dashpots on bonds only), which the exact flow conserves (paper section 5).
template <class D, class = void>
struct has_momentum_decay_rate : std::false_type {};
template <class D>
struct has_momentum_decay_rate<D, std::void_t<decltype(std::declval<const D&>().momentum_decay_rate())>>
    : std::true_type {};
template <class Model>
inline constexpr bool decays_momenta_v = has_momentum_decay_rate<decltype(std::declval<const Model&>().damping)>::value;

template <class Model>
double momentum_decay_rate(const Model& model) {
  if constexpr (decays_momenta_v<Model>) return model.damping.momentum_decay_rate();
  else return 0.0;
}

template <class D, class = void>
struct has_noise_check : std::false_type {};
template <class D>
struct has_noise_check<D, std::void_t<decltype(std::declval<const D&>().has_noise())>> : std::true_type {};

// Refuses, naming the reason, a temperature that Method, composition or the model's damping cannot take.
template <class Method, class Model>
void check_temperature(const Model& model, const Composition& composition, double temperature) {
  if (!(temperature >= 0.0) || !std::isfinite(temperature))
    throw std::invalid_argument("temperature must be a finite number >= 0");
  if (temperature == 0.0) return;
  if constexpr (!takes_temperature<Method>())
    throw std::invalid_argument(std::string("temperature: method '") + Method::name +
                                "' has no exact noise flow (a Runge-Kutta or implicit sub-step, or no damping "
                                "sub-flow); use 3s, 2s or baoab");
  if (composition.is_table())
    throw std::invalid_argument("temperature: composition '" + composition.name() +
                                "' is a near-integrable table, made for the deterministic error O(eps h^" +
                                std::to_string(composition.eps_order()) + " + eps^2 h^2); at a temperature use the "
                                "order-2 method");
  if (composition.stages() != 1)
    throw std::invalid_argument("temperature: composition '" + composition.name() +
                                "' runs sub-steps backward, and a noise flow over a negative time is meaningless; "
                                "use the order-2 method");
  if (model.eps == 0.0)
    throw std::invalid_argument("temperature: this model has no damping (eps = 0); thermal noise is the damping's "
                                "fluctuation-dissipation partner");
  if constexpr (!flows::has_thermal_noise<Model>::value) {
    throw std::invalid_argument("temperature: this system's damping has no exact noise flow");
  } else if constexpr (has_noise_check<decltype(model.damping)>::value) {
    if (!model.damping.has_noise()) throw std::invalid_argument(model.damping.kNoNoise);
  }
}

namespace detail {

// Buffers for J(q, p), sized before the loop so that tracking allocates nothing.
struct MomentumBuffers {
  std::vector<double> j0, j;
  template <class Model, int Dim>
  MomentumBuffers(const Model& model, const State<Dim>& z) : j0(momentum_count(model)), j(j0.size()) {
    if (!j0.empty()) model.momenta(z.q, z.p, j0.data());
  }
  int count() const { return static_cast<int>(j0.size()); }
};

// max_j |J_j - J_j(0) law|, law = J(t) / J(0) by momentum_decay_rate (1 when conserved).
template <class Model, int Dim>
double momentum_drift(const Model& model, const State<Dim>& z, MomentumBuffers& mb, double law) {
  model.momenta(z.q, z.p, mb.j.data());
  double drift = 0.0;
  for (int i = 0; i < mb.count(); ++i) drift = std::max(drift, std::abs(mb.j[i] - law * mb.j0[i]));
  return drift;
}

// The same for a model with a fixed number of momentum maps, on J(0) copied into
// this object: a local of the step loop, so J(0) and J stay in registers instead of
// being reloaded from the heap after every call into the model.
template <class Model, int M = Model::n_momenta>
struct FixedMomentumDrift {
  std::array<double, (M > 0 ? M : 1)> j0{};
  explicit FixedMomentumDrift(const MomentumBuffers& mb) {
    for (int i = 0; i < M; ++i) j0[i] = mb.j0[i];
  }
  template <int Dim>
  double operator()(const Model& model, const State<Dim>& z, double law) const {
    std::array<double, (M > 0 ? M : 1)> j{};
    model.momenta(z.q, z.p, j.data());
    double drift = 0.0;
    for (int i = 0; i < M; ++i) drift = std::max(drift, std::abs(j[i] - law * j0[i]));
    return drift;
  }
};

}  // namespace detail

// Steps between finiteness checks. A blown-up block is replayed step by step from
// its start, so the failing step is found exactly without a check on every step.
inline constexpr long kBlock = 256;

namespace detail {

// The steps of a method with a table that cannot be composed or merged (rk):
// whole steps only.
template <class Method>
struct WholeStepper {
  double h, h_last;
  long last_step;
  template <class Model, class Tab, int Dim, class WS>
  void step(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    raydamp::step<Method>(model, tab, z, i == last_step ? h_last : h, ws);
  }
};

// A stepper that can run a step one composition stage at a time (ComposedStepper::step_by_stage).
template <class Stepper, class = void>
struct has_step_by_stage : std::false_type {};
template <class Stepper>
struct has_step_by_stage<Stepper, std::void_t<decltype(&Stepper::stages)>> : std::true_type {};

// A method with a stepper of its own (Method::Stepper: the linear implicit methods,
// implicit/linear_implicit_step.hpp, which factorise before the first step).
template <class Method, class = void>
struct has_own_stepper : std::false_type {};
template <class Method>
struct has_own_stepper<Method, std::void_t<typename Method::Stepper>> : std::true_type {};

template <class Method, class Model>
auto make_stepper(const Model& model, const Composition& composition, const RunSpec& spec) {
  if constexpr (has_own_stepper<Method>::value) {
    return typename Method::Stepper(model, composition, spec);
  } else if constexpr (is_mergeable<Method>()) {
    return ComposedStepper<Method>(composition, spec.h, spec.h_last, spec.n_steps);
  } else {
    if (composition.stages() != 1)
      throw std::invalid_argument(std::string("composition: method table '") + Method::name +
                                  "' is not symmetric, so it cannot be composed");
    return WholeStepper<Method>{spec.h, spec.h_last, spec.n_steps - 1};
  }
}

// Steps k .. end-1 of y, with nothing saved in between; returns the largest
// momentum-map drift seen, step_drift(y, i, before_trail) after step i (before_trail:
// without its last sub-flow, which the merged loop runs joined to the next step's first).
// (run_block below decides whether it is flattened.)
template <bool Mergeable, class Model, class Tab, class Stepper, int Dim, class WS, class Advance, class Drift>
inline double run_block_body(const Model& model, const Tab& shared_tab, const Stepper& stepper, WS& ws,
                             State<Dim>& state, long k, long end, bool merge, bool track_momenta,
                             const Advance& advance, const Drift& step_drift) {
  // Stepped on local copies (state and durations) that no opaque call (sin, exp)
  // can be assumed to touch, so the compiler keeps them in registers. A state on the
  // heap (Dynamic size: a lattice of 10^6 sites) stays out of registers anyway, and
  // its copy would cost two passes over memory and a fresh buffer's page faults per
  // block: it is stepped in place.
  constexpr bool in_place = Dim == Eigen::Dynamic;
  std::conditional_t<in_place, State<Dim>&, State<Dim>> y = state;
  const Stepper local = stepper;  // a few hundred bytes, once per block
  // A fixed-size tableau is copied too; a run-time one (vectors) is read in place.
  using LocalTab = std::conditional_t<std::is_trivially_copyable_v<Tab>, const Tab, const Tab&>;
  LocalTab tab = shared_tab;
  double block_drift = 0.0;
  if constexpr (Mergeable && !has_materials_v<Model> && (fuses_3s<Model>::value || Dim != Eigen::Dynamic)) {
    // The same sub-flows in the same order as below, grouped as join(i) + body(i + 1)
    // so that a model can run the pair as one call. A fixed-size state takes this
    // grouping too (the damped pendulum's 3s: 0.5 ns of 11 per step less), lanes on
    // the heap the one below (vector_sine lanes: 4% less per member-step there).
    if (merge) {
      local.lead(model, tab, y, k, ws);
      local.body(model, tab, y, k, ws);
      for (long i = k; i + 1 < end; ++i) {
        if (track_momenta) block_drift = std::max(block_drift, step_drift(y, i, true));
        local.join_then_body(model, tab, y, i, ws);
      }
      local.trail(model, tab, y, end - 1, ws);
      if (track_momenta) block_drift = std::max(block_drift, step_drift(y, end - 1, false));
      if constexpr (!in_place) state = y;
      return block_drift;
    }
  } else if constexpr (Mergeable) {
    if (merge) {
      // Materials commit after each step's last kick: the body's, or the joint's where kicks end a step.
      constexpr bool commit_after_body = !kicks_at_ends<typename Stepper::Table>();
      local.lead(model, tab, y, k, ws);
      for (long i = k; i + 1 < end; ++i) {
        local.body(model, tab, y, i, ws);
        if constexpr (commit_after_body) commit_materials(model);
        if (track_momenta) block_drift = std::max(block_drift, step_drift(y, i, true));
        local.join(model, tab, y, i, ws);
        if constexpr (!commit_after_body) commit_materials(model);
      }
      local.body(model, tab, y, end - 1, ws);
      if constexpr (commit_after_body) commit_materials(model);
      local.trail(model, tab, y, end - 1, ws);
      if constexpr (!commit_after_body) commit_materials(model);
      if (track_momenta) block_drift = std::max(block_drift, step_drift(y, end - 1, false));
      if constexpr (!in_place) state = y;
      return block_drift;
    }
  }
  for (long i = k; i < end; ++i) {
    advance(ws, y, i);
    if (track_momenta) block_drift = std::max(block_drift, step_drift(y, i, false));
  }
  if constexpr (!in_place) state = y;
  return block_drift;
}

// The same, flattened: every call in it (sub-flows, the model, Eigen) is inlined,
// whatever the compiler's budget in a translation unit that instantiates every
// method for every model (without it the elastic pendulum's 3s took 43 ns/step
// instead of 30). And not inlined itself: whether run_steps took it in depended on the
// translation unit, and the loop's registers with it (the damped pendulum's 2s: 12.5 ns/step
// in a small program, 17.6 in the module until this made both the same code).
template <bool Mergeable, class Model, class Tab, class Stepper, int Dim, class WS, class Advance, class Drift>
RAYDAMP_FLATTEN double run_block_flat(const Model& model, const Tab& tab, const Stepper& stepper, WS& ws,
                                      State<Dim>& state, long k, long end, bool merge, bool track_momenta,
                                      const Advance& advance, const Drift& step_drift) {
  return run_block_body<Mergeable>(model, tab, stepper, ws, state, k, end, merge, track_momenta, advance, step_drift);
}

template <bool Mergeable, class Model, class Tab, class Stepper, int Dim, class WS, class Advance, class Drift>
inline double run_block(const Model& model, const Tab& tab, const Stepper& stepper, WS& ws,
                        State<Dim>& state, long k, long end, bool merge, bool track_momenta, const Advance& advance,
                        const Drift& step_drift) {
  if constexpr (flattens_step_loop<Model>::value)
    return run_block_flat<Mergeable>(model, tab, stepper, ws, state, k, end, merge, track_momenta, advance, step_drift);
  else
    return run_block_body<Mergeable>(model, tab, stepper, ws, state, k, end, merge, track_momenta, advance, step_drift);
}

// Steps k .. end-1 of z: in place for a state on the heap (see run_block), else on the local y; a
// flattened loop without load or noise runs on the workspace as Unhooked (workspace.hpp).
template <bool Mergeable, class Model, class Tab, class Stepper, class WS, int Dim, class Advance, class Drift>
inline double run_block_on(const Model& model, const Tab& tab, const Stepper& stepper, Unhooked<WS>& unhooked,
                           State<Dim>& z, State<Dim>& y, long k, long end, bool merge, bool track_momenta,
                           const Advance& advance, const Drift& step_drift) {
  WS& ws = unhooked;
  if constexpr (Dim == Eigen::Dynamic) {
    return run_block<Mergeable>(model, tab, stepper, ws, z, k, end, merge, track_momenta, advance, step_drift);
  } else {
    y = z;
    double block_drift = 0.0;
    bool plain = false;
    if constexpr (flattens_step_loop<Model>::value) {
      if ((plain = !ws.load && ws.sigma == 0.0))
        block_drift =
            run_block<Mergeable>(model, tab, stepper, unhooked, y, k, end, merge, track_momenta, advance, step_drift);
    }
    if (!plain)
      block_drift = run_block<Mergeable>(model, tab, stepper, ws, y, k, end, merge, track_momenta, advance, step_drift);
    z = y;
    return block_drift;
  }
}

// A save that ran out of memory ends the run at its last saved row (rows are saved every save_every
// steps from step 0), so steps and the last row agree, as for every other way a run ends.
inline long out_of_memory(RunResult& result, long N, long save_every, long at) {
  const long rows = result.trajectory.rows();
  result.status = Status::out_of_memory;
  result.message = "out of memory after saving " + std::to_string(rows) + " points (at step " + std::to_string(at) +
                   " of " + std::to_string(N) + "); the saved points are kept: raise save_every";
  return (rows - 1) * save_every;
}

// The progress a run reports: after the block that ends at each of about max_progress_calls even marks, and
// once more at the end of a completed run whose last mark was not its last step.
class ProgressReports {
 public:
  ProgressReports(const Control& control, long n)
      : control_(control), n_(n), every_(std::max(1L, n / std::max(1L, control.max_progress_calls))), next_(every_) {}
  long next() const { return next_; }  // the step where the next report is due (a block ends there)
  void at(long k) {
    if (k != next_) return;
    if (control_.progress) control_.progress(k, n_);
    next_ += every_;
  }
  void finish(Status status) const {
    if (control_.progress && status == Status::completed && next_ - every_ != n_) control_.progress(n_, n_);
  }

 private:
  const Control& control_;
  long n_, every_, next_;
};

// Whether the loop merges the last sub-flow of a step with the first of the next. First-same-as-last
// merging needs no intermediate state except the momentum maps', which are read before the merged
// sub-flow: an exact flow of a part of H, which conserves J, or of the damping, which conserves J or
// scales it by a known factor (paper section 5; drift_from_law). The damping work needs the step's
// end points: with work tracked, steps run whole. At a temperature a merged damping flow (3s's join:
// one OU draw over h) and the two it stands for (two draws over h/2) are equal in law, not sample by
// sample: steps then run whole, so that a seed gives one path whatever save_every, progress or a
// replay do.
template <class Method>
bool merges_steps(const RunSpec& spec) {
  if constexpr (is_mergeable<Method>()) {
    const bool noisy_join = spec.temperature > 0.0 && is_damping_flow(Method::stages[0].flow);
    // Events, dense output and envelopes read every step's end: steps run whole.
    return spec.merge_steps && !spec.track_work && !noisy_join && !spec.events && !spec.dense && !spec.envelope;
  } else {
    return false;
  }
}

// The momentum maps' drift from their law J(0) e^{-a t} (see momentum_decay_rate), as
// drift(x, i, before_trail) after step i or, merged, before its last sub-flow: when that is a
// damping flow (3s's damp), the state has then been damped for t_{i+1} minus its duration.
template <class Method, class Model, class Stepper, class TimeAt>
auto drift_from_law(const Model& model, MomentumBuffers& mb, const Stepper& stepper, const TimeAt& time_at) {
  const double decay_rate = momentum_decay_rate(model);
  auto law = [&stepper, time_at, decay_rate](long i, bool before_trail) {
    if constexpr (decays_momenta_v<Model>) {
      if (decay_rate != 0.0) {
        double t = time_at(i + 1);
        if constexpr (is_mergeable<Method>() && is_damping_flow(Method::stages[0].flow))
          if (before_trail) t -= stepper.durations(i).trail;
        return std::exp(-decay_rate * t);
      }
    }
    static_cast<void>(stepper), static_cast<void>(i), static_cast<void>(before_trail);
    return 1.0;
  };
  return [&model, &mb, law, fixed = FixedMomentumDrift<Model>(mb)](const auto& x, long i, bool before_trail) {
    if constexpr (Model::n_momenta > 0) return fixed(model, x, law(i, before_trail));
    else return momentum_drift(model, x, mb, law(i, before_trail));
  };
}

// The workspace's load and noise, as spec asks.
template <class WS>
void hook_workspace(WS& ws, const RunSpec& spec, int n) {
  ws.track_work = spec.track_work;
  if (spec.load && !spec.load->empty()) {
    if (spec.load->size() != n)
      throw std::invalid_argument("load: made for " + std::to_string(spec.load->size()) + " coordinates, the model has " +
                                  std::to_string(n));
    ws.load = spec.load;
  }
  if (spec.temperature > 0.0) {
    ws.sigma = std::sqrt(spec.temperature);
    ws.noise = NormalStream(spec.seed, spec.stream);
    if (spec.stream_per_coordinate) {
      ws.lane_noise.clear();
      for (int i = 0; i < n; ++i) ws.lane_noise.emplace_back(spec.seed, spec.stream + static_cast<std::uint64_t>(i));
    }
  }
}

// Steps k .. end-1 again, one checked step at a time, from the block's start (in z): returns the
// first step whose result is not finite, z then the state before it, or end.
template <class WS, class Rec, class Held, int Dim, class Advance, class Drift>
long replay_block(WS& ws, Rec& rec, Held& before, State<Dim>& z, long k, long end, bool track_momenta,
                  const Advance& advance, const Drift& step_drift, double& max_drift) {
  for (long i = k; i < end; ++i) {
    before.take(z, ws, rec, false);
    advance(ws, z, i);
    if (!z.all_finite()) {
      before.restore(z, ws, rec, false);
      return i;
    }
    if (track_momenta) max_drift = std::max(max_drift, step_drift(z, i, false));
  }
  return end;
}

// One step of tau of Method (composed), outside the run's own step sizes: a piece of a step split at a kink.
template <class Method, class Model, class Tab, int Dim, class WS>
void step_for(const Model& model, const Tab& tab, const Composition& composition, State<Dim>& z, double tau,
              WS& ws) {
  if constexpr (has_own_stepper<Method>::value) {
    throw std::invalid_argument(std::string("method '") + Method::name + "' cannot step a piece of a step");
  } else if constexpr (is_mergeable<Method>()) {
    ComposedStepper<Method>(composition, tau, tau, 1).step(model, tab, z, 0, ws);
  } else {
    raydamp::step<Method>(model, tab, z, tau, ws);
  }
}

// Step i of x split at its springs' kinks (materials/kinks.hpp): the whole step where none falls inside
// it, else pieces of it, each ending at a kink (step_for).
template <class Method, class Kinks, class Model, class Tab, class Stepper, int Dim, class W, class WS, class Rec>
void step_at_kinks(Kinks& kinks, const Model& model, const Tab& tab, const Composition& composition,
                   const RunSpec& spec, const Stepper& stepper, State<Dim>& x, long i, W& w, WS& ws, Rec& rec) {
  const double t = step_time(i, spec.h, spec.n_steps, spec.h_last);
  kinks.step(x, t, i == spec.n_steps - 1 ? spec.h_last : spec.h, ws, rec, [&](State<Dim>& y, double tau, bool whole) {
    if (whole) stepper.step(model, tab, y, i, w);
    else step_for<Method>(model, tab, composition, y, tau, w);
  });
}

// The end of a run at step k: its final state is the last row (saved or not by save_every), then its
// step count, drift and message.
template <class Rec, int Dim>
void end_run(RunResult& result, Rec& rec, const State<Dim>& z, double t_last, long k, const RunSpec& spec,
             double max_drift) {
  if (result.trajectory.t.back() != t_last && result.status != Status::out_of_memory && !rec.save(z, t_last))
    k = out_of_memory(result, spec.n_steps, spec.save_every, k);
  result.steps = k;
  result.max_momentum_drift = max_drift;
  if (result.status == Status::completed) result.message = "completed " + std::to_string(spec.n_steps) + " steps";
}

// After a terminal event (watch.stopped()): z becomes the state at the event's time, the crossing step
// run again from its start with its duration cut to that time; returns the steps taken.
template <class Method, class Watch, class Model, class Tab, class WS, class Rec, int Dim>
long finish_at_event(Watch& watch, const Model& model, const Tab& tab, const Composition& composition,
                     const RunSpec& spec, WS& ws, Rec& rec, State<Dim>& z, RunResult& result) {
  const long steps = watch.finish(z, rec, [&](State<Dim>& x, long i, double dt) {
    RunSpec last = spec;  // a run of i + 1 steps whose last is dt long
    last.n_steps = i + 1;
    last.h_last = dt;
    last.implicit_factors = nullptr;  // an ensemble's shared factors hold no sub-step of dt: made for it
    const auto stepper = make_stepper<Method>(model, composition, last);
    ws.time = step_time(i, spec.h, spec.n_steps, spec.h_last);
    stepper.step(model, tab, x, i, ws);
    rec.on_step(x, dt, watch.stop_time());
  });
  result.status = Status::event;
  result.message = "event '" + watch.stop_name() + "' at t = " + std::to_string(watch.stop_time()) + " (step " +
                   std::to_string(steps) + ", shortened to it)";
  return steps;
}

// The loop: advance a block of steps, check it (finite, not diverged), save, report, cancel. The
// recorder observes the steps and keeps the rows; a checkpoint at each block's start lets a block
// that blew up be replayed step by step to find the failing step exactly.
template <class Method, class Model, class Tab, int Dim>
RunResult run_steps(const Model& model, const Tab& tab, const Composition& composition, State<Dim> z,
                    const RunSpec& spec, const Control& control) {
  static_assert(is_model_v<Model>, "Model lacks part of the interface listed in raydamp/concepts.hpp");
  const FlushSubnormals flush;  // a decayed state would otherwise cycle among subnormals, 25x slower
  if (spec.temperature != 0.0) check_temperature<Method, Model>(model, composition, spec.temperature);
  // At eps = 0 every damping flow is the identity, so 3s is sv with identities between its
  // drifts. Run as sv's table, it equals sv bit for bit: its merged steps would otherwise
  // run drift h/2 twice where sv's run drift h once (both exact; they differ by rounding).
  if constexpr (std::is_same_v<Method, ThreeTermSplitting>)
    if (model.eps == 0.0) return run_steps<StormerVerlet>(model, tab, composition, std::move(z), spec, control);
  const long N = spec.n_steps;
  RunResult result;
  // One workspace; the flattened loop runs on it as Unhooked (no load, no noise) when it can.
  Unhooked<WorkspaceFor<Model>> unhooked(model.size(), tab.stages());
  WorkspaceFor<Model>& ws = unhooked;
  // Damping work by the trapezoidal rule, unless the method integrates it itself (integrates_work).
  constexpr bool trapezoid = !integrates_work<Method>::value;
  hook_workspace(ws, spec, model.size());
  Recorder<Model, Dim, trapezoid> rec(model, spec, ws, result.trajectory);
  const ModelView view = model_view(model);  // what the observers below see of the model
  EventWatcher watch(view, spec, result, view_of(z), 0.0);  // events
  watch.batch_screens(Dim != Eigen::Dynamic && !has_materials_v<Model>, kBlock);
  auto time_at = [&](long k) { return step_time(k, spec.h, N, spec.h_last); };
  auto stop = [&](Status status, long failed_step, std::string message) {
    result.status = status, result.failed_step = failed_step, result.message = std::move(message);
  };
  EnvelopeRecorder envelope(view, spec, result, view_of(z));  // peaks at every step's end
  if (!z.all_finite()) {
    stop(Status::non_finite, 0, "the initial state is not finite");
    return result;
  }
  DivergenceGuard diverged(view, spec, view_of(z), time_at(N));
  MomentumBuffers mb(model, z);
  const bool track_momenta = mb.count() > 0;
  // Copies made now, so the loop never allocates. The block loop steps y, a local
  // that only inlined code sees, so the compiler can keep it in registers.
  Checkpoint<Dim, typename decltype(rec)::Marks> checkpoint(z), before(z);
  State<Dim> y = Dim == Eigen::Dynamic ? State<Dim>{} : z;  // a Dynamic state is stepped in place
  rec.start(z);
  const auto stepper = make_stepper<Method>(model, composition, spec);
  constexpr bool mergeable = is_mergeable<Method>();
  KinkLocator<Model, Dim> kinks(model, spec);  // a Structure's springs with locate_kinks: steps split at kinks
  // A constrained drift for h/2 twice is not the one for h (each ends on the manifold): steps run whole.
  const bool merge = merges_steps<Method>(spec) && !kinks.on() && !has_constraints<Model>::value;
  const auto step_drift = drift_from_law<Method>(model, mb, stepper, time_at);
  auto advance = [&](auto& w, State<Dim>& x, long i) {  // w: ws, or the same as Unhooked
    if (watch.stopped() || envelope.stopped()) return;  // a terminal event or a collapse ended the run
    if (ws.load) ws.time = time_at(i);
    watch.keep(x, rec);  // the step's start, for an event's search (screened events: events/watcher.hpp)
    if constexpr (has_materials_v<Model>) {
      if (kinks.on()) {
        step_at_kinks<Method>(kinks, model, tab, composition, spec, stepper, x, i, w, ws, rec);
        return envelope.after_step(x, i), watch.after_step(model, x, i, time_at(i + 1), rec);
      }
    }
    if constexpr (trapezoid && has_step_by_stage<std::decay_t<decltype(stepper)>>::value) {
      if (rec.tracks_work() && stepper.stages() > 1) {  // the trapezoid's points: the stage boundaries
        double t = time_at(i);
        stepper.step_by_stage(model, tab, x, i, w, [&](double dt) { rec.on_step(x, dt, t += dt); });
        commit_materials(model);
        return envelope.after_step(x, i), watch.after_step(model, x, i, time_at(i + 1), rec);
      }
    }
    stepper.step(model, tab, x, i, w);
    commit_materials(model);
    rec.on_step(x, i == N - 1 ? spec.h_last : spec.h, time_at(i + 1));
    envelope.after_step(x, i), watch.after_step(model, x, i, time_at(i + 1), rec);
  };
  ProgressReports progress(control, N);
  long next_save = spec.save_every, k = 0;
  double max_drift = 0.0;
  while (k < N) {
    if (control.cancel && control.cancel->load(std::memory_order_relaxed)) {
      stop(Status::cancelled, -1, "cancelled after " + std::to_string(k) + " of " + std::to_string(N) + " steps");
      break;
    }
    const long end = std::min({N, next_save, progress.next(), k + kBlock});
    checkpoint.take(z, ws, rec);  // a replay draws the same noise
    save_materials(model);        // and starts from the same material states
    watch.begin_block(z, k, rec);
    ws.time = time_at(k);  // the merged loop's clock; advance() sets it per step
    const double block_drift =
        run_block_on<mergeable>(model, tab, stepper, unhooked, z, y, k, end, merge, track_momenta, advance, step_drift);
    watch.end_block<Dim>(model);  // batched screens: the block's steps observed now
    if (watch.stopped() || envelope.stopped()) {  // a terminal event (its step shortened to it), or a collapse
      k = watch.stopped() ? finish_at_event<Method>(watch, model, tab, composition, spec, ws, rec, z, result)
                          : envelope.stop(result);
      break;
    }
    if (!z.all_finite()) {
      checkpoint.restore(z, ws, rec);
      restore_materials(model);
      watch.restart_screen();
      const long i = replay_block(ws, rec, before, z, k, end, track_momenta, advance, step_drift, max_drift);
      if (i < end) {
        k = i;
        stop(Status::non_finite, i + 1, "the state stopped being finite at step " + std::to_string(i + 1) +
                                            " (t = " + std::to_string(time_at(i + 1)) + "); the last finite state is saved");
        break;
      }
      // The steps one at a time stayed finite where the merged block did not (their roundings differ, and a run
      // at the edge of stability can go either way): the run goes on from the replay's end.
    } else {
      max_drift = std::max(max_drift, block_drift);
    }
    k = end;
    if (diverged.check(z, k, N, time_at(k))) {
      stop(Status::diverged, k, diverged.message(k, time_at(k)));
      break;
    }
    if (k == next_save) {
      if (!rec.save(z, time_at(k))) {
        k = out_of_memory(result, N, spec.save_every, k);
        break;
      }
      next_save += spec.save_every;
    }
    progress.at(k);
  }
  end_run(result, rec, z, watch.stopped() ? watch.stop_time() : time_at(k), k, spec, max_drift);
  progress.finish(result.status);
  return result;
}

}  // namespace detail

// Integrates spec.n_steps steps of Method from z. The built-in tableaux have 1, 2 or
// 4 stages; for those, on a model of fixed size, the loop is instantiated with the
// stage count fixed, so Runge-Kutta stages unroll and stay in registers. Any other
// tableau, and every tableau on a model of run-time size (whose stages are vectors
// on the heap either way), runs from the run-time table: one instantiation, not four.
// `composition` composes a symmetric Method (builtin_composition("none") is Method
// itself); a composed run past the amplification guard (amplification.hpp) is
// refused with std::invalid_argument.
template <class Method, class Model, int Dim = Model::dim>
RunResult integrate(const Model& model, const ButcherTableau& tab, const Composition& composition, State<Dim> z,
                    const RunSpec& spec, const Control& control = {}) {
  check_amplification<Method>(model, z.q, tab, composition, spec.h);
  if constexpr (uses_tableau<Method>() && Dim != Eigen::Dynamic) {
    switch (tab.stages()) {
      case 1: return detail::run_steps<Method>(model, FixedTableau<1>(tab), composition, std::move(z), spec, control);
      case 2: return detail::run_steps<Method>(model, FixedTableau<2>(tab), composition, std::move(z), spec, control);
      case 4: return detail::run_steps<Method>(model, FixedTableau<4>(tab), composition, std::move(z), spec, control);
      default: break;
    }
  }
  return detail::run_steps<Method>(model, tab, composition, std::move(z), spec, control);
}

template <class Method, class Model, int Dim = Model::dim>
RunResult integrate(const Model& model, const ButcherTableau& tab, State<Dim> z, const RunSpec& spec,
                    const Control& control = {}) {
  return integrate<Method>(model, tab, builtin_composition("none"), std::move(z), spec, control);
}

}  // namespace raydamp
