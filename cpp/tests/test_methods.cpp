// Structural and order tests of every method table.
#include <cmath>
#include <string>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

template <class Model, int Dim = Model::dim>
State<Dim> run(const Model& model, const std::string& method, const std::string& tableau, State<Dim> z, double h,
               long n) {
  const ButcherTableau tab = resolve_tableau(method_entry(method), tableau);
  RunSpec spec{h, n, h, n};
  // Whole steps: the structural checks below compare step maps operation by
  // operation; merging the ends of steps (the default) changes only rounding, and
  // test_compositions checks it.
  spec.merge_steps = false;
  return with_method(method, [&](auto m) {
    RunResult r = integrate<decltype(m)>(model, tab, z, spec);
    const long last = r.trajectory.rows() - 1;
    State<Dim> out = z;
    for (int i = 0; i < model.size(); ++i) {
      out.q[i] = r.trajectory.q[last * model.size() + i];
      out.p[i] = r.trajectory.p[last * model.size() + i];
    }
    return out;
  });
}

template <int Dim>
double distance(const State<Dim>& a, const State<Dim>& b) {
  return std::max((a.q - b.q).cwiseAbs().maxCoeff(), (a.p - b.p).cwiseAbs().maxCoeff());
}

// Fitted slope of log(error) against log(h) at t = 10 over h = 0.1 ... 0.0125.
template <class Model, int Dim = Model::dim>
double fitted_order(const Model& model, const std::string& method, const std::string& tableau, State<Dim> z0) {
  const State<Dim> ref = run(model, "rk4", "", z0, 0.1 / 256, 25600);
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const int k = 4;
  for (int i = 0; i < k; ++i) {
    const double h = 0.1 / (1 << i);
    const double x = std::log(h), y = std::log(distance(run(model, method, tableau, z0, h, std::lround(10 / h)), ref));
    sx += x; sy += y; sxx += x * x; sxy += x * y;
  }
  return (k * sxy - sx * sy) / (k * sxx - sx * sx);
}

int main() {
  const State<1> pend0{Vector<1>(0.9 * M_PI), Vector<1>(0.0)};
  const State<3> elas0{Vector<3>(0.0, 1.55884573, -0.6), Vector<3>(1.34164079, 0.0, 0.0)};

  // eps = 0: every splitting method is Stormer-Verlet.
  {
    DampedPendulum pendulum(0.0);
    ElasticPendulum elastic(0.0);
    const State<1> sv1 = run(pendulum, "sv", "", pend0, 0.1, 1000);
    const State<3> sv3 = run(elastic, "sv", "", elas0, 0.1, 1000);
    for (auto [method, tableau] : std::vector<std::pair<std::string, std::string>>{
             {"3s", ""}, {"2s", ""}, {"rks", "heun"}, {"rks", "rk4"}, {"rks", "midpoint"}, {"rks", "euler"}}) {
      CHECK_NEAR(distance(run(pendulum, method, tableau, pend0, 0.1, 1000), sv1), 0.0, 1e-13);
      CHECK_NEAR(distance(run(elastic, method, tableau, elas0, 0.1, 1000), sv3), 0.0, 1e-13);
    }
    // 3s runs as sv's table at eps = 0 (its damping flows are identities): bit for bit.
    CHECK(distance(run(pendulum, "3s", "", pend0, 0.1, 1000), sv1) == 0.0);
    CHECK(distance(run(elastic, "3s", "", elas0, 0.1, 1000), sv3) == 0.0);
  }

  // rksb at eps = 0 is the kick-drift-kick (A-) form of Stormer-Verlet, conjugate
  // to sv rather than equal: check it against that form by hand.
  {
    DampedPendulum pendulum(0.0);
    State<1> z = pend0;
    Workspace<1> ws(1, 1);
    for (int i = 0; i < 1000; ++i) {
      flows::kick(pendulum, z, 0.05, ws);
      flows::drift(pendulum, z, 0.1, ws);
      flows::kick(pendulum, z, 0.05, ws);
    }
    CHECK_NEAR(distance(run(pendulum, "rksb", "heun", pend0, 0.1, 1000), z), 0.0, 1e-13);
  }

  // Orders at eps = 0.5 (sv ignores damping, so it is checked at eps = 0).
  struct Case { const char* method; const char* tableau; double order; };
  const std::vector<Case> cases{{"3s", "", 2}, {"2s", "", 2}, {"rks", "heun", 2}, {"rks", "rk4", 2},
                                {"rks", "midpoint", 2}, {"rks", "euler", 1}, {"rksb", "heun", 2},
                                {"heun", "", 2}, {"rk4", "", 4}};
  for (const auto& c : cases) {
    const double p1 = fitted_order(DampedPendulum(0.5), c.method, c.tableau, pend0);
    const double p3 = fitted_order(ElasticPendulum(0.5), c.method, c.tableau, elas0);
    std::printf("%-5s %-9s pendulum %.3f elastic %.3f\n", c.method, c.tableau, p1, p3);
    CHECK_NEAR(p1, c.order, 0.1);
    CHECK_NEAR(p3, c.order, 0.1);
  }
  CHECK_NEAR(fitted_order(DampedPendulum(0.0), "sv", "", pend0), 2.0, 0.1);
  CHECK_NEAR(fitted_order(ElasticPendulum(0.0), "sv", "", elas0), 2.0, 0.1);

  // Momentum map J3 (paper section 5): 3s, 2s, rks conserve it; rksb and heun do not.
  {
    ElasticPendulum elastic(0.1);
    const double j0 = elas0.q[0] * elas0.p[1] - elas0.q[1] * elas0.p[0];
    for (auto [method, conserves] : std::vector<std::pair<std::string, bool>>{
             {"3s", true}, {"2s", true}, {"rks", true}, {"rksb", false}, {"heun", false}}) {
      const ButcherTableau tab = resolve_tableau(method_entry(method), "");
      RunResult r = with_method(method, [&](auto m) {
        return integrate<decltype(m)>(elastic, tab, elas0, RunSpec{0.1, 100000, 0.1, 100000});
      });
      std::printf("%-5s max |J3 - J3(0)| = %.3g\n", method.c_str(), r.max_momentum_drift);
      if (conserves) CHECK(r.max_momentum_drift < 1e-12 * std::max(1.0, std::abs(j0)));
      else CHECK(r.max_momentum_drift > 1e-6);
    }
  }
  TEST_MAIN_RETURN();
}
