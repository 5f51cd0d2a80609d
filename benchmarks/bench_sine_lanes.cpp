// vector_sine's lanes (models/pendulum_lanes.hpp) in registers of two lanes and of four
// (math/sine_lanes.hpp), side by side: bench_ensemble.py's workload (3s, eps 0.01, h 0.01,
// q0 spread over (-3, 3), p0 = 0, one row saved at the end) as one lane run, timed as the best
// of `rounds` runs of each width taken in turn. Prints figures; never passes or fails on time.
//
//   cmake -S . -B build/bench -DRAYDAMP_BUILD_BENCHMARKS=ON && cmake --build build/bench --target bench_sine_lanes
//   build/bench/benchmarks/bench_sine_lanes [lanes=64] [steps=20000] [rounds=20]
//
// Instructions per member-step, which a shared machine does not disturb: run under
// `valgrind --tool=cachegrind --cache-sim=no` with rounds = 1 at steps N and 2N (keep N near
// 1000) and divide the difference of the "I refs" by lanes * N; the argument `two` or `four`
// after rounds runs that width alone. Valgrind's long doubles are doubles, which fails the
// built-in compositions' checks, so this program builds the one composition it needs itself.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "raydamp/models/pendulum_lanes.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

namespace {

double seconds(math::SineWidth width, int lanes, long steps, double& check) {
  const DampedPendulum member(0.01);
  const ButcherTableau tab = builtin_tableau("heun");  // unused by 3s; any table will do
  const Composition none("none", 2, std::vector<long double>{}, "the base step alone");
  Eigen::VectorXd q0(lanes), p0 = Eigen::VectorXd::Zero(lanes);
  for (int i = 0; i < lanes; ++i) q0[i] = lanes > 1 ? -3.0 + 6.0 * i / (lanes - 1) : 1.0;
  const RunSpec spec{0.01, steps, 0.01, steps};
  const auto start = std::chrono::steady_clock::now();
  RunResult r = detail::run_steps<ThreeTermSplitting>(PendulumLanes(member, lanes, true, width), tab, none,
                                                      State<Eigen::Dynamic>{q0, p0}, spec, Control{});
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  check = r.trajectory.q.back();
  return elapsed;
}

}  // namespace

int main(int argc, char** argv) {
  const int lanes = argc > 1 ? std::atoi(argv[1]) : 64;
  const long steps = argc > 2 ? std::atol(argv[2]) : 20000;
  const int rounds = argc > 3 ? std::atoi(argv[3]) : 20;
  std::vector<math::SineWidth> widths{math::SineWidth::two};
  if (math::best_sine_width() == math::SineWidth::four) widths.push_back(math::SineWidth::four);
  if (argc > 4) widths = {std::strcmp(argv[4], "four") == 0 ? math::SineWidth::four : math::SineWidth::two};
  if (lanes < 1 || steps < 1 || rounds < 1) {
    std::fprintf(stderr, "usage: bench_sine_lanes [lanes >= 1] [steps >= 1] [rounds >= 1] [two|four]\n");
    return 2;
  }
  std::vector<double> best(widths.size(), 1e300), last(widths.size());
  for (int r = 0; r < rounds; ++r)
    for (std::size_t w = 0; w < widths.size(); ++w) best[w] = std::min(best[w], seconds(widths[w], lanes, steps, last[w]));
  std::printf("vector_sine lanes: %d lanes x %ld steps of 3s, best of %d; this processor's best width: %d lanes\n",
              lanes, steps, rounds, static_cast<int>(math::best_sine_width()));
  for (std::size_t w = 0; w < widths.size(); ++w)
    std::printf("  %d lanes per register: %7.3f ns per member-step (last lane's q: %.17g)\n",
                static_cast<int>(widths[w]), best[w] / (static_cast<double>(lanes) * steps) * 1e9, last[w]);
  if (widths.size() == 2) std::printf("  two / four: %.2fx\n", best[0] / best[1]);
  return 0;
}
