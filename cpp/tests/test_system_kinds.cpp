// The compiled-system kinds with hand-written C functions in place of JIT code:
// - one dashpot on |q| with M = I is the elastic pendulum: every method's step equals
//   the built-in struct's to rounding;
// - dashpots on linear functions give a constant D, so their exact flows must equal
//   the constant-matrix kind's, and both must equal exp(-tA) where it is known in
//   closed form (diagonal A);
// - one dashpot's factors, carried from q to q in one workspace as a run carries
//   them, follow q: each flow equals its closed form at every new q;
// - a system with n fixed at compile time (CompiledSystem::fixed) runs the same
//   steps as the run-time-sized one, and fixed<N> refuses a system of another n;
// - with the dashpot's projection and a fused 3s body (damp, drift, kick, drift in one
//   function), merged 3s runs call it for nearly every step, and end
//   where the sub-flows one by one end, run-time and fixed size;
// - phi2 is continuous across its series/direct switch.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "check.hpp"
#include "elastic_functions.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;
using Vec = Eigen::VectorXd;

namespace {

using namespace raydamp::test::elastic;
// Two dashpots on x2 - x1 and x3 - x2: constant gradient rows.
void chain_gradients(double* out, const double*, void*) {
  const double rows[6] = {-1.0, 1.0, 0.0, 0.0, -1.0, 1.0};
  for (int i = 0; i < 6; ++i) out[i] = rows[i];
}

// A dashpot on g = (x^2 + y^2) / 2: grad g = (x, y), so |grad g| and x change with q.
void planar_gradient(double* out, const double* q, void*) {
  out[0] = q[0];
  out[1] = q[1];
}

CompiledFunction fn(CompiledFunction::Fn f) { return {f, nullptr}; }

// The elastic pendulum's damp_then_3s_body (M = I): in = (q, p, k, t0, t1, t2); data
// counts the calls.
void elastic_3s_body(double* out, const double* in, void* calls) {
  ++*static_cast<long*>(calls);
  double u[6], q[3], p[3], g[3];
  radial_projection(u, in, nullptr);
  const double k = in[6], t0 = in[7], t1 = in[8], t2 = in[9];
  for (int i = 0; i < 3; ++i) p[i] = in[3 + i] - k * u[i];
  for (int i = 0; i < 3; ++i) q[i] = in[i] + t0 * p[i];
  gradient(g, q, nullptr);
  for (int i = 0; i < 3; ++i) p[i] -= t1 * g[i];
  for (int i = 0; i < 3; ++i) out[i] = q[i] + t2 * p[i];
  for (int i = 0; i < 3; ++i) out[3 + i] = p[i];
}

double distance(const State<Eigen::Dynamic>& a, const State<3>& b) {
  double d = 0.0;
  for (int i = 0; i < 3; ++i) d = std::max({d, std::abs(a.q[i] - b.q[i]), std::abs(a.p[i] - b.p[i])});
  return d;
}

void elastic_pendulum_as_system() {
  const Eigen::MatrixXd mass = Eigen::MatrixXd::Identity(3, 3);
  const double eps = 0.1;
  using Sys = CompiledSystem<ScalarMass, DamperDamping>;
  const Sys sys(3, eps, ScalarMass(1.0), DamperDamping(mass, eps, {1.0}, fn(radial_gradient)),
                SystemFunctions{fn(potential), fn(gradient), fn(hessian_product), fn(j3), {}}, 1);
  const ElasticPendulum builtin(eps);
  const State<3> z0{Vector<3>(0.0, 1.55884573, -0.6), Vector<3>(1.34164079, 0.0, 0.0)};
  const State<Eigen::Dynamic> y0{Vec(z0.q), Vec(z0.p)};
  for (const char* name : {"3s", "2s", "rks", "rksb", "heun", "rk4"}) {
    const MethodEntry& entry = method_entry(name);
    const ButcherTableau& tab = resolve_tableau(entry, "");
    const RunSpec spec{0.1, 1000, 0.1, 1000, true};
    const RunResult a = with_method(name, [&](auto m) { return integrate<decltype(m)>(sys, tab, y0, spec); });
    const RunResult b = with_method(name, [&](auto m) { return integrate<decltype(m)>(builtin, tab, z0, spec); });
    const auto& ta = a.trajectory;
    const auto& tb = b.trajectory;
    double worst = 0.0;
    for (std::size_t i = 0; i < ta.q.size(); ++i)
      worst = std::max({worst, std::abs(ta.q[i] - tb.q[i]), std::abs(ta.p[i] - tb.p[i])});
    if (!(worst <= 1e-12)) std::printf("method %s: system and built-in differ by %.3g\n", name, worst);
    CHECK(worst <= 1e-12);
    CHECK_NEAR(ta.work.back(), tb.work.back(), 1e-12);
    CHECK(ta.n_momenta == 1);
    CHECK_NEAR(ta.momentum.back(), tb.momentum.back(), 1e-12);
  }
  // n fixed at compile time: the same trajectories to rounding (in practice the same
  // bits; Eigen may order a reduction differently for a fixed size), for the methods
  // the bindings run that way and a composition.
  const auto sys3 = sys.fixed<3>();
  for (const char* name : {"sv", "3s", "2s"}) {
    const ButcherTableau& tab = resolve_tableau(method_entry(name), "");
    for (const char* composition : {"none", "yoshida4"}) {
      const Composition& comp = builtin_composition(composition);
      const RunSpec spec{0.05, 2000, 0.03, 100, false};
      const Sys& s = sys;
      const auto dyn = with_method(name, [&](auto m) { return integrate<decltype(m)>(s, tab, comp, y0, spec); });
      const auto fix = with_method(name, [&](auto m) { return integrate<decltype(m)>(sys3, tab, comp, z0, spec); });
      CHECK(dyn.trajectory.rows() == fix.trajectory.rows());
      double worst = 0.0;
      for (std::size_t i = 0; i < dyn.trajectory.q.size() && i < fix.trajectory.q.size(); ++i)
        worst = std::max({worst, std::abs(dyn.trajectory.q[i] - fix.trajectory.q[i]),
                          std::abs(dyn.trajectory.p[i] - fix.trajectory.p[i])});
      if (!(worst <= 1e-13)) std::printf("fixed size, %s/%s: differs by %.3g\n", name, composition, worst);
      CHECK(worst <= 1e-13);
      CHECK_NEAR(dyn.trajectory.momentum.back(), fix.trajectory.momentum.back(), 1e-13);
    }
  }
  bool refused = false;
  try {
    (void)sys.fixed<2>();
  } catch (const std::invalid_argument&) {
    refused = true;
  }
  CHECK(refused);
  // The single sub-flows agree too, including at a = 0 (eps = 0).
  for (double e : {0.0, 0.1, 50.0}) {
    const Sys s(3, e, ScalarMass(1.0), DamperDamping(mass, e, {1.0}, fn(radial_gradient)),
                SystemFunctions{fn(potential), fn(gradient), fn(hessian_product), fn(j3), {}}, 1);
    const ElasticPendulum p(e);
    State<Eigen::Dynamic> y = y0;
    State<3> z = z0;
    WorkspaceFor<Sys> wy(3, 1);
    WorkspaceFor<ElasticPendulum> wz(3, 1);
    flows::kick_damp(s, y, 0.3, wy);
    flows::kick_damp(p, z, 0.3, wz);
    flows::damp(s, y, 0.7, wy);
    flows::damp(p, z, 0.7, wz);
    CHECK(distance(y, z) <= 1e-14);
  }
}

void fused_3s_body_is_the_sub_flows() {
  const Eigen::MatrixXd mass = Eigen::MatrixXd::Identity(3, 3);
  const double eps = 0.1;
  long calls = 0;
  using Sys = CompiledSystem<ScalarMass, DamperDamping>;
  const SystemFunctions plain{fn(potential), fn(gradient), fn(hessian_product), fn(j3), {}};
  SystemFunctions fused = plain;
  fused.damp_then_3s_body = {elastic_3s_body, &calls};
  const Sys one_by_one(3, eps, ScalarMass(1.0), DamperDamping(mass, eps, {1.0}, fn(radial_gradient), 1.0), plain, 1);
  const Sys in_one_call(3, eps, ScalarMass(1.0),
                        DamperDamping(mass, eps, {1.0}, fn(radial_gradient), 1.0, fn(radial_projection)), fused, 1);
  CHECK(in_one_call.fuses_3s() && !one_by_one.fuses_3s());
  const ButcherTableau& tab = resolve_tableau(method_entry("3s"), "");
  const long steps = 5000;
  RunSpec spec{0.01, steps, 0.01, steps, false};  // no work integral: the steps merge
  const State<Eigen::Dynamic> y0{Vec(Vector<3>(0.0, 1.55884573, -0.6)), Vec(Vector<3>(1.34164079, 0.0, 0.0))};
  const RunResult a = integrate<ThreeTermSplitting>(one_by_one, tab, y0, spec);
  const RunResult b = integrate<ThreeTermSplitting>(in_one_call, tab, y0, spec);
  // join(i) + body(i + 1) in one call for nearly every step: not the first of each
  // block between saves, progress and cancel checks (its damp is the block's lead),
  // nor the last (it has h_last).
  auto mostly_fused = [&] {
    if (!(calls >= steps - steps / 20 && calls < steps)) std::printf("fused calls: %ld of %ld\n", calls, steps);
    return calls >= steps - steps / 20 && calls < steps;
  };
  CHECK(mostly_fused());
  const State<3> z0{Vector<3>(y0.q), Vector<3>(y0.p)};
  calls = 0;
  const RunResult c = integrate<ThreeTermSplitting>(in_one_call.fixed<3>(), tab, z0, spec);
  CHECK(mostly_fused());
  for (const RunResult* r : {&b, &c}) {
    double worst = 0.0;
    for (std::size_t i = 0; i < a.trajectory.q.size(); ++i)
      worst = std::max({worst, std::abs(a.trajectory.q[i] - r->trajectory.q[i]),
                        std::abs(a.trajectory.p[i] - r->trajectory.p[i])});
    if (!(worst <= 1e-12)) std::printf("fused 3s body and sub-flows differ by %.3g\n", worst);
    CHECK(worst <= 1e-12);
    CHECK_NEAR(r->max_momentum_drift, a.max_momentum_drift, 1e-14);
  }
  // A fused body needs the projection (its k is the projection's).
  CHECK(test::throws([&] {
    Sys(3, eps, ScalarMass(1.0), DamperDamping(mass, eps, {1.0}, fn(radial_gradient), 1.0), fused, 1);
  }));
}

void linear_dampers_equal_constant_damping() {
  Eigen::MatrixXd mass = Eigen::Vector3d(1.0, 1.5, 2.0).asDiagonal();
  mass(0, 1) = mass(1, 0) = 0.2;  // a full SPD mass
  const double eps = 0.4, t = 0.9;
  Eigen::Vector3d e1(-1.0, 1.0, 0.0), e2(0.0, -1.0, 1.0);
  const Eigen::MatrixXd d = 1.0 * e1 * e1.transpose() + 1.0 * e2 * e2.transpose();
  const DamperDamping dampers(mass, eps, {1.0, 1.0}, fn(chain_gradients));
  const ConstantDamping constant(mass, d, eps);
  const Vec q = Vec::Zero(3);
  Vec g(3), pa(3), pb(3);
  g << 0.3, -0.1, 0.8;
  pa << 1.0, -2.0, 0.5;
  pb = pa;
  dampers.decay(q, dampers.factors(t), pa);
  constant.decay(q, constant.factors(t), pb);
  CHECK((pa - pb).cwiseAbs().maxCoeff() <= 1e-14);
  dampers.decay_affine(q, dampers.factors(t), g, pa);
  constant.decay_affine(q, constant.factors(t), g, pb);
  CHECK((pa - pb).cwiseAbs().maxCoeff() <= 1e-14);
  Vec ra(3), rb(3);
  dampers.rate(q, pa, ra);
  constant.rate(q, pa, rb);
  CHECK((ra - rb).cwiseAbs().maxCoeff() <= 1e-14);
  dampers.solve_shifted(q, 0.7, ra);
  constant.solve_shifted(q, 0.7, rb);
  CHECK((ra - rb).cwiseAbs().maxCoeff() <= 1e-14);
  // (I + cA) x recovers the input: the shifted solve is a real inverse.
  Vec x = pa, y(3);
  constant.solve_shifted(q, 0.7, x);
  constant.rate(q, x, y);
  CHECK(((x + 0.7 * y) - pa).cwiseAbs().maxCoeff() <= 1e-14);
}

void diagonal_constant_damping_is_exponential() {
  const Eigen::MatrixXd mass = Eigen::Vector2d(2.0, 0.5).asDiagonal();
  const Eigen::MatrixXd d = Eigen::Vector2d(1.0, 3.0).asDiagonal();
  const double eps = 0.2, t = 1.7;
  const ConstantDamping damping(mass, d, eps);
  Vec p(2);
  p << 1.0, -1.0;
  damping.decay(Vec::Zero(2), damping.factors(t), p);
  CHECK_NEAR(p[0], std::exp(-t * eps * 1.0 / 2.0), 1e-15);
  CHECK_NEAR(p[1], -std::exp(-t * eps * 3.0 / 0.5), 1e-15);
}

// One Factors object carried from q to q, as a run does: q1 -> q2 keeps x = -t eps c
// w.grad g (q2 = -q1, same |grad g|), q2 -> q3 changes it. With M = m I and A = eps c g g^T / m,
//   exp(-tA) p = p + expm1(-t a) (g.p / |g|^2) g,  a = eps c |g|^2 / m,
//   t phi1(-tA) v = t v + (t phi1(-t a) - t) (g.v / |g|^2) g.
void rank_one_factors_follow_q() {
  const double m = 2.0, eps = 0.3, c = 1.5, t = 0.8;
  const Eigen::MatrixXd mass = m * Eigen::MatrixXd::Identity(2, 2);
  const DamperDamping damping(mass, eps, {c}, fn(planar_gradient));
  auto decay = damping.factors(t), affine = damping.factors(t);
  Vec p(2), v(2), q(2);
  v << 0.4, -0.9;
  for (const auto& at : {std::array<double, 2>{0.6, -0.8}, {-0.6, 0.8}, {1.7, 0.4}, {0.1, 0.2}}) {
    q << at[0], at[1];
    const double gg = q.squaredNorm(), a = eps * c * gg / m;
    p << 1.0, -2.0;
    Vec expected = p + std::expm1(-t * a) * (q.dot(p) / gg) * q;
    damping.decay(q, decay, p);
    CHECK((p - expected).cwiseAbs().maxCoeff() <= 4e-15);
    p << 1.0, -2.0;
    const double x = -t * a, t_phi1 = t * std::expm1(x) / x;
    expected = p + std::expm1(x) * (q.dot(p) / gg) * q - (t * v + (t_phi1 - t) * (q.dot(v) / gg) * q);
    damping.decay_affine(q, affine, v, p);
    CHECK((p - expected).cwiseAbs().maxCoeff() <= 1e-14);
  }
}

void phi2_is_continuous() {
  for (double x : {1e-3, -1e-3, 0.05, -0.05, 0.5, -0.5}) {
    const double below = phi2(std::nextafter(x, 0.0)), at = phi2(x);
    CHECK(std::abs(below - at) <= 1e-15 * at);
  }
  // Against long double where its direct form is accurate (|x| >= 1e-3: cancellation
  // costs it about 1e-19 / |x|), on both sides of each switch.
  for (double x : {-0.9e-3, 1e-3, -0.0499, 0.05, 0.3, -0.4999, 0.5, -2.0, 3.0}) {
    const long double xl = x;
    const double expected = static_cast<double>((std::expm1(xl) - xl) / (xl * xl));
    CHECK_NEAR(phi2(x), expected, 1e-15 * expected);  // a few ulp
  }
  CHECK_NEAR(phi2(0.0), 0.5, 0.0);
  CHECK_NEAR(phi2(-1.0), (std::exp(-1.0) - 1.0 + 1.0), 1e-15);  // (e^-1 - 1 + 1)/1
}

}  // namespace

int main() {
  fused_3s_body_is_the_sub_flows();
  elastic_pendulum_as_system();
  linear_dampers_equal_constant_damping();
  diagonal_constant_damping_is_exponential();
  rank_one_factors_follow_q();
  phi2_is_continuous();
  TEST_MAIN_RETURN();
}
