// The ensemble's lane path for damped pendulums: runs of consecutive members that
// share eps go through the one step loop as the lanes of one PendulumLanes run
// (models/pendulum_lanes.hpp), then are split back into members whose rows equal
// their single runs bit for bit.
#pragma once

#include <utility>
#include <vector>

#include "raydamp/raydamp.hpp"
#include "raydamp/models/pendulum_lanes.hpp"

namespace raydamp::bindings {

struct LaneBatch {
  long begin, end;  // members [begin, end)
};
// Lanes per run: 256 pendulums are 4 KiB of state, which stays in L1 cache.
inline constexpr long kLanes = 256;
// Fewer members sharing eps than this run one by one (the fixed-size loop is faster there).
inline constexpr long kMinLanes = 4;

// Consecutive members with the same eps, cut every kLanes members.
inline std::vector<LaneBatch> lane_batches(const std::vector<const DampedPendulum*>& models) {
  std::vector<LaneBatch> out;
  const long members = static_cast<long>(models.size());
  long begin = 0;
  for (long i = 1; i <= members; ++i)
    if (i == members || models[i]->eps != models[begin]->eps || i - begin == kLanes) {
      out.push_back({begin, i});
      begin = i;
    }
  return out;
}

// Runs batch's members as lanes and hands each to store(i, RunResult) as its own
// run; a lane run that does not complete (a blow-up, a cancellation) is run again
// member by member with run_member(i), so every member gets its own status and rows.
template <class Method, class Store, class RunMember>
void run_lanes(const DampedPendulum& member, const LaneBatch& batch, const ButcherTableau& tab,
               const Composition& comp, const double* q0, const double* p0, const RunSpec& spec,
               const Control& control, Store& store, RunMember& run_member) {
  const int lanes = static_cast<int>(batch.end - batch.begin);
  // integrate's own check, per member, as a single run makes it.
  for (long i = batch.begin; i < batch.end; ++i) {
    try {
      check_amplification<Method>(member, Vector<1>(q0[i]), tab, comp, spec.h);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("member " + std::to_string(i) + ": " + e.what());
    }
  }
  const PendulumLanes model(member, lanes);
  State<Eigen::Dynamic> z{Eigen::Map<const Eigen::VectorXd>(q0 + batch.begin, lanes),
                          Eigen::Map<const Eigen::VectorXd>(p0 + batch.begin, lanes)};
  RunResult r = detail::run_steps<Method>(model, tab, comp, std::move(z), spec, control);
  if (r.status != Status::completed) {
    for (long i = batch.begin; i < batch.end; ++i) run_member(i);
    return;
  }
  const Trajectory& tr = r.trajectory;
  const long rows = tr.rows();
  for (int lane = 0; lane < lanes; ++lane) {
    RunResult one;
    one.status = r.status;
    one.steps = r.steps;
    one.failed_step = r.failed_step;
    one.message = r.message;
    one.max_momentum_drift = r.max_momentum_drift;
    Trajectory& out = one.trajectory;
    out.n = 1;
    out.t = tr.t;
    out.q.resize(rows);
    out.p.resize(rows);
    out.energy.resize(rows);
    for (long row = 0; row < rows; ++row) {
      out.q[row] = tr.q[row * lanes + lane];
      out.p[row] = tr.p[row * lanes + lane];
      // The member's energy by the single run's own formula (integrate.hpp's energy).
      out.energy[row] = energy(member, State<1>{Vector<1>(out.q[row]), Vector<1>(out.p[row])});
    }
    store(batch.begin + lane, std::move(one));
  }
}

}  // namespace raydamp::bindings
