// Events and dense output (events/watcher.hpp): crossing times against a closed form, a terminal
// event's shortened last step, and the stepped trajectory unchanged by watching it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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

// Whether two runs found the same events, bit for bit, and stepped the same rows.
bool same_runs(const RunResult& a, const RunResult& b) {
  return a.events.t == b.events.t && a.events.q == b.events.q && a.events.p == b.events.p &&
         a.events.event == b.events.event && a.events.direction == b.events.direction &&
         a.trajectory.t == b.trajectory.t && a.trajectory.q == b.trajectory.q && a.trajectory.p == b.trajectory.p &&
         a.trajectory.work == b.trajectory.work && a.steps == b.steps && a.status == b.status;
}

// Affine events of q[index] - level and of t - clock, direction 0 unless given.
EventSet levels_of(int index, const std::vector<double>& levels, const std::vector<double>& clocks,
                   bool terminal = false, int direction = 0) {
  EventSet set;
  set.fn.fn = &angle;  // never called: every g is affine
  set.slots = {{EventSlot::Kind::q, index}, {EventSlot::Kind::v, index}};
  for (std::size_t k = 0; k < levels.size(); ++k) {
    EventFunction f(direction, terminal, "level" + std::to_string(k));
    f.affine = true;
    f.constant = -levels[k];
    f.terms = {{EventSlot::Kind::q, index, 1.0}};
    set.events.push_back(f);
  }
  for (const double clock : clocks) {
    EventFunction f(0, terminal, "clock");
    f.affine = true;
    f.constant = -clock;
    f.terms = {{EventSlot::Kind::t, 0, 1.0}};
    set.events.push_back(f);
  }
  return set;
}

// The batched screen's kernel (events/block_sums.hpp) against inside()'s test written out, end by end:
// levels hit exactly, a rounding either side, rates of +0 and -0, NaN and infinity, a group of two terms
// and one of t; from every start, on both widths where the processor has AVX2.
struct KernelInput {
  int which, index;
  double coefficient;
};
long first_loud_by_hand(const std::vector<block_sums::Group<KernelInput>>& groups, const double* rows, const double* t,
                        long j, long m) {
  for (; j < m; ++j)
    for (const auto& g : groups) {
      double L = 0.0, S = 0.0, R = 0.0;
      for (const KernelInput* in = g.first; in != g.last; ++in) {
        const double c = in->coefficient;
        const double term = in->which == 0 ? c * rows[4 * j + in->index] : c * t[j];
        R += in->which == 0 ? c * rows[4 * j + 2 + in->index] : c;  // rows of q0 q1 p0 p1, M = 1
        L += term;
        S += std::abs(term);
      }
      const double margin = g.slack * S;
      if (!(L - g.lo > g.lo_slack + margin && g.hi - L > g.hi_slack + margin && std::signbit(R) == g.falling))
        return j;
    }
  return m;
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
    for (long i = 0; i < std::min({a.events.size(), b.events.size(), c.events.size()}); ++i) {
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

  // Screens batched a block at a time (fixed-size models: events/watcher.hpp, batch_screens) find what the
  // loop's screen of every step finds, bit for bit: ten levels of a damped pendulum's angle and a clock, over
  // blocks of steps with a short last step; a pendulum on a spring (three coordinates read at a stride, a
  // scalar mass); terminal events mid-block, on a step's end (the clock at a step end: the recorder's work
  // sums of that end, not of the block's), and at the first step of a block.
  {
    const DampedPendulum damped(0.1);
    const Composition& none = builtin_composition("none");
    const State<1> start{Vector<1>(2.0), Vector<1>(0.0)};
    std::vector<double> ten;
    for (int k = 0; k < 10; ++k) ten.push_back(0.1 * k - 0.3);
    Control control;
    control.max_progress_calls = 1;  // blocks of kBlock steps between saved rows (not a hundredth of the run)
    auto both = [&](const auto& model, const auto& z, const EventSet& set, RunSpec spec) {
      spec.events = &set;
      spec.track_work = true;
      spec.merge_steps = false;
      const RunResult batched = integrate<ThreeTermSplitting>(model, tab, none, z, spec, control);
      spec.batch_screens = false;
      const RunResult looped = integrate<ThreeTermSplitting>(model, tab, none, z, spec, control);
      CHECK(same_runs(batched, looped));
      return batched;
    };
    // a level at a step end's value (g = 0 there), and one just past the lowest step end of a swing (a touch
    // inside the step: its rate turns there, and the interpolant dips through the level between the ends)
    RunSpec dense_spec{0.01, 3000, 0.015, 3000};
    dense_spec.merge_steps = false;
    dense_spec.dense = true;
    const RunResult path = integrate<ThreeTermSplitting>(damped, tab, none, start, dense_spec);
    const long bottom = std::min_element(path.dense.q.begin() + 150, path.dense.q.begin() + 450) - path.dense.q.begin();
    ten.push_back(path.dense.q[700]);
    ten.push_back(path.dense.q[bottom] - 1e-9);
    // (a last step longer than h: the clock at 30.002 lies past 3000 h, inside it)
    const EventSet levels = levels_of(0, ten, {7.005, 30.002});
    const RunResult r = both(damped, start, levels, RunSpec{0.01, 3000, 0.015, 1000});
    std::printf("batched screens: %ld crossings of ten levels and two clocks\n", r.events.size());
    CHECK(r.events.size() > 60);
    CHECK(std::count(r.events.event.begin(), r.events.event.end(), 12) == 1);  // each clock, once
    CHECK(std::count(r.events.event.begin(), r.events.event.end(), 13) == 1);
    CHECK(std::count(r.events.t.begin(), r.events.t.end(), path.dense.t[700]) == 1);  // on the step end
    long touched = 0;  // the touch: two crossings inside the bottom's step
    for (long i = 0; i < r.events.size(); ++i)
      touched += r.events.event[i] == 11 && r.events.t[i] > path.dense.t[bottom - 1] &&
                 r.events.t[i] < path.dense.t[bottom + 1];
    CHECK(touched == 2);

    const ElasticPendulum spring(0.2);
    const State<3> hung{Vector<3>(0.3, -0.2, -1.1), Vector<3>(0.0, 0.4, 0.0)};
    const RunResult s = both(spring, hung, levels_of(1, {-0.1, 0.0, 0.15}, {}), RunSpec{0.01, 2000, 0.01, 500});
    CHECK(s.events.size() > 10);
    // a level just inside the interpolant's turn at a block's first step (a block a step: save_every = 1),
    // crossed twice inside it: that step's start rate is the block start's M^-1 p (a scalar mass here; the
    // review found it read as 0, which ruled the turn out and lost both crossings)
    const State<3> swung{Vector<3>(0.3, -0.2, -1.1), Vector<3>(0.0, 0.8, 0.0)};
    const RunResult turn = both(spring, swung, levels_of(2, {-2.3523289745457943}, {}), RunSpec{0.25, 100, 0.25, 1});
    CHECK(turn.events.size() == 4);

    // terminal: the first fall through 0.2, mid-block; the clock on a step's end (3.0 = 300 h); the clock
    // inside the first step of the second block (step 256 ends at 2.57)
    const RunResult mid = both(damped, start, levels_of(0, {0.2}, {}, true, -1), RunSpec{0.01, 3000, 0.01, 3000});
    CHECK(mid.status == Status::event && mid.steps % kBlock != 0);
    const RunResult on_end = both(damped, start, levels_of(0, {}, {3.0}, true), RunSpec{0.01, 3000, 0.01, 3000});
    CHECK(on_end.status == Status::event && on_end.steps == 300 && on_end.trajectory.t.back() == 3.0);
    const RunResult first = both(damped, start, levels_of(0, {}, {2.565}, true), RunSpec{0.01, 3000, 0.01, 3000});
    CHECK(first.status == Status::event && first.steps == kBlock + 1);
    std::printf("terminal, batched as looped: steps %ld, %ld, %ld\n", mid.steps, on_end.steps, first.steps);
  }

  // The batched screen's kernel, end by end (first_loud_by_hand).
  {
    const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
    const double lo = 0.25, hi = 0.75;
    const std::vector<double> q0 = {0.5, lo, std::nextafter(lo, 1.0), hi, std::nextafter(hi, 0.0), 0.5, 0.5, nan, 0.6,
                                    inf, 0.4, 0.5, 0.3, std::nextafter(lo, 0.0), 0.7, 0.5, 0.5, 0.53};
    const std::vector<double> v0 = {1.0, 1.0, 1.0, 1.0, 1.0,    0.0, -0.0, 1.0, nan,
                                    1.0, -2.0, 1e-300, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0};
    const long m = static_cast<long>(q0.size());
    std::vector<double> rows(4 * (m + 4), 0.0), t(m + 4, 0.0);
    for (long j = 0; j < m; ++j) {
      rows[4 * j] = q0[j], rows[4 * j + 1] = 0.1 * static_cast<double>(j % 3);  // q1
      rows[4 * j + 2] = v0[j], rows[4 * j + 3] = 0.5;                           // p1 = v1
      t[j] = 0.01 * static_cast<double>(j);
    }
    const KernelInput one[] = {{0, 0, 1.0}}, two[] = {{0, 0, 1.0}, {0, 1, -1.0}}, clock[] = {{2, 0, -1.0}};
    const block_sums::Rows at{rows.data(), rows.data() + 2, t.data()};
    int compared = 0;
    for (const double slack : {0.0, 1e-15, 0.1})  // (0.1: end 17's two terms, 0.53 - 0.2, inside by S only)
      for (const bool falling : {false, true})
        for (int shape = 0; shape < 3; ++shape) {
          std::vector<block_sums::Group<KernelInput>> groups = {
              {one, one + 1, lo, hi, slack * lo, slack * hi, slack, falling}};
          if (shape == 1) groups[0].first = two, groups[0].last = two + 2;
          if (shape == 2) groups.push_back({clock, clock + 1, -1.0, 0.1, slack, slack * 0.1, slack, true});
          for (long j = 0; j < m; ++j) {
            const long want = first_loud_by_hand(groups, rows.data(), t.data(), j, m);
            long got = m;
            for (const auto& g : groups) got = block_sums::first_loud2<4, 4>(g, at, j, got);
            CHECK(got == want);
            const long dispatched = block_sums::first_loud<4, 4>(groups.data(), groups.size(), at, j, m);
            CHECK(dispatched == want);
#if defined(__x86_64__) || defined(__i386__)
            if (has_avx2()) {
              long wide = m;
              for (const auto& g : groups) wide = block_sums::first_loud4<4, 4, false>(g, at, j, wide);
              CHECK(wide == want);
            }
#endif
            ++compared;
          }
        }
    std::printf("batched screen's kernel: %d starts judged as by hand\n", compared);
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
