// The exact Kepler drift (flows/kepler.hpp) in its two forms side by side: kepler::drift, which takes a
// step short beside the orbit (kShortReach) in double, and kepler::extended_drift, the long-double form
// every step took before. Two tables:
//   cost: ns per drift over bench_vs_rebound.py's ensemble (1,000 orbits, pericentre radii 0.5-2, e 0-0.7,
//         h = 0.01), best of `rounds` short rounds;
//   accuracy: the relative energy change after n drifts of orbits at reach |t| (|v0| + sqrt(mu/r0)) / r0
//         near kShortReach (the most a double step takes), each form against the other: a rounding that
//         repeats from step to step would show as |dE/E| growing like n rather than sqrt(n).
//   step loop: ns per member per step of 2s on one Kepler(particles=1000) (bench_vs_rebound.py's ensemble
//         door), with the drift as it is (lanes), one body at a time, and every drift in long double.
// Prints figures; never passes or fails on time.
//
//   g++ -O2 -march=x86-64-v2 -DNDEBUG -I cpp/include -I /usr/include/eigen3 benchmarks/bench_kepler_drift.cpp \
//       -o build/bench_kepler_drift && build/bench_kepler_drift [rounds=200]
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "raydamp/flows/kepler.hpp"
#include "raydamp/models/kepler.hpp"
#include "raydamp/raydamp.hpp"

namespace {

using Vec2 = Eigen::Vector2d;

struct Orbits {
  std::vector<Vec2> q, v;
};

Orbits ensemble(int members) {
  std::mt19937_64 rng(46);
  std::uniform_real_distribution<double> radius(0.5, 2.0), ecc(0.0, 0.7);
  Orbits o;
  for (int i = 0; i < members; ++i) {
    const double rp = radius(rng), e = ecc(rng);
    o.q.emplace_back(rp, 0.0);
    o.v.emplace_back(0.0, std::sqrt((1.0 + e) / rp));
  }
  return o;
}

template <class Drift>
double ns_per_drift(const Orbits& start, double h, long steps, int rounds, Drift drift, double& check) {
  double best = 1e300;
  for (int r = 0; r < rounds; ++r) {
    Orbits o = start;
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < o.q.size(); ++i)
      for (long k = 0; k < steps; ++k) drift(1.0, h, o.q[i], o.v[i]);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, s);
    check = o.q[0][0] + o.q.back()[1];
  }
  return 1e9 * best / (static_cast<double>(start.q.size()) * steps);
}

// The Kepler kind with its drift one body at a time: the step loop as it ran before the lanes.
struct ScalarKepler : raydamp::Kepler {
  using raydamp::Kepler::Kepler;
  void drift(Vec& q, Vec& p, double t) const {
    for (int i = 0; i < planets; ++i)
      raydamp::kepler::drift_body(mu[i], mass.m[2 * i], mass.inverse[2 * i], t, 2, &q[2 * i], &p[2 * i]);
  }
};

// Every body of the ensemble drifted `steps` times by drift_bodies (mass 1: p = v), best of `rounds`.
double ns_per_lane_drift(const Orbits& start, double h, long steps, int rounds, double& check) {
  const int n = static_cast<int>(start.q.size());
  std::vector<double> mu(n, 1.0), m(2 * n, 1.0), q0(2 * n), p0(2 * n);
  for (int i = 0; i < n; ++i) q0[2 * i] = start.q[i][0], q0[2 * i + 1] = start.q[i][1], p0[2 * i] = start.v[i][0],
                             p0[2 * i + 1] = start.v[i][1];
  double best = 1e300;
  for (int r = 0; r < rounds; ++r) {
    std::vector<double> q = q0, p = p0;
    const auto t0 = std::chrono::steady_clock::now();
    for (long k = 0; k < steps; ++k) raydamp::kepler::drift_bodies(mu.data(), m.data(), m.data(), h, 2, n, q.data(), p.data());
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    check = q[0] + q[2 * n - 1];
  }
  return 1e9 * best / (static_cast<double>(n) * steps);
}

// The Kepler kind with every drift in long double: the step loop as it ran before the short-step path.
struct ExtendedKepler : raydamp::Kepler {
  using raydamp::Kepler::Kepler;
  void drift(Vec& q, Vec& p, double t) const {
    for (int i = 0; i < planets; ++i) {
      Eigen::Vector2d x(q[2 * i], q[2 * i + 1]), v(p[2 * i], p[2 * i + 1]);  // mass 1
      raydamp::kepler::extended_drift(mu[i], t, x, v);
      q[2 * i] = x[0], q[2 * i + 1] = x[1], p[2 * i] = v[0], p[2 * i + 1] = v[1];
    }
  }
};

template <class Model>
double ns_per_member_step(const Model& model, const Orbits& o, int rounds, long steps, double& check) {
  const int n = static_cast<int>(o.q.size());
  Eigen::VectorXd q(2 * n), p(2 * n);
  for (int i = 0; i < n; ++i) q.segment<2>(2 * i) = o.q[i], p.segment<2>(2 * i) = o.v[i];
  const raydamp::ButcherTableau& tab = raydamp::builtin_tableau("heun");  // unused by 2s
  double best = 1e300;
  for (int r = 0; r < rounds; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    raydamp::RunResult res = raydamp::integrate<raydamp::TwoTermSplitting>(
        model, tab, raydamp::State<Eigen::Dynamic>{q, p}, raydamp::RunSpec{0.01, steps, 0.01, steps});
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    check = res.trajectory.q.back();
  }
  return 1e9 * best / (static_cast<double>(n) * steps);
}

double energy(const Vec2& q, const Vec2& v) { return 0.5 * v.squaredNorm() - 1.0 / q.norm(); }

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 200;
  const Orbits o = ensemble(1000);
  double a = 0, b = 0;
  auto fast = [](double mu, double t, Vec2& q, Vec2& v) { raydamp::kepler::drift(mu, t, q, v); };
  auto extended = [](double mu, double t, Vec2& q, Vec2& v) { raydamp::kepler::extended_drift(mu, t, q, v); };
  const double ns_fast = ns_per_drift(o, 0.01, 100, rounds, fast, a);
  const double ns_ext = ns_per_drift(o, 0.01, 100, rounds, extended, b);
  std::printf("cost, 1,000 orbits x 100 drifts of h = 0.01 (best of %d: short rounds, so that the best is one\n"
              "that no other process interrupted):\n", rounds);
  std::printf("  kepler::drift (short steps in double)   %6.1f ns per drift\n", ns_fast);
  std::printf("  kepler::extended_drift (long double)    %6.1f ns per drift   (checks %.3f %.3f)\n", ns_ext, a, b);
  double l = 0;
  const double ns_lanes = ns_per_lane_drift(o, 0.01, 100, rounds, l);
  std::printf("  kepler::drift_bodies (SIMD lanes)       %6.1f ns per drift   (check %.3f)\n", ns_lanes, l);

  const raydamp::Kepler model(1.0, 1.0, 2, 1000, 1e-3);
  const ScalarKepler scalar_model(1.0, 1.0, 2, 1000, 1e-3);
  const ExtendedKepler extended_model(1.0, 1.0, 2, 1000, 1e-3);
  double c = 0, d = 0, e = 0;
  const double step_fast = ns_per_member_step(model, o, rounds / 10 + 1, 100, c);
  const double step_scalar = ns_per_member_step(scalar_model, o, rounds / 10 + 1, 100, e);
  const double step_ext = ns_per_member_step(extended_model, o, rounds / 10 + 1, 100, d);
  std::printf("\nstep loop, 2s, eps = 1e-3, one Kepler(particles=1000), 100 steps of h = 0.01 (best of %d):\n",
              rounds / 10 + 1);
  std::printf("  the drift as it is (SIMD lanes)         %6.1f ns per member per step\n", step_fast);
  std::printf("  one body at a time                      %6.1f ns per member per step   (check %.3f)\n",
              step_scalar, e);
  std::printf("  every drift in long double (as before)  %6.1f ns per member per step   (checks %.3f %.3f)\n",
              step_ext, c, d);

  std::printf("\naccuracy: |E - E0| / |E0| after n drifts, e at pericentre rp = 1, h at reach ~ kShortReach = %.2f\n",
              raydamp::kepler::kShortReach);
  std::printf("  %5s %9s %10s %12s %12s\n", "e", "h", "n", "double", "long double");
  for (double e : {0.0, 0.5, 0.9}) {
    const Vec2 q0(1.0, 0.0), v0(0.0, std::sqrt(1.0 + e));
    // reach at the pericentre, where it is largest: h (v + 1) < kShortReach
    const double h = 0.95 * raydamp::kepler::kShortReach / (std::sqrt(2.0) * std::sqrt(v0.squaredNorm() + 1.0));
    const double e0 = energy(q0, v0);
    for (long n : {10000L, 100000L, 1000000L}) {
      Vec2 qa = q0, va = v0, qb = q0, vb = v0;
      for (long k = 0; k < n; ++k) {
        raydamp::kepler::drift(1.0, h, qa, va);
        raydamp::kepler::extended_drift(1.0, h, qb, vb);
      }
      std::printf("  %5.2f %9.3g %10ld %12.2e %12.2e\n", e, h, n, std::abs(energy(qa, va) - e0) / std::abs(e0),
                  std::abs(energy(qb, vb) - e0) / std::abs(e0));
    }
  }
  return 0;
}
