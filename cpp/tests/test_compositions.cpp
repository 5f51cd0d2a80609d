// Compositions as data and first-same-as-last merging: validated tables, the
// one-stage composition is its base, merged steps equal unmerged ones to rounding.
#include <cmath>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

template <class Model, int Dim = Model::dim>
RunResult run(const Model& model, const std::string& method, const std::string& tableau,
              const std::string& composition, const State<Dim>& z, RunSpec spec) {
  const MethodEntry& entry = method_entry(method);
  const ButcherTableau& tab = resolve_tableau(entry, tableau);
  const Composition& comp = resolve_composition(entry, tab, composition);
  return with_method(method, [&](auto m) { return integrate<decltype(m)>(model, tab, comp, z, spec); });
}

// max |a - b| / max(1, |b|) over every saved q and p.
double max_difference(const Trajectory& a, const Trajectory& b) {
  double d = 0.0;
  if (a.q.size() != b.q.size()) return INFINITY;
  for (std::size_t i = 0; i < a.q.size(); ++i) {
    d = std::max(d, std::abs(a.q[i] - b.q[i]) / std::max(1.0, std::abs(b.q[i])));
    d = std::max(d, std::abs(a.p[i] - b.p[i]) / std::max(1.0, std::abs(b.p[i])));
  }
  return d;
}

using raydamp::test::throws;

int main() {
  const State<1> pend0{Vector<1>(0.9 * M_PI), Vector<1>(0.0)};
  const State<3> elas0{Vector<3>(0.0, 1.55884573, -0.6), Vector<3>(1.34164079, 0.0, 0.0)};

  // The tables: derived middle coefficients agree with the printed ones, every
  // table sums to 1, and each order > 2 has a backward stage.
  {
    CHECK_NEAR(builtin_composition("yoshida4").gamma(1), -std::cbrt(2.0) / (2.0 - std::cbrt(2.0)), 1e-15);
    CHECK_NEAR(builtin_composition("kahan_li6").gamma(4), 0.79854399093482996339895035, 1e-15);
    CHECK_NEAR(builtin_composition("mclachlan8").gamma(7), -0.79688793935291635401978884, 1e-15);
    CHECK_NEAR(builtin_composition("kahan_li8").gamma(8), -0.60550853383003451169892108, 1e-15);
    CHECK(builtin_composition("suzuki4").stages() == 5 && builtin_composition("kahan_li6").stages() == 9 &&
          builtin_composition("mclachlan8").stages() == 15 && builtin_composition("kahan_li8").stages() == 17);
    for (const Composition& c : builtin_compositions()) {
      double sum = 0.0;
      for (double g : c.gammas()) sum += g;
      CHECK_NEAR(sum, 1.0, 1e-15);
      CHECK((c.order() > 2) == (c.min_gamma() < 0.0));
    }
    // A mistyped digit breaks an odd-power condition and is refused.
    CHECK(throws([] { Composition("typo", 4, {1.35120719195966}, "test"); }));
    CHECK(!throws([] { Composition("exact", 4, {1.0L / (2.0L - std::cbrt(2.0L))}, "test"); }));
    CHECK(throws([] { builtin_composition("yoshida6"); }));
  }

  // The near-integrable tables, computed from the Legendre polynomials, against Laskar & Robutel's closed
  // forms; a table whose kicks do not integrate tau^k exactly for k < its eps-order is refused, and so is a
  // base that is not a drift, kick, drift.
  {
    const Composition& saba2 = builtin_composition("saba2");
    CHECK(saba2.is_table() && saba2.order() == 2 && saba2.eps_order() == 4 && saba2.stages() == 2);
    CHECK_NEAR(saba2.ends()[0], 0.5 - std::sqrt(3.0) / 6.0, 1e-16);
    CHECK_NEAR(saba2.ends()[1], std::sqrt(3.0) / 3.0, 1e-16);
    CHECK_NEAR(builtin_composition("saba3").gamma(0), 5.0 / 18.0, 1e-16);
    CHECK_NEAR(builtin_composition("saba3").ends()[0], 0.5 - std::sqrt(15.0) / 10.0, 1e-16);
    CHECK_NEAR(builtin_composition("saba4").gamma(0), 0.25 - std::sqrt(30.0) / 72.0, 1e-16);
    const Composition& sbab3 = builtin_composition("sbab3");
    CHECK(sbab3.ends()[0] == 0.0 && sbab3.ends()[4] == 0.0 && sbab3.stages() == 4);
    CHECK_NEAR(sbab3.ends()[1], 0.5 - std::sqrt(5.0) / 10.0, 1e-16);
    CHECK_NEAR(sbab3.gamma(0), 1.0 / 12.0, 1e-16);
    CHECK_NEAR(builtin_composition("sbab4").gamma(1), 49.0 / 180.0, 1e-16);
    CHECK(!builtin_composition("yoshida4").is_table());
    CHECK(throws([] { Composition("saba2 as order 6", 6, near_integrable::saba(2), "test"); }));
    near_integrable::Table typo = near_integrable::saba(3);
    typo.middles[0] = typo.middles[2] = 0.27777777777777L;  // 5/18 to 14 digits
    typo.middles[1] = 1.0L - 2.0L * typo.middles[0];
    CHECK(throws([&] { Composition("typo", 6, typo, "test"); }));
    for (const char* m : {"3s", "baoab", "midpoint"}) {
      const MethodEntry& e = method_entry(m);
      CHECK(throws([&] { resolve_composition(e, resolve_tableau(e, ""), "saba2"); }));
    }
    for (const char* m : {"sv", "2s"}) {
      const MethodEntry& e = method_entry(m);
      CHECK(!throws([&] { resolve_composition(e, resolve_tableau(e, ""), "sbab2"); }));
    }
  }

  // Only symmetric order-2 bases compose.
  {
    const MethodEntry& rks = method_entry("rks");
    CHECK(throws([&] { resolve_composition(rks, resolve_tableau(rks, "heun"), "yoshida4"); }));
    CHECK(!throws([&] { resolve_composition(rks, resolve_tableau(rks, "midpoint"), "yoshida4"); }));
    for (const char* m : {"rksb", "heun", "rk4"}) {
      const MethodEntry& e = method_entry(m);
      CHECK(throws([&] { resolve_composition(e, resolve_tableau(e, ""), "suzuki4"); }));
    }
    for (const char* m : {"sv", "3s", "2s"}) {
      const MethodEntry& e = method_entry(m);
      CHECK(!throws([&] { resolve_composition(e, resolve_tableau(e, ""), "kahan_li8"); }));
      CHECK(method_order(e, resolve_tableau(e, ""), builtin_composition("kahan_li8")) == 8);
    }
  }

  // Composing yoshida4 by hand: three whole 3s steps of gamma_i h equal one composed step.
  {
    ElasticPendulum elastic(0.3);
    const Composition& y4 = builtin_composition("yoshida4");
    const ButcherTableau& tab = builtin_tableau("euler");
    State<3> z = elas0;
    WorkspaceFor<ElasticPendulum> ws(3, 1);
    for (int i = 0; i < 3; ++i) step<ThreeTermSplitting>(elastic, tab, z, y4.gamma(i) * 0.1, ws);
    RunResult r = run(elastic, "3s", "", "yoshida4", elas0, RunSpec{0.1, 1, 0.1, 1});
    for (int i = 0; i < 3; ++i) {
      CHECK_NEAR(r.trajectory.q[3 + i], z.q[i], 1e-15);
      CHECK_NEAR(r.trajectory.p[3 + i], z.p[i], 1e-15);
    }
  }

  // A near-integrable table by hand: one saba2 step over 2s is drift a_0 h, kick+damp b_1 h, drift a_1 h,
  // kick+damp b_2 h, drift a_2 h.
  {
    ElasticPendulum elastic(0.3);
    const Composition& saba2 = builtin_composition("saba2");
    const ButcherTableau& tab = builtin_tableau("euler");
    State<3> z = elas0;
    WorkspaceFor<ElasticPendulum> ws(3, 1);
    for (int i = 0; i < 2; ++i) {
      apply_flow<Flow::drift>(elastic, tab, z, saba2.ends()[i] * 0.1, ws);
      apply_flow<Flow::kick_damp>(elastic, tab, z, saba2.gamma(i) * 0.1, ws);
    }
    apply_flow<Flow::drift>(elastic, tab, z, saba2.ends()[2] * 0.1, ws);
    RunResult r = run(elastic, "2s", "", "saba2", elas0, RunSpec{0.1, 1, 0.1, 1});
    for (int i = 0; i < 3; ++i) {
      CHECK_NEAR(r.trajectory.q[3 + i], z.q[i], 1e-15);
      CHECK_NEAR(r.trajectory.p[3 + i], z.p[i], 1e-15);
    }
  }

  // Merged (the default) against whole steps, for every mergeable method, plain and
  // composed, on both paper models, with a short last step, saving every 7 steps
  // (blocks of all lengths).
  {
    DampedPendulum pendulum(0.4);
    ElasticPendulum elastic(0.4);
    struct Case { const char* method; const char* tableau; const char* composition; };
    const std::vector<Case> cases{{"3s", "", ""},         {"2s", "", ""},         {"rks", "heun", ""},
                                  {"rks", "midpoint", ""}, {"rksb", "heun", ""},   {"3s", "", "yoshida4"},
                                  {"2s", "", "kahan_li8"}, {"rks", "midpoint", "suzuki4"}, {"2s", "", "saba3"},
                                  {"2s", "", "sbab2"}, {"rks", "midpoint", "saba2"}};
    for (const Case& c : cases) {
      RunSpec merged{0.05, 1000, 0.03, 7};
      RunSpec whole = merged;
      whole.merge_steps = false;
      const double dp = max_difference(run(pendulum, c.method, c.tableau, c.composition, pend0, merged).trajectory,
                                       run(pendulum, c.method, c.tableau, c.composition, pend0, whole).trajectory);
      const double de = max_difference(run(elastic, c.method, c.tableau, c.composition, elas0, merged).trajectory,
                                       run(elastic, c.method, c.tableau, c.composition, elas0, whole).trajectory);
      std::printf("merged vs whole %-5s %-9s %-10s pendulum %.2g elastic %.2g\n", c.method, c.tableau,
                  c.composition, dp, de);
      CHECK(dp <= 1e-12);
      CHECK(de <= 1e-12);
    }
    // sv at eps = 0 too (its ends are drifts).
    DampedPendulum undamped(0.0);
    RunSpec merged{0.05, 1000, 0.05, 1000}, whole = merged;
    whole.merge_steps = false;
    CHECK(max_difference(run(undamped, "sv", "", "mclachlan8", pend0, merged).trajectory,
                         run(undamped, "sv", "", "mclachlan8", pend0, whole).trajectory) <= 1e-12);
    // And they are not trivially equal: merging changes rounding, not nothing.
    const Trajectory a = run(elastic, "3s", "", "", elas0, RunSpec{0.05, 1000, 0.05, 1000}).trajectory;
    RunSpec w{0.05, 1000, 0.05, 1000};
    w.merge_steps = false;
    const Trajectory b = run(elastic, "3s", "", "", elas0, w).trajectory;
    std::printf("3s elastic, merged vs whole after 1000 steps: %.3g\n", max_difference(a, b));
  }

  // Compositions of the momentum-conserving bases conserve J3 to rounding (paper section 5).
  {
    ElasticPendulum elastic(0.1);
    const double j0 = elas0.q[0] * elas0.p[1] - elas0.q[1] * elas0.p[0];
    for (auto [method, tableau] : std::vector<std::pair<std::string, std::string>>{
             {"3s", ""}, {"2s", ""}, {"rks", "midpoint"}}) {
      for (const char* comp : {"yoshida4", "kahan_li8"}) {
        RunResult r = run(elastic, method, tableau, comp, elas0, RunSpec{0.1, 20000, 0.1, 20000});
        CHECK(r.status == Status::completed);
        CHECK(r.max_momentum_drift < 1e-12 * std::max(1.0, std::abs(j0)));
      }
    }
  }
  // The amplification guard. Damped pendulum with eps = 50 (rho = 50), h = 0.1:
  // yoshida4 over 2s runs kick+damp for -1.70 h, e^{8.5} ~ 4900: refused; over 3s
  // the backward damp is only the merged (gamma_1 + gamma_2)/2 h = -0.176 h,
  // e^{0.88} ~ 2.4: accepted; order 2 has no backward sub-step: accepted.
  {
    DampedPendulum stiff(50.0);
    CHECK_NEAR(damping_spectral_radius(stiff, pend0.q), 50.0, 1e-12);
    ElasticPendulum elastic(0.7);  // rho = eps / m along the spring
    CHECK_NEAR(damping_spectral_radius(elastic, elas0.q), 0.7, 1e-12);
    const RunSpec spec{0.1, 10, 0.1, 1};
    std::string message;
    try {
      run(stiff, "2s", "", "yoshida4", pend0, spec);
    } catch (const std::invalid_argument& e) {
      message = e.what();
    }
    std::printf("refused: %s\n", message.c_str());
    CHECK(message.rfind("composition: 'yoshida4'", 0) == 0);
    CHECK(message.find("h = 0.1") != std::string::npos && message.find("4.97e+03") != std::string::npos);
    CHECK(!throws([&] { run(stiff, "3s", "", "yoshida4", pend0, spec); }));
    CHECK(!throws([&] { run(stiff, "2s", "", "", pend0, spec); }));
    // The h the message suggests passes, and a little more does not.
    const Composition& y4 = builtin_composition("yoshida4");
    const double h_max = std::log(kMaxAmplification) / (50.0 * -y4.gamma(1));
    CHECK_NEAR(amplification_bound<TwoTermSplitting>(y4, builtin_tableau("euler"), h_max, 50.0), 10.0, 1e-9);
    // Rounded down, not to nearest (0.0271 was printed, and refused): the printed h itself passes.
    const double suggested = std::strtod(message.substr(message.rfind("h <= ") + 5).c_str(), nullptr);
    CHECK(message.find("h <= 0.0270508") != std::string::npos);
    CHECK(suggested <= h_max && suggested >= h_max * (1 - 1e-5));
    CHECK(!throws([&] { run(stiff, "2s", "", "yoshida4", pend0, RunSpec{suggested, 10, suggested, 1}); }));
    CHECK_NEAR(h_max, 0.0271, 5e-5);
    CHECK(!throws([&] { run(stiff, "2s", "", "yoshida4", pend0, RunSpec{0.999 * h_max, 10, 0.999 * h_max, 1}); }));
    CHECK(throws([&] { run(stiff, "2s", "", "yoshida4", pend0, RunSpec{1.001 * h_max, 10, 1.001 * h_max, 1}); }));
    // Implicit midpoint backward: R(z) = (1 + z/2) / (1 - z/2) > e^z, a pole at z = 2.
    const ButcherTableau& mid = builtin_tableau("midpoint");
    CHECK_NEAR(stability_magnitude(mid, 1.0), 3.0, 1e-15);
    CHECK(std::isinf(stability_magnitude(mid, 2.0)));
    CHECK_NEAR(stability_magnitude(builtin_tableau("rk4"), 1.0), 1 + 1 + 0.5 + 1.0 / 6 + 1.0 / 24, 1e-15);
  }
  TEST_MAIN_RETURN();
}
