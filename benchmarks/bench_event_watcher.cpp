// The event watcher's cost per step (events/watcher.hpp) on the damped pendulum (eps = 0.1, 3s, h = 0.01,
// 10^6 whole steps), from C++ with no Python around it: the whole-step run without events, the floor (one
// affine g = t - 1e9 that never crosses), one level event g = q[0] and ten g = q[0] - 0.1 k. Best of 9
// rounds each, the cases interleaved; the ratio to the whole-step run is issue 41's figure (target 1.2x).
// `perf record` on it shows where a step's time goes without the interpreter's share.
// Prints figures; never passes or fails on time. An argument 0-3 runs that case only (for perf).
//
//   g++ -O3 -DNDEBUG -std=c++17 -DEIGEN_UNALIGNED_VECTORIZE=0 -Wno-psabi -I cpp/include -isystem /usr/include/eigen3
//       benchmarks/bench_event_watcher.cpp -o build/bench_event_watcher && build/bench_event_watcher
#include <chrono>
#include <cstdio>
#include <algorithm>
#include <vector>
#include <cstdlib>
#include "raydamp/raydamp.hpp"
using namespace raydamp;
// The compiled form that affine events never call (EventSet requires one).
static void dummy(double* out, const double* in, void*) { out[0] = in[0]; out[1] = in[1]; }
EventSet affine_set(int count, bool never) {
  EventSet set; set.fn.fn = &dummy;
  set.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}};
  for (int k = 0; k < count; ++k) {
    EventFunction e(0, false, "e" + std::to_string(k));
    e.affine = true;
    if (never) { e.constant = -1e9; e.terms = {{EventSlot::Kind::t, 0, 1.0}}; }
    else { e.constant = -0.1 * k; e.terms = {{EventSlot::Kind::q, 0, 1.0}}; }
    set.events.push_back(e);
  }
  return set;
}
int main(int argc, char** argv) {
  const DampedPendulum pendulum(0.1);
  const ButcherTableau& tab = builtin_tableau("heun");
  const Composition& none = builtin_composition("none");
  State<1> z0{Vector<1>(1.0), Vector<1>(0.0)};
  const long N = 1000000;
  EventSet floor_ = affine_set(1, true), one = affine_set(1, false), ten = affine_set(10, false);
  const EventSet* cases[] = {nullptr, &floor_, &one, &ten};
  const char* names[] = {"whole", "floor", "1 event", "10 events"};
  std::vector<double> best(4, 1e9);
  const int only = argc > 1 ? std::atoi(argv[1]) : -1;
  for (int round = 0; round < 9; ++round)
    for (int c = 0; c < 4; ++c) {
      if (only >= 0 && c != only) continue;
      RunSpec spec{0.01, N, 0.01, N};
      spec.merge_steps = false;
      spec.events = cases[c];
      auto t0 = std::chrono::steady_clock::now();
      RunResult r = integrate<ThreeTermSplitting>(pendulum, tab, none, z0, spec);
      double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / N;
      best[c] = std::min(best[c], ns);
      if (r.status != Status::completed) std::printf("status!\n");
    }
  for (int c = 0; c < 4; ++c) std::printf("%-10s %6.2f ns/step  x%.2f\n", names[c], best[c], best[c] / best[0]);
}
