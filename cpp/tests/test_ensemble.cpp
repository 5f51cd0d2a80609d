// Ensembles: members spread over threads equal their single runs bit for bit whatever
// the thread count; a failing member reports the lowest failing index.
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/ensemble/driver.hpp"
#include "check.hpp"
#include "raydamp/ensemble.hpp"
#include "raydamp/models/pendulum_lanes.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

int main() {
  const ButcherTableau heun = builtin_tableau("heun");
  const long members = 37;
  std::vector<DampedPendulum> models;
  std::vector<State<1>> starts;
  for (long i = 0; i < members; ++i) {
    models.emplace_back(0.01 * i);
    starts.push_back(State<1>{Vector<1>(-3.0 + 0.15 * i), Vector<1>(0.1 * (i % 5))});
  }
  const RunSpec spec{0.05, 301, 0.05, 7};
  std::vector<RunResult> single(members);
  for (long i = 0; i < members; ++i) single[i] = integrate<ThreeTermSplitting>(models[i], heun, starts[i], spec);

  for (int threads : {1, 2, 3, 8}) {
    std::vector<RunResult> ens(members);
    long reported = 0;
    EnsembleControl control;
    control.progress = [&](long done, long total) {
      CHECK(total == members);
      CHECK(done > reported);  // one call at a time, counts only grow
      reported = done;
    };
    for_each_member(members, threads, [&](long i) {
      ens[i] = integrate<ThreeTermSplitting>(models[i], heun, starts[i], spec);
    }, control);
    CHECK(reported == members);
    for (long i = 0; i < members; ++i) {
      CHECK(ens[i].trajectory.q == single[i].trajectory.q);  // exact equality of every saved double
      CHECK(ens[i].trajectory.p == single[i].trajectory.p);
      CHECK(ens[i].trajectory.t == single[i].trajectory.t);
      CHECK(ens[i].steps == single[i].steps);
    }
  }

  // Progress under contention: members that take no time, a report for every member,
  // so threads race to report. The counts must still only grow and end at `members`
  // (a thread that finished member 36 could once report after the one that finished 37).
  for (int round = 0; round < 200; ++round) {
    long reported = 0;
    bool grew = true;
    EnsembleControl control;
    control.max_progress_calls = 4000;
    control.progress = [&](long done, long) {
      grew = grew && done > reported;
      reported = done;
    };
    for_each_member(4000, 4, [](long) {}, control);
    CHECK(grew);
    CHECK(reported == 4000);
  }

  // Members 11 and 23 fail; whatever the threads, member 11's error is the one reported.
  for (int threads : {1, 2, 4}) {
    std::string what;
    try {
      for_each_member(members, threads, [&](long i) {
        if (i == 11 || i == 23) throw std::invalid_argument("h: bad for member " + std::to_string(i));
      });
    } catch (const std::invalid_argument& e) {
      what = e.what();
    }
    CHECK(what == "h: bad for member 11");
  }
  // Pendulums as lanes of one run: lane i equals member i's single run bit for bit
  // (3s, 2s and a composition; a shortened last step; rows every 7 steps).
  {
    const int lanes = 19;
    const DampedPendulum member(0.3);
    Eigen::VectorXd q0(lanes), p0(lanes);
    for (int i = 0; i < lanes; ++i) {
      q0[i] = -3.0 + 0.31 * i;
      p0[i] = 0.05 * (i % 3);
    }
    const RunSpec lane_spec{0.05, 103, 0.02, 7};
    const Composition& yoshida = builtin_composition("yoshida4");
    auto compare = [&](auto method, const Composition& comp) {
      using Method = decltype(method);
      RunResult all = detail::run_steps<Method>(PendulumLanes(member, lanes), heun, comp,
                                                State<Eigen::Dynamic>{q0, p0}, lane_spec, Control{});
      CHECK(all.status == Status::completed);
      for (int i = 0; i < lanes; ++i) {
        RunResult one = integrate<Method>(member, heun, comp, State<1>{Vector<1>(q0[i]), Vector<1>(p0[i])}, lane_spec);
        CHECK(one.trajectory.rows() == all.trajectory.rows());
        CHECK(one.trajectory.t == all.trajectory.t);
        for (long row = 0; row < one.trajectory.rows(); ++row) {
          CHECK(one.trajectory.q[row] == all.trajectory.q[row * lanes + i]);
          CHECK(one.trajectory.p[row] == all.trajectory.p[row * lanes + i]);
        }
      }
    };
    compare(ThreeTermSplitting{}, builtin_composition("none"));
    compare(TwoTermSplitting{}, builtin_composition("none"));
    compare(ThreeTermSplitting{}, yoshida);
    // vector_sine: the lanes' sines are math::sin's, in registers of two or four lanes
    // (math/sine_lanes.hpp). Lane i then equals a run of member i as the only lane
    // (math::sin) bit for bit, whatever the other lanes, the block it fell in and the
    // width (19 lanes: two blocks of eight or four of four, and a tail of three); it
    // differs from the libm single run by rounding only (measured: about 1e-15 here),
    // and not at all on no lane would mean the flag did nothing.
    std::vector<math::SineWidth> widths{math::SineWidth::two};
    if (math::best_sine_width() == math::SineWidth::four) widths.push_back(math::SineWidth::four);
    auto compare_vector_sine = [&](auto method, math::SineWidth width) {
      using Method = decltype(method);
      const Composition& none = builtin_composition("none");
      RunResult all = detail::run_steps<Method>(PendulumLanes(member, lanes, true, width), heun, none,
                                                State<Eigen::Dynamic>{q0, p0}, lane_spec, Control{});
      CHECK(all.status == Status::completed);
      int differing = 0;
      for (int i = 0; i < lanes; ++i) {
        RunResult alone = detail::run_steps<Method>(PendulumLanes(member, 1, true, width), heun, none,
                                                    State<Eigen::Dynamic>{q0.segment(i, 1), p0.segment(i, 1)},
                                                    lane_spec, Control{});
        RunResult libm = integrate<Method>(member, heun, none, State<1>{Vector<1>(q0[i]), Vector<1>(p0[i])}, lane_spec);
        CHECK(alone.trajectory.rows() == all.trajectory.rows());
        bool differs = false;
        for (long row = 0; row < alone.trajectory.rows(); ++row) {
          CHECK(alone.trajectory.q[row] == all.trajectory.q[row * lanes + i]);
          CHECK(alone.trajectory.p[row] == all.trajectory.p[row * lanes + i]);
          CHECK(std::abs(libm.trajectory.q[row] - alone.trajectory.q[row]) <= 1e-12);
          CHECK(std::abs(libm.trajectory.p[row] - alone.trajectory.p[row]) <= 1e-12);
          differs = differs || libm.trajectory.q[row] != alone.trajectory.q[row];
        }
        differing += differs;
      }
      CHECK(differing > 0);
    };
    for (math::SineWidth width : widths) {
      compare_vector_sine(ThreeTermSplitting{}, width);
      compare_vector_sine(TwoTermSplitting{}, width);  // its kick-damp takes the gradient's kernel
    }
  }
  // vector_sine's AVX2 registers (four lanes) give the SSE2 ones' bits (two lanes): 1003
  // pendulums swinging and going over the top (q0 over (-9, 9), p0 over (-2, 2)), 3s and
  // 2s, every saved row of every member. Only where the processor has AVX2 (printed).
  {
    std::printf("vector_sine widths tested: %zu (best %d lanes)\n", math::best_sine_width() == math::SineWidth::four
                ? std::size_t{2} : std::size_t{1}, static_cast<int>(math::best_sine_width()));
    if (math::best_sine_width() == math::SineWidth::four) {
      const int lanes = 1003;
      const DampedPendulum member(0.05);
      Eigen::VectorXd q0(lanes), p0(lanes);
      for (int i = 0; i < lanes; ++i) {
        q0[i] = -9.0 + 18.0 * i / (lanes - 1);
        p0[i] = -2.0 + 4.0 * ((i * 37) % lanes) / (lanes - 1);
      }
      const RunSpec spec{0.02, 400, 0.02, 50};
      auto same_bits = [&](auto method) {
        using Method = decltype(method);
        const Composition& none = builtin_composition("none");
        RunResult two = detail::run_steps<Method>(PendulumLanes(member, lanes, true, math::SineWidth::two), heun, none,
                                                  State<Eigen::Dynamic>{q0, p0}, spec, Control{});
        RunResult four = detail::run_steps<Method>(PendulumLanes(member, lanes, true, math::SineWidth::four), heun,
                                                   none, State<Eigen::Dynamic>{q0, p0}, spec, Control{});
        CHECK(two.status == Status::completed && four.status == Status::completed);
        CHECK(two.trajectory.rows() == 9);
        CHECK(two.trajectory.q == four.trajectory.q);
        CHECK(two.trajectory.p == four.trajectory.p);
      };
      same_bits(ThreeTermSplitting{});
      same_bits(TwoTermSplitting{});
    }
  }
  // Lane batches: about kBatchesPerThread per thread, between 32 and 256 lanes, a
  // multiple of four, and a change of eps always starts a new batch (members sharing
  // a run share eps).
  CHECK(batch_lanes(1000, 2) == 64);  // 16 batches for 2 threads
  CHECK(batch_lanes(1000, 1) == 128);
  CHECK(batch_lanes(90, 1) == 32);
  CHECK(batch_lanes(1000, 3) == 44);  // 42 rounded up
  CHECK(batch_lanes(100, 2) == 32);
  CHECK(batch_lanes(1000000, 2) == 256);
  {
    const DampedPendulum a(0.1), b(0.2);
    std::vector<const DampedPendulum*> run(100, &a);
    for (int i = 40; i < 50; ++i) run[i] = &b;
    const std::vector<LaneBatch> batches = lane_batches(run, 32);
    const std::vector<long> begins{0, 32, 40, 50, 82};
    CHECK(batches.size() == begins.size());
    for (std::size_t k = 0; k < batches.size() && k < begins.size(); ++k) {
      CHECK(batches[k].begin == begins[k]);
      CHECK(batches[k].end == (k + 1 < begins.size() ? begins[k + 1] : 100));
    }
  }
  // The driver (ensemble/driver.hpp): every member equals its single run bit for bit, on one thread
  // and three, through the pendulum lanes (3s) and one by one (rks), and a member that fails ends with
  // its own status and rows while every other member completes.
  {
    const long count = 24;
    const DampedPendulum calm(0.2), wild(400.0);  // rks's Heun damping sub-step multiplies p by 181 a step
    const double nan = std::nan("");
    std::vector<double> q0(count), p0(count);
    for (long i = 0; i < count; ++i) {
      q0[i] = -2.0 + 0.17 * i;
      p0[i] = 0.1 * (i % 4);
    }
    const RunSpec spec{0.05, 700, 0.05, 9};
    const Composition& none = builtin_composition("none");
    auto check_members = [&](auto method, const std::vector<const DampedPendulum*>& models,
                             const std::vector<double>& q, Status failing, long kept) {
      using Method = decltype(method);
      for (int threads : {1, 3}) {
        std::vector<RunResult> got(count);
        auto store = [&](long i, RunResult&& r) { got[i] = std::move(r); };
        EnsembleSpec ens{spec, 0, threads, false};
        run_members<Method>(models, {}, q.data(), p0.data(), heun, none, ens, Control{}, EnsembleControl{}, store);
        for (long i = 0; i < count; ++i) {
          const RunResult one = integrate<Method>(*models[i], heun, none, State<1>{Vector<1>(q[i]), Vector<1>(p0[i])}, spec);
          CHECK(got[i].status == (i == 5 ? failing : Status::completed));
          CHECK(got[i].status == one.status && got[i].steps == one.steps && got[i].failed_step == one.failed_step);
          CHECK(got[i].trajectory.t == one.trajectory.t);
          CHECK(got[i].trajectory.q == one.trajectory.q);  // every saved double
          CHECK(got[i].trajectory.p == one.trajectory.p);
          CHECK(got[i].trajectory.energy == one.trajectory.energy);
        }
        CHECK(got[5].trajectory.rows() == kept && got[0].trajectory.rows() == save_rows(700, 9));
      }
    };
    std::vector<const DampedPendulum*> one_wild(count, &calm);
    one_wild[5] = &wild;
    // member 5 overflows at step 137 (p x 181 a step): rows 0, 9, ..., 135 and its last finite state, 136
    check_members(RungeKuttaSplitting{}, one_wild, q0, Status::non_finite, 17);
    std::vector<double> one_nan = q0;
    one_nan[5] = nan;  // the lane run fails at once; its members then run one by one
    check_members(ThreeTermSplitting{}, std::vector<const DampedPendulum*>(count, &calm), one_nan, Status::non_finite, 0);
  }
  CHECK(ensemble_threads(0, 5) >= 1);
  CHECK(ensemble_threads(4, 2) == 2);
  return raydamp::test::failures == 0 ? 0 : 1;
}
