// The step loop: saving, the final row, blow-up detection at the exact step, cancellation.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

// The build's Eigen configuration (CMakeLists.txt): a fixed 3-vector runs in scalars,
// a dynamic one in SIMD packets. Without the first, the elastic pendulum's step pays
// for packet shuffles on its serial chain (benchmarks/bench_steps.py).
static_assert(!(Eigen::internal::evaluator<Eigen::Vector3d>::Flags & Eigen::PacketAccessBit),
              "the raydamp target sets EIGEN_UNALIGNED_VECTORIZE=0");
static_assert(Eigen::internal::evaluator<Eigen::VectorXd>::Flags & Eigen::PacketAccessBit,
              "dynamic-size vectors keep their SIMD packets");

using namespace raydamp;

int main() {
  DampedPendulum pendulum(0.01);
  const State<1> z0{Vector<1>(0.9 * M_PI), Vector<1>(0.0)};
  const ButcherTableau heun = builtin_tableau("heun");

  // save_every = 3 over 10 steps: rows at 0, 3, 6, 9 and the final 10.
  {
    RunResult r = integrate<ThreeTermSplitting>(pendulum, heun, z0, RunSpec{0.1, 10, 0.1, 3});
    CHECK(r.status == Status::completed);
    CHECK(r.trajectory.rows() == 5);
    CHECK_NEAR(r.trajectory.t[3], 0.9, 1e-15);
    CHECK_NEAR(r.trajectory.t[4], 1.0, 1e-15);
    CHECK(r.steps == 10);
  }
  // A short last step lands exactly on t_end.
  {
    RunResult r = integrate<TwoTermSplitting>(pendulum, heun, z0, RunSpec{0.3, 4, 0.1, 1});
    CHECK_NEAR(r.trajectory.t.back(), 1.0, 1e-15);
  }
  // Blow-up: Heun on the pendulum with a huge step. Replaying by hand finds the
  // first non-finite step; the loop must report that step and keep what came before.
  {
    // Heun on p' = -eps p multiplies p by 1 - x + x^2/2 per step, x = h eps = 100.
    DampedPendulum wild(100.0);
    const State<1> start{Vector<1>(0.5), Vector<1>(1.0)};
    const double h = 1.0;
    State<1> z = start;
    Workspace<1> ws(1, 2);
    long first_bad = -1;
    for (long i = 0; i < 5000 && first_bad < 0; ++i) {
      step<RungeKutta>(wild, heun, z, h, ws);
      if (!z.all_finite()) first_bad = i + 1;
    }
    CHECK(first_bad > 1);
    RunResult r = integrate<RungeKutta>(wild, heun, start, RunSpec{h, 5000, h, 1});
    std::printf("blow-up at step %ld (replay says %ld)\n", r.failed_step, first_bad);
    CHECK(r.status == Status::non_finite);
    CHECK(r.failed_step == first_bad);
    CHECK(r.steps == first_bad - 1);
    CHECK(r.trajectory.rows() == first_bad);  // rows 0 .. first_bad - 1, all finite
    for (double x : r.trajectory.q) CHECK(std::isfinite(x));
    for (double x : r.trajectory.p) CHECK(std::isfinite(x));
  }
  // The same blow-up with few saved points: blocks of up to 256 steps, so the failing
  // block is replayed step by step; the step found and the rows kept must not change.
  {
    DampedPendulum wild(100.0);
    const State<1> start{Vector<1>(0.5), Vector<1>(1.0)};
    RunResult every = integrate<RungeKutta>(wild, heun, start, RunSpec{1.0, 5000, 1.0, 1});
    RunResult sparse = integrate<RungeKutta>(wild, heun, start, RunSpec{1.0, 5000, 1.0, 1000});
    CHECK(sparse.status == Status::non_finite);
    CHECK(sparse.failed_step == every.failed_step);
    CHECK(sparse.steps == every.steps);
    CHECK(sparse.trajectory.rows() == 2);  // the initial state and the last finite one
    CHECK(sparse.trajectory.p.back() == every.trajectory.p.back());
    CHECK(sparse.trajectory.t.back() == every.trajectory.t.back());
  }
  // Divergence (record/divergence.hpp): Heun's damping on p' = -eps p multiplies p by 1 - x + x^2/2 =
  // 1.105 a step at x = h eps = 2.1, so p gains 1e11 over the first 256 steps and would overflow only
  // after about 7000. The run stops "diverged" at the first check, the first block's end at or past
  // step 256 (blocks end at the progress points, every 50 steps here: step 300), with its rows: the
  // same bits as a run of that many steps without the test. Without it, 5000 steps "complete" at
  // |p| ~ 1e216.
  {
    const DampedPendulum slow(42.0);
    const State<1> start{Vector<1>(0.5), Vector<1>(1.0)};
    const RunResult r = integrate<RungeKutta>(slow, heun, start, RunSpec{0.05, 5000, 0.05, 1000});
    std::printf("%s\n", r.message.c_str());
    CHECK(r.status == Status::diverged);
    CHECK(r.failed_step == 300 && r.steps == 300);
    CHECK(r.trajectory.rows() == 2 && r.trajectory.t.back() == 300 * 0.05);
    RunSpec off{0.05, 300, 0.05, 1000};
    off.divergence = 0.0;
    const RunResult same = integrate<RungeKutta>(slow, heun, start, off);
    CHECK(same.status == Status::completed && same.trajectory.p.back() == r.trajectory.p.back());
    off.n_steps = 5000;
    const RunResult unchecked = integrate<RungeKutta>(slow, heun, start, off);
    CHECK(unchecked.status == Status::completed && std::abs(unchecked.trajectory.p.back()) > 1e200);
    // The same stiff damping run by 3s, whose damping flow is exact: nothing to flag.
    const RunResult exact = integrate<ThreeTermSplitting>(slow, heun, start, RunSpec{0.05, 5000, 0.05, 1000});
    CHECK(exact.status == Status::completed);
    // A bad factor is refused.
    RunSpec bad{0.05, 10, 0.05, 1};
    bad.divergence = -1.0;
    CHECK(test::throws([&] { integrate<RungeKutta>(slow, heun, start, bad); }));
  }
  // The save grid: step 0, every save_every-th step and the last, at the times the loop saves them.
  {
    CHECK(save_rows(10, 3) == 5 && save_rows(9, 3) == 4 && save_rows(0, 1) == 1);
    const std::vector<double> grid = save_grid(0.3, 4, 0.1, 3);
    CHECK(grid.size() == 3 && grid[1] == 3 * 0.3 && grid[2] == 3 * 0.3 + 0.1);
    const RunResult r = integrate<TwoTermSplitting>(pendulum, heun, z0, RunSpec{0.3, 4, 0.1, 3});
    CHECK(r.trajectory.t == grid);
  }
  // Cancellation before the first block: only the initial row.
  {
    std::atomic<bool> cancel{true};
    Control control;
    control.cancel = &cancel;
    RunResult r = integrate<ThreeTermSplitting>(pendulum, heun, z0, RunSpec{0.1, 1000, 0.1, 1}, control);
    CHECK(r.status == Status::cancelled);
    CHECK(r.steps == 0 && r.trajectory.rows() == 1);
  }
  // Progress is called a bounded number of times, ending at the total.
  {
    long calls = 0, last = 0;
    Control control;
    control.progress = [&](long done, long) { ++calls; last = done; };
    integrate<ThreeTermSplitting>(pendulum, heun, z0, RunSpec{0.01, 123457, 0.01, 1000}, control);
    CHECK(calls <= 102 && calls >= 50);
    CHECK(last == 123457);
  }
  // The unrolled (fixed stage count) loop computes what the run-time table does.
  {
    ElasticPendulum elastic(0.3);
    const State<3> w0{Vector<3>(0.0, 1.55884573, -0.6), Vector<3>(1.34164079, 0.0, 0.0)};
    for (const char* name : {"heun", "rk4", "midpoint", "euler"}) {
      const ButcherTableau& tab = builtin_tableau(name);
      const RunSpec spec{0.1, 1000, 0.1, 1000};
      RunResult fixed = integrate<RungeKuttaSplitting>(elastic, tab, w0, spec);
      RunResult table =
          detail::run_steps<RungeKuttaSplitting>(elastic, tab, builtin_composition("none"), w0, spec, Control{});
      for (int i = 0; i < 3; ++i) {
        CHECK_NEAR(fixed.trajectory.q[3 + i], table.trajectory.q[3 + i], 1e-13);
        CHECK_NEAR(fixed.trajectory.p[3 + i], table.trajectory.p[3 + i], 1e-13);
      }
    }
  }
  TEST_MAIN_RETURN();
}
