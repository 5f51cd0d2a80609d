// The one step loop: fixed steps of any method on any model, with saving,
// blow-up detection, momentum-drift tracking, progress and cancellation.
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

#ifndef RAYDAMP_FLATTEN
#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_FLATTEN __attribute__((flatten, noinline))
#else
#define RAYDAMP_FLATTEN
#endif
#endif

namespace raydamp {

class LinearImplicitFactors;  // implicit/linear_implicit_factors.hpp

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

enum class Status { completed, non_finite, cancelled, out_of_memory };

inline const char* status_name(Status s) {
  switch (s) {
    case Status::completed: return "completed";
    case Status::non_finite: return "non_finite";
    case Status::out_of_memory: return "out_of_memory";
    default: return "cancelled";
  }
}

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
  long rows() const { return static_cast<long>(t.size()); }
};

struct RunResult {
  Status status = Status::completed;
  long steps = 0;          // steps taken whose result is finite
  long failed_step = -1;   // 1-based index of the step whose result was not finite
  std::string message;
  // max over every step of max_j |J_j(t) - J_j(0) e^{-a t}|: the distance of the momentum maps from
  // the law the exact flow follows, a = momentum_decay_rate(model) (0: conserved; see run_steps).
  double max_momentum_drift = 0.0;
  Trajectory trajectory;
};

template <class Model, int Dim>
double energy(const Model& model, const State<Dim>& z) {
  return model.mass.kinetic(z.p) + model.potential(z.q);
}

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
  explicit MomentumBuffers(int m) : j0(m), j(m) {}
  int count() const { return static_cast<int>(j0.size()); }
};

template <class Model, int Dim, class WS>
void save_point(const Model& model, const State<Dim>& z, double t, const WS& ws,
                MomentumBuffers& mb, const std::vector<int>& dofs, Trajectory& out) {
  out.t.push_back(t);
  if (ws.track_work) out.work.push_back(ws.work);
  if (ws.track_work && ws.load) out.load_work.push_back(ws.load_work);
  if (dofs.empty()) {
    out.q.insert(out.q.end(), z.q.data(), z.q.data() + z.q.size());
    out.p.insert(out.p.end(), z.p.data(), z.p.data() + z.p.size());
  } else {
    for (int i : dofs) out.q.push_back(z.q[i]);
    for (int i : dofs) out.p.push_back(z.p[i]);
  }
  out.energy.push_back(energy(model, z));
  if (mb.count() == 0) return;
  model.momenta(z.q, z.p, mb.j.data());
  out.momentum.insert(out.momentum.end(), mb.j.begin(), mb.j.end());
}

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
inline constexpr long kReserveRows = 1L << 16;  // saved rows reserved before the first step

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
  if constexpr (Mergeable && (fuses_3s<Model>::value || Dim != Eigen::Dynamic)) {
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
      local.lead(model, tab, y, k, ws);
      for (long i = k; i + 1 < end; ++i) {
        local.body(model, tab, y, i, ws);
        if (track_momenta) block_drift = std::max(block_drift, step_drift(y, i, true));
        local.join(model, tab, y, i, ws);
      }
      local.body(model, tab, y, end - 1, ws);
      local.trail(model, tab, y, end - 1, ws);
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

template <class Method, class Model, class Tab, int Dim>
RunResult run_steps(const Model& model, const Tab& tab, const Composition& composition, State<Dim> z,
                    const RunSpec& spec, const Control& control) {
  static_assert(is_model_v<Model>, "Model lacks part of the interface listed in raydamp/concepts.hpp");
  if (spec.temperature != 0.0) check_temperature<Method, Model>(model, composition, spec.temperature);
  // At eps = 0 every damping flow is the identity, so 3s is sv with identities between its
  // drifts. Run as sv's table, it equals sv bit for bit: its merged steps would otherwise
  // run drift h/2 twice where sv's run drift h once (both exact; they differ by rounding).
  if constexpr (std::is_same_v<Method, ThreeTermSplitting>)
    if (model.eps == 0.0) return run_steps<StormerVerlet>(model, tab, composition, std::move(z), spec, control);
  const long N = spec.n_steps;
  const int n = model.size();
  RunResult result;
  Trajectory& out = result.trajectory;
  for (int i : spec.save_dofs)
    if (i < 0 || i >= n) throw std::invalid_argument("save_dofs: " + std::to_string(i) + " is not a coordinate");
  out.n = spec.save_dofs.empty() ? n : static_cast<int>(spec.save_dofs.size());
  MomentumBuffers mb(momentum_count(model));
  out.n_momenta = mb.count();
  // Reserved up to kReserveRows rows; past that the buffers grow at save points (never inside a
  // block of steps), so a run asking for more rows than memory holds saves what fits and stops
  // with out_of_memory instead of failing before its first step.
  const long rows = std::min(N / spec.save_every + 2, kReserveRows);
  out.t.reserve(rows);
  out.q.reserve(rows * out.n);
  out.p.reserve(rows * out.n);
  out.energy.reserve(rows);
  out.momentum.reserve(rows * mb.count());

  // One workspace; the flattened loop runs on it as Unhooked (no load, no noise) when it can.
  Unhooked<WorkspaceFor<Model>> unhooked(n, tab.stages());
  WorkspaceFor<Model>& ws = unhooked;
  ws.track_work = spec.track_work;
  if (spec.track_work) out.work.reserve(rows);
  if (spec.load && !spec.load->empty()) {
    if (spec.load->size() != n)
      throw std::invalid_argument("load: made for " + std::to_string(spec.load->size()) + " coordinates, the model has " +
                                  std::to_string(n));
    ws.load = spec.load;
    if (spec.track_work) out.load_work.reserve(rows);
  }
  if (spec.temperature > 0.0) {
    ws.sigma = std::sqrt(spec.temperature);
    ws.noise = NormalStream(spec.seed, spec.stream);
    if (spec.stream_per_coordinate) {
      ws.lane_noise.clear();
      for (int i = 0; i < n; ++i) ws.lane_noise.emplace_back(spec.seed, spec.stream + static_cast<std::uint64_t>(i));
    }
  }
  // Copies made now, so the loop never allocates. The block loop steps y, a local
  // that only inlined code sees, so the compiler can keep it in registers.
  State<Dim> checkpoint = z, before = z;
  State<Dim> y = Dim == Eigen::Dynamic ? State<Dim>{} : z;  // a Dynamic state is stepped in place
  if (mb.count() > 0) model.momenta(z.q, z.p, mb.j0.data());
  const bool track_momenta = mb.count() > 0;
  auto time_at = [&](long k) { return k == N && spec.h_last != spec.h ? (N - 1) * spec.h + spec.h_last : k * spec.h; };
  auto step_size = [&](long k) { return k == N - 1 ? spec.h_last : spec.h; };  // size of step k -> k+1

  if (!z.all_finite()) {
    result.status = Status::non_finite;
    result.failed_step = 0;
    result.message = "the initial state is not finite";
    return result;
  }
  save_point(model, z, 0.0, ws, mb, spec.save_dofs, out);
  // A save that runs out of memory takes back its partial row, so every array keeps the same rows.
  auto save = [&](double t) {
    const std::size_t sizes[] = {out.t.size(), out.q.size(), out.p.size(), out.energy.size(), out.momentum.size(),
                                 out.work.size(), out.load_work.size()};
    try {
      save_point(model, z, t, ws, mb, spec.save_dofs, out);
      return true;
    } catch (const std::bad_alloc&) {
      out.t.resize(sizes[0]);
      out.q.resize(sizes[1]);
      out.p.resize(sizes[2]);
      out.energy.resize(sizes[3]);
      out.momentum.resize(sizes[4]);
      out.work.resize(sizes[5]);
      out.load_work.resize(sizes[6]);
      return false;
    }
  };
  // The run then ends at its last saved row (rows are saved every save_every steps from step 0),
  // so steps and the last row agree, as for every other way a run ends.
  auto out_of_memory = [&](long at) {
    result.status = Status::out_of_memory;
    result.message = "out of memory after saving " + std::to_string(out.rows()) + " points (at step " +
                     std::to_string(at) + " of " + std::to_string(N) + "); the saved points are kept: raise save_every";
    return (out.rows() - 1) * spec.save_every;
  };
  const long progress_every = std::max(1L, N / std::max(1L, control.max_progress_calls));
  long next_save = spec.save_every, next_progress = progress_every, k = 0;
  double max_drift = 0.0;
  // Damping work by the trapezoidal rule on the step's end points, unless the
  // method integrates it itself (see integrates_work).
  constexpr bool trapezoid = !integrates_work<Method>::value;
  double power = spec.track_work && trapezoid ? dissipated_power(model, z, ws) : 0.0;
  // The load's power f(t) . M^{-1} p, by the same rule.
  auto load_power = [&](const State<Dim>& x, double t) {
    model.mass.velocity(x.p, ws.v);
    return ws.load->dot(t, ws.v.data());
  };
  const bool track_load = spec.track_work && trapezoid && ws.load;
  double power_f = track_load ? load_power(z, 0.0) : 0.0;
  const auto stepper = make_stepper<Method>(model, composition, spec);
  // First-same-as-last merging needs no intermediate state except the momentum
  // maps', which are read before the merged sub-flow: an exact flow of a part of
  // H, which conserves J, or of the damping, which conserves J or scales it by a
  // known factor (paper section 5; `law` below). The damping work needs the step's
  // end points: with work tracked, steps run whole.
  constexpr bool mergeable = is_mergeable<Method>();
  // At a temperature a merged damping flow (3s's join: one OU draw over h) and the two it stands for (two
  // draws over h/2) are equal in law, not sample by sample: steps then run whole, so that a seed gives one
  // path whatever save_every, progress or a replay do.
  bool noisy_join = false;
  if constexpr (mergeable) noisy_join = spec.temperature > 0.0 && is_damping_flow(Method::stages[0].flow);
  const bool merge = mergeable && spec.merge_steps && !spec.track_work && !noisy_join;
  // The momentum maps' drift from their law J(0) e^{-a t} (see momentum_decay_rate), after
  // step i or, merged, before its last sub-flow: when that is a damping flow (3s's damp),
  // the state has then been damped for t_{i+1} minus its duration.
  const double decay_rate = momentum_decay_rate(model);
  auto law = [&](long i, bool before_trail) {
    if constexpr (decays_momenta_v<Model>) {
      if (decay_rate != 0.0) {
        double t = time_at(i + 1);
        if constexpr (mergeable && is_damping_flow(Method::stages[0].flow))
          if (before_trail) t -= stepper.durations(i).trail;
        return std::exp(-decay_rate * t);
      }
    }
    return 1.0;
  };
  auto step_drift = [&, fixed = FixedMomentumDrift<Model>(mb)](const State<Dim>& x, long i, bool before_trail) {
    if constexpr (Model::n_momenta > 0) return fixed(model, x, law(i, before_trail));
    else return momentum_drift(model, x, mb, law(i, before_trail));
  };
  // The trapezoid's points: a composed step's stage boundaries (see ComposedStepper::step_by_stage).
  auto trapezoid_point = [&](const State<Dim>& x, double dt, double t) {
    const double next = dissipated_power(model, x, ws);
    ws.work += 0.5 * dt * (power + next);
    power = next;
    if (track_load) {
      const double next_f = load_power(x, t);
      ws.load_work += 0.5 * dt * (power_f + next_f);
      power_f = next_f;
    }
  };
  auto advance = [&](auto& w, State<Dim>& x, long i) {  // w: ws, or the same as Unhooked
    if (ws.load) ws.time = time_at(i);
    if constexpr (trapezoid && has_step_by_stage<std::decay_t<decltype(stepper)>>::value) {
      if (spec.track_work && stepper.stages() > 1) {
        double t = time_at(i);
        stepper.step_by_stage(model, tab, x, i, w, [&](double dt) { trapezoid_point(x, dt, t += dt); });
        return;
      }
    }
    stepper.step(model, tab, x, i, w);
    if constexpr (trapezoid) {
      if (spec.track_work) trapezoid_point(x, step_size(i), time_at(i + 1));
    }
  };

  while (k < N) {
    if (control.cancel && control.cancel->load(std::memory_order_relaxed)) {
      result.status = Status::cancelled;
      result.message = "cancelled after " + std::to_string(k) + " of " + std::to_string(N) + " steps";
      break;
    }
    const long end = std::min({N, next_save, next_progress, k + kBlock});
    checkpoint = z;
    const double checkpoint_work = ws.work, checkpoint_power = power, checkpoint_load_work = ws.load_work,
                 checkpoint_power_f = power_f;
    ws.time = time_at(k);  // the merged loop's clock; advance() sets it per step
    ws.save_noise();  // a replay draws the same noise
    double block_drift = 0.0;
    if constexpr (Dim == Eigen::Dynamic) {  // stepped in place (see run_block)
      block_drift = run_block<mergeable>(model, tab, stepper, ws, z, k, end, merge, track_momenta, advance, step_drift);
    } else {
      y = z;
      bool plain = false;  // a flattened loop without load or noise runs Unhooked (workspace.hpp)
      if constexpr (flattens_step_loop<Model>::value) plain = !ws.load && ws.sigma == 0.0;
      if constexpr (flattens_step_loop<Model>::value) {
        if (plain)
          block_drift =
              run_block<mergeable>(model, tab, stepper, unhooked, y, k, end, merge, track_momenta, advance, step_drift);
      }
      if (!plain)
        block_drift = run_block<mergeable>(model, tab, stepper, ws, y, k, end, merge, track_momenta, advance, step_drift);
      z = y;
    }
    if (!z.all_finite()) {
      // Replay the block one checked step at a time from its start.
      z = checkpoint;
      ws.work = checkpoint_work;
      power = checkpoint_power;
      ws.load_work = checkpoint_load_work;
      power_f = checkpoint_power_f;
      ws.restore_noise();
      long i = k;
      for (; i < end; ++i) {
        before = z;
        const double work_before = ws.work, load_work_before = ws.load_work;
        advance(ws, z, i);
        if (!z.all_finite()) {
          z = before;
          ws.work = work_before;
          ws.load_work = load_work_before;
          break;
        }
        if (track_momenta) max_drift = std::max(max_drift, step_drift(z, i, false));
      }
      if (i < end) {
        k = i;
        result.status = Status::non_finite;
        result.failed_step = i + 1;
        result.message = "the state stopped being finite at step " + std::to_string(i + 1) + " (t = " +
                         std::to_string(time_at(i + 1)) + "); the last finite state is saved";
        break;
      }
      // The steps one at a time stayed finite where the merged block did not (their roundings differ, and a run
      // at the edge of stability can go either way): the run goes on from the replay's end. (It stopped here,
      // "non_finite" at a step past the block, with a finite state saved.)
    } else {
      max_drift = std::max(max_drift, block_drift);
    }
    k = end;
    if (k == next_save) {
      if (!save(time_at(k))) {
        k = out_of_memory(k);
        break;
      }
      next_save += spec.save_every;
    }
    if (k == next_progress) {
      if (control.progress) control.progress(k, N);
      next_progress += progress_every;
    }
  }
  // The final state is always the last row, saved or not by save_every.
  if (out.t.back() != time_at(k) && result.status != Status::out_of_memory && !save(time_at(k))) k = out_of_memory(k);
  if (control.progress && result.status == Status::completed && next_progress - progress_every != N) control.progress(N, N);
  result.steps = k;
  result.max_momentum_drift = max_drift;
  if (result.status == Status::completed) result.message = "completed " + std::to_string(N) + " steps";
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
