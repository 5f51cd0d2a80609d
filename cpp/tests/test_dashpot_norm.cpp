// One dashpot with a constant a = grad g^T M^{-1} grad g (DamperDamping's norm, taken
// once per sub-step length) against the general path (norm NaN: a at every q):
// - the elastic pendulum (a dashpot on |q|, M = I, a = 1) and a planar spring between
//   two particles (a dashpot on |q1 - q2|, a = 1/m1 + 1/m2), with a scalar and with a
//   diagonal (dense kind) mass: every method's trajectory agrees to 1e-13;
// - the single flows agree at several q, including eps = 0;
// - the same with the flows taking the compiled projection P(q, u) = grad g (grad g .
//   M^{-1} u) instead of the gradient (what a System's dashpot with a constant a runs);
// - a constant norm is refused where it cannot hold (several dashpots, a < 0, inf), and
//   a projection without one.
#include <cmath>
#include <cstdio>
#include <limits>

#include "check.hpp"
#include "elastic_functions.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;
using Vec = Eigen::VectorXd;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

CompiledFunction fn(CompiledFunction::Fn f) { return {f, nullptr}; }

// Two particles in the plane, q = (x1, y1, x2, y2), joined by a spring (k = 2, l = 1)
// with a dashpot on its length r = |q1 - q2|.
double spring_length(const double* q) { return std::hypot(q[0] - q[2], q[1] - q[3]); }
void spring_potential(double* out, const double* q, void*) {
  const double r = spring_length(q);
  out[0] = (r - 1.0) * (r - 1.0);
}
void spring_gradient(double* out, const double* q, void*) {
  const double r = spring_length(q), s = 2.0 * (1.0 - 1.0 / r);
  out[0] = s * (q[0] - q[2]);
  out[1] = s * (q[1] - q[3]);
  out[2] = -out[0];
  out[3] = -out[1];
}
void length_gradient(double* out, const double* q, void*) {
  const double r = spring_length(q);
  out[0] = (q[0] - q[2]) / r;
  out[1] = (q[1] - q[3]) / r;
  out[2] = -out[0];
  out[3] = -out[1];
}
// P(q, u) of the dashpot on |q1 - q2|; data: the diagonal of M^{-1} (4 entries).
void length_projection(double* out, const double* in, void* data) {
  const double* u = in + 4;
  const double* inverse = static_cast<const double*>(data);
  double g[4], s = 0.0;
  length_gradient(g, in, nullptr);
  for (int i = 0; i < 4; ++i) s += g[i] * inverse[i] * u[i];
  for (int i = 0; i < 4; ++i) out[i] = s * g[i];
}
void no_hessian(double* out, const double*, void*) {
  for (int i = 0; i < 4; ++i) out[i] = 0.0;
}

template <class Mass>
Mass make_mass(const Eigen::MatrixXd& m) {
  if constexpr (std::is_same_v<Mass, ScalarMass>) return ScalarMass(m(0, 0));
  else return DenseMass(m);
}

// Every method on the system with a constant norm (taking the gradient, then the
// projection) against norm NaN: q and p at the saved points agree to 1e-13 (the
// same arithmetic but for phi1's argument) and, for the projection, to 2e-12: it
// rounds differently ((g.M^{-1}p) g against (w.p) g; the single flows agree to 4e-15
// below) and 2000 steps of the spring grow that to 6e-13.
template <class Mass>
void check_paths(const Eigen::MatrixXd& mass, double norm, CompiledFunction potential, CompiledFunction gradient,
                        CompiledFunction damper, CompiledFunction projection, const Vec& q0, const Vec& p0) {
  const int n = static_cast<int>(q0.size());
  const double eps = 0.1;
  using Sys = CompiledSystem<Mass, DamperDamping>;
  const SystemFunctions f{potential, gradient, fn(no_hessian), {}, {}};
  const Sys constant(n, eps, make_mass<Mass>(mass), DamperDamping(mass, eps, {1.5}, damper, norm), f, 0);
  const Sys projected(n, eps, make_mass<Mass>(mass), DamperDamping(mass, eps, {1.5}, damper, norm, projection), f, 0);
  const Sys general(n, eps, make_mass<Mass>(mass), DamperDamping(mass, eps, {1.5}, damper), f, 0);
  CHECK(constant.damping.constant_norm() && !general.damping.constant_norm());
  CHECK(projected.damping.projects() && !constant.damping.projects());
  const State<Eigen::Dynamic> z0{q0, p0};
  for (const char* name : {"3s", "2s", "rks", "rksb", "heun"}) {
    const ButcherTableau& tab = resolve_tableau(method_entry(name), "");
    const RunSpec spec{0.1, 2000, 0.07, 100, true};
    const RunResult b = with_method(name, [&](auto m) { return integrate<decltype(m)>(general, tab, z0, spec); });
    for (const Sys* sys : {&constant, &projected}) {
      const RunResult a = with_method(name, [&](auto m) { return integrate<decltype(m)>(*sys, tab, z0, spec); });
      double d = 0.0;
      for (std::size_t i = 0; i < a.trajectory.q.size(); ++i)
        d = std::max(
            {d, std::abs(a.trajectory.q[i] - b.trajectory.q[i]), std::abs(a.trajectory.p[i] - b.trajectory.p[i])});
      const double tolerance = sys == &constant ? 1e-13 : 2e-12;
      if (!(d <= tolerance))
        std::printf("method %s: %s and general path differ by %.3g\n", name,
                    sys == &constant ? "constant norm" : "projection", d);
      CHECK(d <= tolerance);
      CHECK(a.trajectory.rows() == b.trajectory.rows());
      CHECK_NEAR(a.trajectory.work.back(), b.trajectory.work.back(), tolerance);
    }
  }
}

void pendulum_constant_norm_is_the_general_path() {
  const Eigen::MatrixXd mass = Eigen::MatrixXd::Identity(3, 3);
  Vec q0(3), p0(3);
  q0 << 0.0, 1.55884573, -0.6;
  p0 << 1.34164079, 0.0, 0.0;
  check_paths<ScalarMass>(mass, 1.0, fn(test::elastic::potential), fn(test::elastic::gradient),
                          fn(test::elastic::radial_gradient), fn(test::elastic::radial_projection), q0, p0);
}

void spring_constant_norm_is_the_general_path() {
  Vec q0(4), p0(4);
  q0 << 0.0, 0.0, 1.3, 0.4;
  p0 << 0.2, -0.5, -0.1, 0.7;
  const Eigen::MatrixXd equal = 2.0 * Eigen::MatrixXd::Identity(4, 4);
  double half[4] = {0.5, 0.5, 0.5, 0.5};
  check_paths<ScalarMass>(equal, 1.0, fn(spring_potential), fn(spring_gradient), fn(length_gradient),
                          {length_projection, half}, q0, p0);
  const Eigen::MatrixXd unequal = Eigen::Vector4d(1.3, 1.3, 2.7, 2.7).asDiagonal();
  double inverse[4] = {1.0 / 1.3, 1.0 / 1.3, 1.0 / 2.7, 1.0 / 2.7};
  check_paths<DenseMass>(unequal, 1.0 / 1.3 + 1.0 / 2.7, fn(spring_potential), fn(spring_gradient),
                         fn(length_gradient), {length_projection, inverse}, q0, p0);
}

// The flows one at a time, each from a fresh state, at q where |q1 - q2| differs.
void single_flows_agree() {
  const Eigen::MatrixXd mass = Eigen::Vector4d(1.3, 1.3, 2.7, 2.7).asDiagonal();
  const double norm = 1.0 / 1.3 + 1.0 / 2.7;
  for (double eps : {0.0, 0.1, 30.0}) {
    const DamperDamping constant(mass, eps, {0.8}, fn(length_gradient), norm);
    const DamperDamping general(mass, eps, {0.8}, fn(length_gradient));
    double inverse[4] = {1.0 / 1.3, 1.0 / 1.3, 1.0 / 2.7, 1.0 / 2.7};
    const DamperDamping projected(mass, eps, {0.8}, fn(length_gradient), norm, {length_projection, inverse});
    for (double t : {0.05, 0.5}) {
      const auto fc = constant.factors(t), fg = general.factors(t), fp = projected.factors(t);
      for (double x2 : {1.3, -0.2, 4.0}) {
        Vec q(4), g(4), pc(4), pg(4);
        q << 0.1, -0.3, x2, 0.5;
        g << 0.3, -0.1, 0.8, 0.2;
        pc << 1.0, -2.0, 0.5, 0.25;
        pg = pc;
        Vec pp = pc;
        constant.decay(q, fc, pc);
        general.decay(q, fg, pg);
        projected.decay(q, fp, pp);
        CHECK((pc - pg).cwiseAbs().maxCoeff() <= 1e-15);
        CHECK((pp - pg).cwiseAbs().maxCoeff() <= 4e-15);
        constant.decay_affine(q, fc, g, pc);
        general.decay_affine(q, fg, g, pg);
        projected.decay_affine(q, fp, g, pp);
        CHECK((pc - pg).cwiseAbs().maxCoeff() <= 1e-15);
        CHECK((pp - pg).cwiseAbs().maxCoeff() <= 4e-15);
      }
    }
  }
}

void constant_norm_refused_where_it_cannot_hold() {
  const Eigen::MatrixXd mass = Eigen::MatrixXd::Identity(4, 4);
  using test::throws;
  CHECK(throws([&] { DamperDamping(mass, 0.1, {1.0, 1.0}, fn(length_gradient), 1.0); }));
  CHECK(throws([&] { DamperDamping(mass, 0.1, {1.0}, fn(length_gradient), -1.0); }));
  CHECK(throws([&] { DamperDamping(mass, 0.1, {1.0}, fn(length_gradient), std::numeric_limits<double>::infinity()); }));
  CHECK(!throws([&] { DamperDamping(mass, 0.1, {1.0}, fn(length_gradient), 2.0); }));
  CHECK(!throws([&] { DamperDamping(mass, 0.1, {1.0, 1.0}, fn(length_gradient), kNaN); }));
  double inverse[4] = {1.0, 1.0, 1.0, 1.0};
  const CompiledFunction projection{length_projection, inverse};
  CHECK(throws([&] { DamperDamping(mass, 0.1, {1.0}, fn(length_gradient), kNaN, projection); }));
  CHECK(throws([&] { DamperDamping(mass, 0.1, {1.0, 1.0}, fn(length_gradient), kNaN, projection); }));
  CHECK(!throws([&] { DamperDamping(mass, 0.1, {1.0}, fn(length_gradient), 2.0, projection); }));
}

}  // namespace

int main() {
  pendulum_constant_norm_is_the_general_path();
  spring_constant_norm_is_the_general_path();
  single_flows_agree();
  constant_norm_refused_where_it_cannot_hold();
  TEST_MAIN_RETURN();
}
