// The event watcher's cost per step (events/watcher.hpp) on the damped pendulum (eps = 0.1, 3s, h = 0.01,
// 10^6 whole steps, released from q = 1), from C++ with no Python around it. Through integrate(): the
// whole-step run without events; the floor (one affine g = t - 1e9 that never crosses); one level g = q[0];
// ten levels g = q[0] - 0.1 k; five levels of q and five of p (p's rate is the force: one more sine a step);
// and the one and ten levels again, screened a step at a time in the loop instead of a block at a time
// (RunSpec::batch_screens = false: the watcher's form before batching, the same events). Beside them, the
// floor of any watcher: the same 3s step in a bare loop, alone and with ten sign checks of q[0] - 0.1 k
// inlined after it (no call, no copy, no rate): what ten events cost at the least.
// Then the 10-storey shear frame of benchmarks/ground_motion_frame.py (storey masses 1e5 kg, storey
// stiffness 2e8 N/m, lumped M, 5% Rayleigh damping in modes 1 and 3) by 3s, h = 0.005, 2 10^5 whole steps of
// free vibration from a linear shape (roof at 0.1 m): without events, the floor, and ten storey-drift events
// q[k] - q[k-1] - 0.005 (q[0] - 0.005 for the first storey), as Python's affine forms of those expressions.
// Best of 9 rounds each, the cases interleaved; the ratio to the whole-step run is issue 41's figure
// (target 1.2x). `perf record` on it shows where a step's time goes without the interpreter's share.
// Prints figures; never passes or fails on time. An argument 0-8 runs that pendulum case only, "frame" the
// frame's cases only (for perf).
//
//   g++ -O3 -DNDEBUG -std=c++17 -fPIC -ffp-contract=off -DEIGEN_UNALIGNED_VECTORIZE=0 -Wno-psabi -I cpp/include
//       -isystem /usr/include/eigen3 benchmarks/bench_event_watcher.cpp -o build/bench_event_watcher
//   build/bench_event_watcher
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <Eigen/Eigenvalues>

#include "raydamp/models/linear_structure.hpp"
#include "raydamp/raydamp.hpp"
using namespace raydamp;

// The compiled form that affine events never call (EventSet requires one).
static void dummy(double* out, const double* in, void*) {
  out[0] = in[0];
  out[1] = in[1];
}

// count levels: g = x - 0.1 k on q[0] (the first q_levels of them) and on p[0] (the rest); or one clock
// event that never crosses.
EventSet affine_set(int count, int q_levels, bool never) {
  EventSet set;
  set.fn.fn = &dummy;
  set.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}};  // what g reads: p's levels read p and f too
  if (q_levels < count && !never) set.slots.insert(set.slots.end(), {{EventSlot::Kind::p, 0}, {EventSlot::Kind::f, 0}});
  for (int k = 0; k < count; ++k) {
    EventFunction e(0, false, "e" + std::to_string(k));
    e.affine = true;
    if (never) {
      e.constant = -1e9;
      e.terms = {{EventSlot::Kind::t, 0, 1.0}};
    } else {
      e.constant = -0.1 * (k < q_levels ? k : k - q_levels);
      e.terms = {{k < q_levels ? EventSlot::Kind::q : EventSlot::Kind::p, 0, 1.0}};
    }
    set.events.push_back(e);
  }
  return set;
}

// The 3s step of run_steps, in a bare loop; with checks, ten sign checks of q[0] - 0.1 k after each step.
template <bool Checks>
double bare(const DampedPendulum& pendulum, const ButcherTableau& tab, const Composition& none, State<1> z,
            const RunSpec& spec, long& crossings) {
  Unhooked<WorkspaceFor<DampedPendulum>> ws(pendulum.size(), tab.stages());
  const auto stepper = detail::make_stepper<ThreeTermSplitting>(pendulum, none, spec);
  double level[10];
  for (int k = 0; k < 10; ++k) level[k] = 0.1 * k;
  std::uint64_t was = 0;
  for (int k = 0; k < 10; ++k) was |= static_cast<std::uint64_t>(std::signbit(z.q[0] - level[k])) << k;
  long found = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long i = 0; i < spec.n_steps; ++i) {
    stepper.step(pendulum, tab, z, i, ws);
    if constexpr (Checks) {
      std::uint64_t now = 0;
      for (int k = 0; k < 10; ++k) now |= static_cast<std::uint64_t>(std::signbit(z.q[0] - level[k])) << k;
      found += now != was;
      was = now;
    }
  }
  const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  crossings = found + (z.q[0] > 1e300);  // kept live
  return ns / static_cast<double>(spec.n_steps);
}

// The frame's ten storey drifts above 0.005 m (or one clock event that never crosses).
EventSet drift_set(bool never) {
  EventSet set;
  set.fn.fn = &dummy;
  set.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}};
  for (int k = 0; k < (never ? 1 : 10); ++k) {
    EventFunction e(0, false, "drift" + std::to_string(k));
    e.affine = true;
    e.constant = never ? -1e9 : -0.005;
    if (never) e.terms = {{EventSlot::Kind::t, 0, 1.0}};
    else if (k == 0) e.terms = {{EventSlot::Kind::q, 0, 1.0}};
    else e.terms = {{EventSlot::Kind::q, k, 1.0}, {EventSlot::Kind::q, k - 1, -1.0}};
    set.events.push_back(e);
  }
  return set;
}

void frame() {
  const int n = 10;
  const double mass = 1e5, stiffness = 2e8, zeta = 0.05;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    K(i, i) += stiffness;
    if (i + 1 < n) {
      K(i, i) += stiffness;
      K(i, i + 1) = K(i + 1, i) = -stiffness;
    }
  }
  const Eigen::VectorXd w = (Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K / mass).eigenvalues()).cwiseSqrt();
  const double alpha = 2.0 * zeta * w[0] * w[2] / (w[0] + w[2]), beta = 2.0 * zeta / (w[0] + w[2]);
  const LinearStructure<LumpedMass> s(LumpedMass(Eigen::VectorXd::Constant(n, mass)), K.sparseView(),
                                      Eigen::VectorXd(), alpha, beta);
  State<Eigen::Dynamic> z0{Eigen::VectorXd::LinSpaced(n, 0.01, 0.1), Eigen::VectorXd::Zero(n)};
  const long N = 200000;
  const EventSet floor_ = drift_set(true), drifts = drift_set(false);
  const EventSet* cases[] = {nullptr, &floor_, &drifts};
  const char* names[] = {"whole steps, no events", "floor: 1 event t - 1e9", "10 storey drifts"};
  double best[3] = {1e9, 1e9, 1e9};
  long found[3] = {0, 0, 0};
  for (int round = 0; round < 9; ++round)
    for (int c = 0; c < 3; ++c) {
      RunSpec spec{0.005, N, 0.005, N};
      spec.merge_steps = false;
      spec.events = cases[c];
      const auto t0 = std::chrono::steady_clock::now();
      RunResult r = integrate<ThreeTermSplitting>(s, builtin_tableau("heun"), builtin_composition("none"), z0, spec);
      const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / N;
      best[c] = std::min(best[c], ns);
      found[c] = r.events.size();
      if (r.status != Status::completed) std::printf("status!\n");
    }
  std::printf("10-storey frame, 3s, h = 0.005, %ld whole steps, best of 9\n", N);
  for (int c = 0; c < 3; ++c)
    std::printf("  %-28s %6.1f ns/step  x%.2f  (%ld crossings)\n", names[c], best[c], best[c] / best[0], found[c]);
}

int main(int argc, char** argv) {
  const DampedPendulum pendulum(0.1);
  const ButcherTableau& tab = builtin_tableau("heun");
  const Composition& none = builtin_composition("none");
  State<1> z0{Vector<1>(1.0), Vector<1>(0.0)};
  const long N = 1000000;
  EventSet floor_ = affine_set(1, 1, true), one = affine_set(1, 1, false), ten = affine_set(10, 10, false),
           mixed = affine_set(10, 5, false);
  // the last two: the same events screened in the loop, a step at a time (RunSpec::batch_screens = false)
  const EventSet* cases[] = {nullptr, &floor_, &one, &ten, &mixed, &one, &ten};
  const char* names[] = {"whole steps, no events",  "floor: 1 event t - 1e9",   "1 event q",
                         "10 events q - 0.1k",      "5 on q, 5 on p",           "1 event q, in the loop",
                         "10 events, in the loop",  "bare 3s loop",             "bare loop + 10 sign checks"};
  constexpr int kCases = 9, kBare = 7;
  std::vector<double> best(kCases, 1e9);
  std::vector<long> found(kCases, 0);
  if (argc > 1 && std::strcmp(argv[1], "frame") == 0) return frame(), 0;
  const int only = argc > 1 ? std::atoi(argv[1]) : -1;
  for (int round = 0; round < 9; ++round)
    for (int c = 0; c < kCases; ++c) {
      if (only >= 0 && c != only) continue;
      RunSpec spec{0.01, N, 0.01, N};
      spec.merge_steps = false;
      if (c >= kBare) {
        long crossings = 0;
        const double ns = c == kBare ? bare<false>(pendulum, tab, none, z0, spec, crossings)
                                 : bare<true>(pendulum, tab, none, z0, spec, crossings);
        best[c] = std::min(best[c], ns);
        found[c] = crossings;
        continue;
      }
      spec.events = cases[c];
      spec.batch_screens = c < 5;
      const auto t0 = std::chrono::steady_clock::now();
      RunResult r = integrate<ThreeTermSplitting>(pendulum, tab, none, z0, spec);
      const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / N;
      best[c] = std::min(best[c], ns);
      found[c] = r.events.size();
      if (r.status != Status::completed) std::printf("status!\n");
    }
  std::printf("damped pendulum, 3s, h = 0.01, %ld whole steps, best of 9 (ratio: to the first row; the bare loop's\n"
              "checks to the bare loop)\n",
              N);
  for (int c = 0; c < kCases; ++c)
    std::printf("  %-28s %6.2f ns/step  x%.2f  (%ld %s)\n", names[c], best[c], best[c] / best[c >= kBare ? kBare : 0],
                found[c], c >= kBare ? "steps with a crossing" : "crossings");
  if (only < 0) frame();
}
