// The ensemble driver: every member of an ensemble run on its own model, load and initial state,
// spread over threads (ensemble.hpp), each handed to store(i, RunResult&&) as it ends. A member is a
// single run (integrate_model), so member i equals its single run bit for bit, and a member that
// fails (blows up, diverges) ends with its own status while the others run on. Members of the damped
// pendulum that share eps run as the SIMD lanes of one run (lanes.hpp), and Kepler test particles that
// share their parameters as the particles of one (lanes_kepler.hpp); both are split back.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/ensemble.hpp"
#include "raydamp/ensemble/lanes.hpp"
#include "raydamp/ensemble/lanes_kepler.hpp"
#include "raydamp/errors.hpp"
#include "raydamp/implicit/linear_implicit_step.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/models/compiled_system.hpp"

namespace raydamp {

template <class Model>
struct is_compiled_system : std::false_type {};
template <class Mass, class Damping>
struct is_compiled_system<CompiledSystem<Mass, Damping>> : std::true_type {};

// Method on model from z: integrate() itself, except that a compiled system of
// n <= 3 coordinates run by a method without a Runge-Kutta stage (sv, 3s, 2s)
// runs with n fixed at compile time (CompiledSystem::fixed), chosen here once per
// run. Only those methods: each size is another instantiation of the step loop per
// kind, and the tableau methods gained nothing measurable from it (rks on the
// elastic pendulum: 61 -> 59 ns/step, against 83 -> 67 for 3s). Single runs and
// ensemble members both come through here, so they stay equal bit for bit.
template <class Method, class Model>
RunResult integrate_model(const Model& model, const ButcherTableau& tab, const Composition& comp,
                          State<Model::dim> z, const RunSpec& spec, const Control& control) {
  if constexpr (has_materials_v<Model>) {  // a run's materials are its own, from their virgin state
    const Model own = model.fresh_run();
    return integrate<Method>(own, tab, comp, std::move(z), spec, control);
  }
  if constexpr (is_compiled_system<Model>::value && !uses_tableau<Method>()) {
    switch (model.size()) {
      case 1: return integrate<Method>(model.template fixed<1>(), tab, comp, State<1>{z.q, z.p}, spec, control);
      case 2: return integrate<Method>(model.template fixed<2>(), tab, comp, State<2>{z.q, z.p}, spec, control);
      case 3: return integrate<Method>(model.template fixed<3>(), tab, comp, State<3>{z.q, z.p}, spec, control);
      default: break;
    }
  }
  return integrate<Method>(model, tab, comp, std::move(z), spec, control);
}

// What every member of an ensemble shares.
struct EnsembleSpec {
  RunSpec run;                     // h, steps, save_every, temperature and seed (its load and stream: per member)
  std::uint64_t first_stream = 0;  // member i draws stream first_stream + i (a sweep's chunk: its first member)
  int threads = 0;                 // <= 0: one per hardware thread
  bool vector_sine = false;        // the pendulum lanes' sines as math::sin's SIMD lanes
};

// Runs member i, i < models.size(), on *models[i] with the load loads[i] (null: none; loads may be
// empty) from q0[i n .. i n + n), p0 likewise, and calls store(i, RunResult&&) from the thread that
// ran it. A member's std::invalid_argument is rethrown prefixed "member i: ". Returns how many
// factorisations the linear implicit methods made (once per distinct model, shared by its members).
template <class Method, class Model, class Store>
int run_members(const std::vector<const Model*>& models, const std::vector<const Load*>& loads, const double* q0,
                const double* p0, const ButcherTableau& tab, const Composition& comp, const EnsembleSpec& ens,
                const Control& member_control, const EnsembleControl& control, Store& store) {
  const long members = static_cast<long>(models.size());
  if (members == 0) return 0;
  const int n = models.front()->size();
  const RunSpec& spec = ens.run;
  const bool loaded = std::any_of(loads.begin(), loads.end(), [](const Load* l) { return l != nullptr; });
  if (spec.temperature != 0.0) check_temperature<Method>(*models.front(), comp, spec.temperature);  // once, here
  // Refusals before the factorisations below, which can take seconds.
  constexpr bool lanes = std::is_same_v<Model, DampedPendulum> && !uses_tableau<Method>();
  if (ens.vector_sine && !lanes)
    throw std::invalid_argument("vector_sine: only the damped pendulum's 3s, 2s and sv ensembles run their "
                                "sines as SIMD lanes");
  if (ens.vector_sine && loaded) throw std::invalid_argument("vector_sine: the SIMD lanes take no load");
  // events/watcher.hpp and record/envelope.hpp: read at every member's step end
  const bool watched = (spec.events && !spec.events->empty()) || spec.dense || spec.envelope;
  if (ens.vector_sine && watched) throw std::invalid_argument("vector_sine: the SIMD lanes locate no events");
  // The linear implicit methods' factorisations: made here, once per distinct model and sub-step length,
  // before any thread starts, and read by every member of that model (each with scratch of its own).
  int factorisations = 0;
  std::vector<std::shared_ptr<const LinearImplicitFactors>> factors(members);
  if constexpr (detail::has_own_stepper<Method>::value) {
    std::map<const Model*, std::shared_ptr<const LinearImplicitFactors>> by_model;
    for (long i = 0; i < members; ++i) {
      auto& made = by_model[models[i]];
      if (!made) made = Method::Stepper::prepare(*models[i], comp, spec);
      factors[i] = made;
    }
    for (const auto& entry : by_model) factorisations += entry.second->count();
  }
  auto initial = [&](long i) {
    using Vec = typename Model::Vec;
    return State<Model::dim>{Vec(Eigen::Map<const Vec>(q0 + i * n, n)), Vec(Eigen::Map<const Vec>(p0 + i * n, n))};
  };
  auto run_member = [&](long i) {
    try {
      RunSpec member_spec = spec;
      member_spec.load = loads.empty() ? nullptr : loads[i];
      member_spec.implicit_factors = factors[i];
      member_spec.stream = ens.first_stream + static_cast<std::uint64_t>(i);
      store(i, integrate_model<Method>(*models[i], tab, comp, initial(i), member_spec, member_control));
    } catch (const std::invalid_argument& e) {
      rethrow_prefixed("member " + std::to_string(i) + ": ", e);
    }
  };
  // Runs each batch with run_batch(batch) on the threads, progress counted in members.
  auto for_each_batch = [&](const std::vector<LaneBatch>& batches, const auto& run_batch) {
    std::atomic<long> finished{0};
    EnsembleControl batch_control;
    long reported = 0;  // called under for_each_member's lock: members counts only grow, as there
    if (control.progress)
      batch_control.progress = [&](long, long) {
        const long now = finished.load();
        if (now > reported) control.progress(reported = now, members);
      };
    for_each_member(static_cast<long>(batches.size()), ens.threads, [&](long b) {
      run_batch(batches[b]);
      finished.fetch_add(batches[b].end - batches[b].begin);
    }, batch_control);
  };
  if constexpr (lanes) {
    if (!loaded && !watched) {  // the lanes' step has no clock, nor events: such members run one by one
      // Runs of members sharing eps go as the lanes of one run (lanes.hpp).
      for_each_batch(lane_batches(models, batch_lanes(members, ensemble_threads(ens.threads, members))),
                     [&](const LaneBatch& batch) {
                       // With vector_sine every member runs as a lane, so that its sines are math::sin's.
                       if (batch.end - batch.begin < kMinLanes && !ens.vector_sine) {
                         for (long i = batch.begin; i < batch.end; ++i) run_member(i);
                       } else {
                         run_lanes<Method>(*models[batch.begin], batch, tab, comp, q0, p0, spec, ens.first_stream,
                                           member_control, ens.vector_sine, store, run_member);
                       }
                     });
      return factorisations;
    }
  }
  // Kepler test particles by 3s, 2s, sv and their compositions: runs of members with the same parameters go
  // as the particles of one run (lanes_kepler.hpp). Not with a load, noise, events, envelopes or saved
  // coordinates, which the batch would see as one run's. Only those methods (baoab serves a temperature,
  // rks is a tableau's): each instantiates the splitting back once more.
  constexpr bool kepler_lanes =
      std::is_same_v<Model, Planets> && (std::is_same_v<Method, ThreeTermSplitting> ||
                                         std::is_same_v<Method, TwoTermSplitting> || std::is_same_v<Method, StormerVerlet>);
  if constexpr (kepler_lanes) {
    if (!loaded && !watched && spec.temperature == 0.0 && !spec.track_work && spec.save_dofs.empty()) {
      for_each_batch(kepler_batches(models, batch_lanes(members, ensemble_threads(ens.threads, members))),
                     [&](const LaneBatch& batch) {
                       if (batch.end - batch.begin < kMinLanes) {
                         for (long i = batch.begin; i < batch.end; ++i) run_member(i);
                       } else {
                         run_kepler_lanes<Method>(*models[batch.begin], batch, tab, comp, q0, p0, spec,
                                                  member_control, store, run_member);
                       }
                     });
      return factorisations;
    }
  }
  for_each_member(members, ens.threads, run_member, control);
  return factorisations;
}

}  // namespace raydamp
