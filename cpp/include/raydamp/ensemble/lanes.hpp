// The ensemble's lane path for damped pendulums: runs of consecutive members that
// share eps go through the one step loop as the lanes of one PendulumLanes run
// (models/pendulum_lanes.hpp), then are split back into members whose rows equal
// their single runs bit for bit.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "raydamp/errors.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/models/pendulum_lanes.hpp"

namespace raydamp {

struct LaneBatch {
  long begin, end;  // members [begin, end)
};
// Lanes per run: at most 256 pendulums (4 KiB of state, which stays in L1 cache).
inline constexpr long kLanes = 256;
// At least this many (below it the per-pass loop overhead starts to show; 32 lanes
// cost the same per member-step as 256 here).
inline constexpr long kMinBatchLanes = 32;
// Fewer members sharing eps than this run one by one (the fixed-size loop is faster there).
inline constexpr long kMinLanes = 4;
// Batches per thread the lanes are cut into: threads take batches from one counter,
// so with several per thread a thread that was slowed (another process on its core,
// a batch whose members swing wider and spend longer in sin's slower range) hands
// the rest to the others. With 4 batches of 256 for 1000 members on 2 threads, the
// thread that finished first idled for up to a whole batch (a quarter of the run).
inline constexpr long kBatchesPerThread = 8;

// Lanes per batch for `members` members on `threads` threads: a whole number of
// vector_sine's blocks of four, so that no batch but an eps run's last ends in lanes
// that take the scalar sine (63 lanes cost 4% more per member-step than 64).
inline long batch_lanes(long members, int threads) {
  const long per = (members + kBatchesPerThread * threads - 1) / (kBatchesPerThread * threads);
  return std::clamp((per + 3) / 4 * 4, kMinBatchLanes, kLanes);
}

// How a batch's run ended (status, steps, failed step, message, momentum drift), copied into one member's
// result: every member of a batch ends as the batch did.
inline void copy_outcome(const RunResult& batch, RunResult& member) {
  member.status = batch.status;
  member.steps = batch.steps;
  member.failed_step = batch.failed_step;
  member.message = batch.message;
  member.max_momentum_drift = batch.max_momentum_drift;
}

// Consecutive members for which same(member, the batch's first) holds, cut every `lanes` members.
template <class Model, class Same>
std::vector<LaneBatch> consecutive_batches(const std::vector<const Model*>& models, long lanes, const Same& same) {
  std::vector<LaneBatch> out;
  const long members = static_cast<long>(models.size());
  long begin = 0;
  for (long i = 1; i <= members; ++i)
    if (i == members || !same(*models[i], *models[begin]) || i - begin == lanes) {
      out.push_back({begin, i});
      begin = i;
    }
  return out;
}

// Consecutive members with the same eps, cut every `lanes` members.
inline std::vector<LaneBatch> lane_batches(const std::vector<const DampedPendulum*>& models, long lanes = kLanes) {
  return consecutive_batches(models, lanes,
                             [](const DampedPendulum& a, const DampedPendulum& b) { return a.eps == b.eps; });
}

// Runs batch's members as lanes and hands each to store(i, RunResult) as its own
// run; a lane run that does not complete (a blow-up, a cancellation) is run again
// member by member, so every member gets its own status and rows: with run_member(i),
// its single run, or with vector_sine as a run of one lane (the sines it had here).
template <class Method, class Store, class RunMember>
void run_lanes(const DampedPendulum& member, const LaneBatch& batch, const ButcherTableau& tab,
               const Composition& comp, const double* q0, const double* p0, const RunSpec& spec,
               std::uint64_t first_stream, const Control& control, bool vector_sine, Store& store,
               RunMember& run_member) {
  const int lanes = static_cast<int>(batch.end - batch.begin);
  // integrate's own check, per member, as a single run makes it.
  for (long i = batch.begin; i < batch.end; ++i) {
    try {
      check_amplification<Method>(member, Vector<1>(q0[i]), tab, comp, spec.h);
    } catch (const std::invalid_argument& e) {
      rethrow_prefixed("member " + std::to_string(i) + ": ", e);
    }
  }
  const PendulumLanes model(member, lanes, vector_sine);
  State<Eigen::Dynamic> z{Eigen::Map<const Eigen::VectorXd>(q0 + batch.begin, lanes),
                          Eigen::Map<const Eigen::VectorXd>(p0 + batch.begin, lanes)};
  // At a temperature lane k draws member (begin + k)'s stream, as that member's single run does.
  RunSpec lane_spec = spec;
  lane_spec.stream = first_stream + static_cast<std::uint64_t>(batch.begin);
  lane_spec.stream_per_coordinate = true;
  RunResult r = detail::run_steps<Method>(model, tab, comp, std::move(z), lane_spec, control);
  if (r.status != Status::completed && !vector_sine) {
    for (long i = batch.begin; i < batch.end; ++i) run_member(i);
    return;
  }
  if (r.status != Status::completed && lanes > 1) {
    for (long i = batch.begin; i < batch.end; ++i)
      run_lanes<Method>(member, LaneBatch{i, i + 1}, tab, comp, q0, p0, spec, first_stream, control, true, store,
                        run_member);
    return;
  }
  const Trajectory& tr = r.trajectory;
  const long rows = tr.rows();
  // One member's result, refilled for each lane: the buffers are allocated once per
  // batch, not once per member (store() copies what it keeps; what it takes, the
  // refill gives back).
  RunResult one;
  Trajectory& out = one.trajectory;
  for (int lane = 0; lane < lanes; ++lane) {
    copy_outcome(r, one);
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

}  // namespace raydamp
