// A load as data (raydamp/load.hpp): series located by one division or by bisection agree,
// zero or held outside the range, rows of n values; and the step loop's clock: the kick of
// Stormer-Verlet sees f at t_n + h/2 (the time the drift has reached), merged steps or not.
#include <cmath>
#include <memory>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

namespace {

LoadTerm series_term(std::vector<double> t, std::vector<double> v, double step, bool hold, int n) {
  auto s = std::make_shared<LoadSeries>();
  s->times = std::move(t);
  s->values = std::move(v);
  s->step = step;
  s->hold = hold;
  LoadTerm term;
  term.shape = LoadTerm::Shape::series;
  term.series = s;
  auto d = std::make_shared<LoadDirection>();
  for (int i = 0; i < n; ++i) {
    d->index.push_back(i);
    d->value.push_back(i + 1.0);
  }
  term.direction = d;
  return term;
}

double at(const Load& load, double t, int i = 0) {
  std::vector<double> f(load.size(), 0.0);
  load.add(t, 1.0, f.data());
  return f[i];
}

void check_series() {
  std::vector<double> t, v;
  for (int k = 0; k <= 100; ++k) {
    t.push_back(0.01 * k);
    v.push_back(std::sin(3.0 * k));
  }
  const Load uniform({series_term(t, v, 0.01, false, 2)}, 2), irregular({series_term(t, v, 0.0, false, 2)}, 2);
  for (double x = -0.05; x < 1.05; x += 0.00137) {
    CHECK_NEAR(at(uniform, x, 1), at(irregular, x, 1), 1e-15);
    if (x >= 0.0 && x <= 1.0) {
      const int k = std::min(99, static_cast<int>(x / 0.01));
      const double w = (x - t[k]) / 0.01;
      CHECK_NEAR(at(uniform, x), (1 - w) * v[k] + w * v[k + 1], 1e-13);
    } else {
      CHECK(at(uniform, x) == 0.0);
    }
  }
  const Load held({series_term({0.0, 1.0}, {2.0, 5.0}, 0.0, true, 1)}, 1);
  CHECK(at(held, -1.0) == 2.0 && at(held, 3.0) == 5.0);
  CHECK(test::throws([] { Load({series_term({0.0, 0.0}, {1.0, 1.0}, 0.0, false, 1)}, 1); }));
  CHECK(test::throws([] { Load({series_term({0.0, 0.5, 1.2}, {1.0, 1.0, 1.0}, 0.5, false, 1)}, 1); }));
  // rows of n values
  LoadTerm rows = series_term({0.0, 2.0}, {1.0, 2.0, 3.0, 5.0}, 0.0, false, 0);
  std::const_pointer_cast<LoadSeries>(rows.series)->width = 2;
  rows.direction.reset();
  const Load vector_load({rows}, 2);
  CHECK_NEAR(at(vector_load, 0.5, 0), 1.5, 1e-15);
  CHECK_NEAR(at(vector_load, 0.5, 1), 2.75, 1e-15);
  std::vector<double> velocity{1.0, -1.0};
  CHECK_NEAR(vector_load.dot(0.5, velocity.data()), 1.5 - 2.75, 1e-15);
}

// sv (drift h/2, kick h, drift h/2) under f(t) = a sin(w t): two steps by hand.
void check_clock(bool merge) {
  const DampedPendulum model(0.0);
  LoadTerm term;
  term.shape = LoadTerm::Shape::harmonic;
  term.omega = 2.0;
  term.phase = 0.3;
  auto d = std::make_shared<LoadDirection>();
  d->index = {0};
  d->value = {0.7};
  term.direction = d;
  const Load load({term}, 1);
  const double h = 0.1;
  RunSpec spec{h, 2, h, 1, false};
  spec.merge_steps = merge;
  spec.load = &load;
  State<1> z{Vector<1>(0.4), Vector<1>(-0.2)};
  const RunResult r = integrate<StormerVerlet>(model, builtin_tableau("heun"), z, spec);
  double q = 0.4, p = -0.2;
  for (int n = 0; n < 2; ++n) {
    const double mid = n * h + h / 2;
    q += h / 2 * p;
    p += -h * std::sin(q) + h * 0.7 * std::sin(2.0 * mid + 0.3);
    q += h / 2 * p;
    CHECK_NEAR(r.trajectory.q[n + 1], q, 1e-15);
    CHECK_NEAR(r.trajectory.p[n + 1], p, 1e-15);
  }
}

}  // namespace

int main() {
  check_series();
  check_clock(true);
  check_clock(false);
  if (test::failures) std::printf("%d check(s) failed\n", test::failures);
  return test::failures ? 1 : 0;
}
