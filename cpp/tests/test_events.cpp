// Events and dense output (events/watcher.hpp): crossing times against a closed form, a terminal
// event's shortened last step, and the stepped trajectory unchanged by watching it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

namespace {

// g = q0, dg/dt = v0: the event function Python compiles for "q[0]" (slots q0, v0).
void angle(double* out, const double* in, void*) {
  out[0] = in[0];
  out[1] = in[1];
}

EventSet angle_events(int direction, bool terminal) {
  EventSet set;
  set.fn.fn = &angle;
  set.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}};
  set.events.push_back({direction, terminal, "vertical"});
  return set;
}

// The complete elliptic integral of the first kind, K(k), by the arithmetic-geometric mean.
double ellipk(double k) {
  double a = 1.0, b = std::sqrt(1.0 - k * k);
  for (int i = 0; i < 40; ++i) {
    const double next = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = next;
  }
  return M_PI / (2.0 * a);
}

}  // namespace

int main() {
  const DampedPendulum pendulum(0.0);
  const ButcherTableau& tab = builtin_tableau("heun");
  const Composition& yoshida = builtin_composition("yoshida4");
  const double theta0 = 1.0;
  const double quarter = ellipk(std::sin(theta0 / 2.0));  // omega_0 = 1
  State<1> z0{Vector<1>(theta0), Vector<1>(0.0)};

  // A terminal event at the first downward crossing of the vertical: the quarter period, to order 4.
  {
    const EventSet events = angle_events(-1, true);
    double err[2];
    const double hs[2] = {0.02, 0.01};
    for (int k = 0; k < 2; ++k) {
      RunSpec spec{hs[k], static_cast<long>(std::lround(5.0 / hs[k])), hs[k], 1};
      spec.events = &events;
      RunResult r = integrate<StormerVerlet>(pendulum, tab, yoshida, z0, spec);
      CHECK(r.status == Status::event);
      CHECK(r.events.size() == 1);
      err[k] = std::abs(r.events.t[0] - quarter);
      CHECK_NEAR(r.trajectory.t.back(), r.events.t[0], 0.0);  // the last row is at the event
      CHECK_NEAR(r.trajectory.q.back(), 0.0, 1e-7);           // the shortened step lands on it
      CHECK(r.steps == static_cast<long>(std::ceil(quarter / hs[k])));
    }
    std::printf("quarter period errors %.3g %.3g, slope %.2f\n", err[0], err[1], std::log2(err[0] / err[1]));
    CHECK(err[1] < 1e-8);
    CHECK(std::log2(err[0] / err[1]) > 3.8);
  }

  // Both directions over several periods: crossings alternate, half a period apart; the trajectory
  // equals the run without events bit for bit (both whole steps: sv's merged kicks are off with events).
  {
    const EventSet events = angle_events(0, false);
    RunSpec spec{0.01, 2000, 0.01, 1};
    spec.merge_steps = false;
    RunResult plain = integrate<StormerVerlet>(pendulum, tab, yoshida, z0, spec);
    spec.events = &events;
    spec.dense = true;
    RunResult watched = integrate<StormerVerlet>(pendulum, tab, yoshida, z0, spec);
    CHECK(watched.status == Status::completed);
    CHECK(watched.trajectory.q == plain.trajectory.q && watched.trajectory.p == plain.trajectory.p);
    CHECK(watched.events.size() == static_cast<long>(std::floor((20.0 / quarter + 1.0) / 2.0)));
    for (long i = 0; i < watched.events.size(); ++i) {
      CHECK_NEAR(watched.events.t[i], (2 * i + 1) * quarter, 1e-7);
      CHECK(watched.events.direction[i] == (i % 2 == 0 ? -1 : 1));
      CHECK_NEAR(watched.events.q[i], 0.0, 1e-12);
    }
    CHECK(watched.dense.rows() == 2001);
    CHECK(watched.dense.q == plain.trajectory.q);
    CHECK_NEAR(watched.dense.f[1], -std::sin(watched.dense.q[1]), 0.0);
  }

  // A touch inside one step: g = q - q_max + tiny dips below zero between two step ends.
  {
    static double level;
    level = theta0 - 1e-9;  // the turning point is at q = theta0 (energy conserved to the method's error)
    EventSet events;
    events.fn.fn = [](double* out, const double* in, void*) {
      out[0] = in[0] - level;
      out[1] = in[1];
    };
    events.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}};
    events.events.push_back({0, false, "near top"});
    RunSpec spec{0.05, 200, 0.05, 1};
    State<1> start{Vector<1>(0.0), Vector<1>(2.0 * std::sin(theta0 / 2.0))};  // energy of the release at theta0
    spec.events = &events;
    RunResult r = integrate<StormerVerlet>(pendulum, tab, yoshida, start, spec);
    long rows_above = 0;
    for (double q : r.trajectory.q) rows_above += q > level;
    std::printf("touch: %ld crossings, %ld rows above the level\n", r.events.size(), rows_above);
    CHECK(r.events.size() >= 2);  // found though no step end need lie above the level
    for (long i = 0; i + 1 < r.events.size(); i += 2) CHECK(r.events.direction[i] == 1 && r.events.direction[i + 1] == -1);
  }

  // An affine g evaluated from its coefficients (no compiled call; bounded inside a step) finds the same
  // crossings as the compiled call, bit for bit for a unit coefficient; and Henon's step lands each crossing
  // of the section q = 0 on it, at the flow's crossing from a stepped state: closer to the exact times
  // (2k + 1) K than the interpolant's at a coarse step of an order-6 composition.
  {
    const Composition& sixth = builtin_composition("kahan_li6");  // stepped states of order 6, the interpolant 4
    const EventSet compiled = angle_events(0, false);
    EventSet affine = angle_events(0, false), henon = angle_events(0, false);
    for (EventSet* set : {&affine, &henon}) {
      set->events[0].affine = true;
      set->events[0].terms = {{EventSlot::Kind::q, 0, 1.0}};
    }
    henon.events[0].henon = true;
    RunSpec spec{0.1, 200, 0.1, 1};
    spec.merge_steps = false;
    spec.events = &compiled;
    const RunResult a = integrate<StormerVerlet>(pendulum, tab, sixth, z0, spec);
    spec.events = &affine;
    const RunResult b = integrate<StormerVerlet>(pendulum, tab, sixth, z0, spec);
    spec.events = &henon;
    const RunResult c = integrate<StormerVerlet>(pendulum, tab, sixth, z0, spec);
    CHECK(a.events.size() == 6 && b.events.size() == 6 && c.events.size() == 6);
    double interpolated = 0.0, landed = 0.0;
    for (long i = 0; i < a.events.size(); ++i) {
      CHECK(a.events.t[i] == b.events.t[i] && a.events.q[i] == b.events.q[i] && a.events.p[i] == b.events.p[i]);
      CHECK(std::abs(c.events.q[i]) <= 1e-15);
      CHECK(c.events.direction[i] == a.events.direction[i]);
      interpolated = std::max(interpolated, std::abs(a.events.t[i] - (2 * i + 1) * quarter));
      landed = std::max(landed, std::abs(c.events.t[i] - (2 * i + 1) * quarter));
    }
    std::printf("crossing time errors at h = 0.1: interpolant %.3g, Henon %.3g\n", interpolated, landed);
    CHECK(landed < interpolated);
    CHECK(c.trajectory.q == a.trajectory.q);  // refining reads the steps, never changes them
  }

  // Levels of q and p (affine events grouped by form: a step is ruled out once per form) find what the
  // compiled call of the same g at every step end finds, bit for bit (q - c is -c + 1 q): levels exactly at
  // step-end values (g = 0 at a step's end), one twice, two one rounding apart, one just past the lowest
  // step end of a swing (a touch inside a step), levels never reached, and both directions.
  {
    static std::vector<double> levels;
    static int q_levels;
    const DampedPendulum damped(0.05);
    RunSpec spec{0.02, 2000, 0.02, 100};
    spec.merge_steps = false;
    spec.dense = true;
    const RunResult plain = integrate<ThreeTermSplitting>(damped, tab, builtin_composition("none"),
                                                          State<1>{Vector<1>(2.0), Vector<1>(0.0)}, spec);
    const std::vector<double>& q = plain.dense.q;
    const std::vector<double>& p = plain.dense.p;
    const long bottom = std::min_element(q.begin() + 150, q.begin() + 280) - q.begin();
    levels = {q[7], q[150], q[1001], 0.5, 0.5, std::nextafter(0.5, 1.0), q[bottom] - 1e-9, 3.0, -1.3};
    q_levels = static_cast<int>(levels.size());
    for (double c : {p[33], p[640], 0.25, -0.7, 5.0}) levels.push_back(c);
    EventSet compiled, affine;
    compiled.fn.fn = [](double* out, const double* in, void*) {
      for (std::size_t e = 0; e < levels.size(); ++e) {
        const bool on_q = static_cast<int>(e) < q_levels;
        out[2 * e] = (on_q ? in[0] : in[2]) - levels[e];
        out[2 * e + 1] = on_q ? in[1] : in[3];
      }
    };
    compiled.slots = {{EventSlot::Kind::q, 0}, {EventSlot::Kind::v, 0}, {EventSlot::Kind::p, 0},
                      {EventSlot::Kind::f, 0}};
    affine.fn = compiled.fn;
    affine.slots = compiled.slots;
    for (std::size_t e = 0; e < levels.size(); ++e) {
      const bool on_q = static_cast<int>(e) < q_levels;
      EventFunction f(static_cast<int>(e % 3) - 1, false, "level" + std::to_string(e));
      compiled.events.push_back(f);
      f.affine = true;
      f.constant = -levels[e];
      f.terms = {{on_q ? EventSlot::Kind::q : EventSlot::Kind::p, 0, 1.0}};
      affine.events.push_back(f);
    }
    spec.dense = false;
    spec.events = &compiled;
    const RunResult a = integrate<ThreeTermSplitting>(damped, tab, builtin_composition("none"),
                                                      State<1>{Vector<1>(2.0), Vector<1>(0.0)}, spec);
    spec.events = &affine;
    const RunResult b = integrate<ThreeTermSplitting>(damped, tab, builtin_composition("none"),
                                                      State<1>{Vector<1>(2.0), Vector<1>(0.0)}, spec);
    std::printf("levels: %ld crossings by the compiled call, %ld by the grouped forms\n", a.events.size(),
                b.events.size());
    CHECK(a.events.size() > 40);
    CHECK(a.events.t == b.events.t && a.events.q == b.events.q && a.events.p == b.events.p);
    CHECK(a.events.event == b.events.event && a.events.direction == b.events.direction);
    bool at_step_end = false;  // a level on a step end is found there
    for (long i = 0; i < b.events.size(); ++i) at_step_end = at_step_end || (b.events.event[i] == 1 && b.events.t[i] == plain.dense.t[150]);
    CHECK(at_step_end);
  }

  // Refusals, each naming the argument.
  {
    EventSet events = angle_events(2, false);
    RunSpec spec{0.1, 10, 0.1, 1};
    spec.events = &events;
    CHECK(test::throws([&] { integrate<StormerVerlet>(pendulum, tab, z0, spec); }));
    events.events[0].direction = 0;
    events.slots[0].index = 3;
    CHECK(test::throws([&] { integrate<StormerVerlet>(pendulum, tab, z0, spec); }));
  }
  return test::failures == 0 ? 0 : 1;
}
