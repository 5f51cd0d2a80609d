// The sparse linear-structure kinds (models/linear_structure.hpp) on a 1-D bar of
// two-node finite elements, lumped and consistent mass, against a dense modal
// reference: K Phi = M Phi Lambda, Phi^T M Phi = I, so f(K M^{-1}) = M Phi f(Lambda) Phi^T.
// - the exact damping flows (Chebyshev) equal the modal ones to 1e-12 for t rho from 1e-6 to 100;
// - the spectral bound is above lambda_max and within the margin of it;
// - solve_shifted is the inverse of I + cA;
// - eps = 0 (alpha = beta = 0): 3s and 2s equal sv;
// - once warmed up, the flows allocate nothing (a counting operator new);
// - a small structure (n <= kMaxDenseDim) flows by its modes: the same checks, and its flows equal
//   the Chebyshev ones (dense_limit 0) to 1e-13.
// GCC 12 false positives: "may be used uninitialized" inside Eigen's dense generalised
// eigensolver (the test's reference), "null argument" in Eigen's copy of an empty
// vector, and free() after the counting operator new of counting_new.hpp (which does call malloc).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wnonnull"
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <Eigen/Eigenvalues>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "check.hpp"
#include "counting_new.hpp"
#include "raydamp/raydamp.hpp"
#include "raydamp/models/linear_structure.hpp"


using namespace raydamp;
using raydamp::test::throws;
using Vec = Eigen::VectorXd;

namespace {

// A fixed-free bar of n elements (unit length, EA = 1, rho A = 1), node 0 clamped.
struct Bar {
  SparseColMajor k, m;
  Vec lumped;
};

Bar bar(int n) {
  const double h = 1.0 / n;
  std::vector<Eigen::Triplet<double>> kt, mt;
  Vec lumped = Vec::Zero(n);
  for (int e = 0; e < n; ++e) {  // element e joins nodes e and e + 1; node 0 is clamped (dropped)
    const int a = e - 1, b = e;
    const double ke[2][2] = {{1.0 / h, -1.0 / h}, {-1.0 / h, 1.0 / h}};
    const double me[2][2] = {{h / 3.0, h / 6.0}, {h / 6.0, h / 3.0}};
    const int dofs[2] = {a, b};
    for (int i = 0; i < 2; ++i) {
      if (dofs[i] < 0) continue;
      lumped[dofs[i]] += h / 2.0;
      for (int j = 0; j < 2; ++j) {
        if (dofs[j] < 0) continue;
        kt.emplace_back(dofs[i], dofs[j], ke[i][j]);
        mt.emplace_back(dofs[i], dofs[j], me[i][j]);
      }
    }
  }
  Bar out{SparseColMajor(n, n), SparseColMajor(n, n), lumped};
  out.k.setFromTriplets(kt.begin(), kt.end());
  out.m.setFromTriplets(mt.begin(), mt.end());
  return out;
}

struct Modal {
  Eigen::MatrixXd m, phi;
  Vec lambda;
  // f(K M^{-1}) x
  template <class F>
  Vec apply(F f, const Vec& x) const {
    Vec c = phi.transpose() * x;
    for (Eigen::Index i = 0; i < c.size(); ++i) c[i] *= f(lambda[i]);
    return m * (phi * c);
  }
};

Modal modal(const SparseColMajor& k, const Eigen::MatrixXd& m) {
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(Eigen::MatrixXd(k), m);
  return {m, eig.eigenvectors(), eig.eigenvalues()};
}

double relative(const Vec& a, const Vec& b) { return (a - b).norm() / b.norm(); }

template <class Mass>
void flows_equal_modal(const Mass& mass, const Eigen::MatrixXd& dense_mass, const SparseColMajor& k,
                       const char* label) {
  const Modal ref = modal(k, dense_mass);
  const double lambda_max = ref.lambda.maxCoeff();
  const double alpha = 0.05, beta = 2e-3;
  const LinearStructure<Mass> s(mass, k, Vec(), alpha, beta);
  const double bound = s.damping.spectral_bound();
  if (!(bound >= lambda_max && bound <= 1.2 * lambda_max))
    std::printf("%s: spectral bound %.6g, lambda_max %.6g\n", label, bound, lambda_max);
  CHECK(bound >= lambda_max && bound <= 1.2 * lambda_max);
  const double rho = alpha + beta * lambda_max;
  const int n = s.size();
  Vec p(n), g(n);
  for (int i = 0; i < n; ++i) {
    p[i] = std::cos(0.3 * i) + 0.1 * i / n;
    g[i] = std::sin(0.7 * i + 0.2);
  }
  for (double t_rho : {1e-6, 1e-3, 0.1, 1.0, 10.0, 100.0}) {
    const double t = t_rho / rho;
    auto rate = [&](double l) { return alpha + beta * l; };
    const Vec expected_damp = ref.apply([&](double l) { return std::exp(-t * rate(l)); }, p);
    const Vec expected_affine =
        expected_damp - ref.apply([&](double l) { return t * phi1(-t * rate(l)); }, g);
    Vec got = p;
    const auto f = s.damping.factors(t);
    s.damping.decay(Vec(), f, got);
    const double e1 = relative(got, expected_damp);
    got = p;
    s.damping.decay_affine(Vec(), f, g, got);
    const double e2 = relative(got, expected_affine);
    if (!(e1 <= 1e-12 && e2 <= 1e-12))
      std::printf("%s t rho = %g: damp error %.3g, kick_damp error %.3g (degrees %d, %d)\n", label, t_rho, e1, e2,
                  f.series->exp.degree(), f.series->t_phi1.degree());
    CHECK(e1 <= 1e-12);
    CHECK(e2 <= 1e-12);
  }
  // (I + cA) (I + cA)^{-1} x = x.
  for (double c : {1e-3, 0.5, 40.0}) {
    Vec x = p, ax(n);
    s.damping.solve_shifted(Vec(), c, x);
    s.damping.rate(Vec(), x, ax);
    CHECK(relative(x + c * ax, p) <= 1e-12);
  }
  // The rate is A p = alpha p + beta K M^{-1} p.
  Vec ap(n);
  s.damping.rate(Vec(), p, ap);
  CHECK(relative(ap, ref.apply([&](double l) { return alpha + beta * l; }, p)) <= 1e-12);
  // V, grad V and T.
  Vec q = g, grad(n);
  s.gradient(q, grad);
  CHECK(relative(grad, Vec(k * q)) <= 1e-15);
  CHECK_NEAR(s.potential(q), 0.5 * q.dot(k * q), 1e-13 * q.dot(k * q));
  CHECK_NEAR(s.mass.kinetic(p), 0.5 * p.dot(dense_mass.ldlt().solve(p)), 1e-12 * p.squaredNorm());
}

template <class Mass>
void flows_do_not_allocate(const Mass& mass, const SparseColMajor& k) {
  const LinearStructure<Mass> s(mass, k, Vec::Ones(k.rows()), 0.1, 1e-3);
  using Model = LinearStructure<Mass>;
  const int n = s.size();
  State<Eigen::Dynamic> z{Vec::Constant(n, 0.01), Vec::Constant(n, 0.02)};
  WorkspaceFor<Model> ws(n, 1);
  auto round = [&] {
    flows::damp(s, z, 0.05, ws);
    flows::kick_damp(s, z, 0.05, ws);
    flows::drift(s, z, 0.05, ws);
    s.damping.rate(z.q, z.p, ws.f);
    s.damping.solve_shifted(z.q, 0.025, ws.f);
    (void)energy(s, z);
  };
  for (const double sigma : {0.0, 0.5}) {  // and at a temperature: beta K's noise (R xi, then psi's series)
    ws.sigma = sigma;
    ws.noise = NormalStream(7, 0);
    round();  // first use: factors, shifted factorisation, noise factor and series, scratch
    const long before = allocations.load();
    for (int i = 0; i < 10; ++i) round();
    const long made = allocations.load() - before;
    if (made != 0) std::printf("%s, sigma %g: %ld allocations in 10 rounds of flows\n", Mass::kind, sigma, made);
    CHECK(made == 0);
  }
}

template <class Mass>
void undamped_splittings_are_stormer_verlet(const Mass& mass, const SparseColMajor& k) {
  const LinearStructure<Mass> s(mass, k, Vec(), 0.0, 0.0);
  CHECK(s.eps == 0.0);
  const int n = s.size();
  Vec q0(n), p0 = Vec::Zero(n);
  for (int i = 0; i < n; ++i) q0[i] = std::sin(0.1 * i);
  // h omega_max = 1.04 for the consistent bar (omega_max = sqrt(12) n): inside sv's stability interval
  // (at h = 0.01 it is 2.08 and every run blows up, so the comparison would compare overflows).
  const RunSpec spec{0.005, 200, 0.005, 200};
  const ButcherTableau& tab = resolve_tableau(method_entry("3s"), "");
  const State<Eigen::Dynamic> z0{q0, p0};
  const RunResult sv = integrate<StormerVerlet>(s, tab, z0, spec);
  for (const char* name : {"3s", "2s"}) {
    const RunResult r = with_method(name, [&](auto m) { return integrate<decltype(m)>(s, tab, z0, spec); });
    double worst = 0.0;
    for (std::size_t i = 0; i < r.trajectory.q.size(); ++i)
      worst = std::max({worst, std::abs(r.trajectory.q[i] - sv.trajectory.q[i]),
                        std::abs(r.trajectory.p[i] - sv.trajectory.p[i])});
    if (!(worst <= 1e-13)) std::printf("%s %s at eps = 0 differs from sv by %.3g\n", Mass::kind, name, worst);
    CHECK(worst <= 1e-13);
  }
}

// The dense (modal) flows of a small structure against its Chebyshev flows, which the same
// structure runs with dense_limit = 0.
template <class Mass>
void dense_flows_equal_chebyshev(const Mass& mass, const SparseColMajor& k, const char* label) {
  const double alpha = 0.05, beta = 2e-3;
  const LinearStructure<Mass> dense(mass, k, Vec::Ones(k.rows()), alpha, beta);
  const LinearStructure<Mass> sparse(mass, k, Vec::Ones(k.rows()), alpha, beta, 0);
  CHECK(dense.damping.dense() && !sparse.damping.dense());
  const int n = dense.size();
  Vec p(n), g(n);
  for (int i = 0; i < n; ++i) {
    p[i] = std::cos(0.3 * i) + 0.1 * i / n;
    g[i] = std::sin(0.7 * i + 0.2);
  }
  const double rho = sparse.damping.rate_bound();
  double worst = 0.0;
  for (double t_rho : {1e-6, 1e-3, 0.1, 1.0, 10.0, 100.0}) {
    const double t = t_rho / rho;
    Vec a = p, b = p;
    dense.damping.decay(Vec(), dense.damping.factors(t), a);
    sparse.damping.decay(Vec(), sparse.damping.factors(t), b);
    worst = std::max(worst, (a - b).norm() / p.norm());
    a = p;
    b = p;
    dense.damping.decay_affine(Vec(), dense.damping.factors(t), g, a);
    sparse.damping.decay_affine(Vec(), sparse.damping.factors(t), g, b);
    worst = std::max(worst, (a - b).norm() / (p.norm() + t * g.norm()));
  }
  Vec a(n), b(n);
  dense.damping.rate(Vec(), p, a);
  sparse.damping.rate(Vec(), p, b);
  worst = std::max(worst, relative(a, b));
  a = p;
  b = p;
  dense.damping.solve_shifted(Vec(), 0.5, a);
  sparse.damping.solve_shifted(Vec(), 0.5, b);
  worst = std::max(worst, relative(a, b));
  Vec ga(n), gb(n);
  dense.gradient(g, ga);
  sparse.gradient(g, gb);
  worst = std::max(worst, relative(ga, gb));
  CHECK_NEAR(dense.potential(g), sparse.potential(g), 1e-13 * std::abs(sparse.potential(g)));
  if (!(worst <= 1e-13)) std::printf("%s: dense flows differ from the Chebyshev ones by %.3g\n", label, worst);
  CHECK(worst <= 1e-13);
  // An ensemble member (K scaled): its bound is the scaled one, its flows its own structure's.
  const LinearStructure<Mass> member = dense.with_parameters(0.1, 1e-3, 4.0);
  const LinearStructure<Mass> direct(mass, SparseColMajor(4.0 * k), Vec::Ones(k.rows()), 0.1, 1e-3);
  CHECK_NEAR(member.damping.spectral_bound(), 4.0 * dense.damping.spectral_bound(), 1e-15 * member.damping.spectral_bound());
  Vec x = p, y = p;
  member.damping.decay_affine(Vec(), member.damping.factors(0.3), g, x);
  direct.damping.decay_affine(Vec(), direct.damping.factors(0.3), g, y);
  CHECK(relative(x, y) <= 1e-13);
  CHECK(throws([&] { dense.with_parameters(0.1, 0.0, 0.0); }));
}

}  // namespace

int main() {
  const Bar b = bar(60);
  const Eigen::MatrixXd consistent = Eigen::MatrixXd(b.m);
  const Eigen::MatrixXd lumped = b.lumped.asDiagonal();
  flows_equal_modal(LumpedMass(b.lumped), lumped, b.k, "lumped");
  flows_equal_modal(ConsistentMass(b.m), consistent, b.k, "consistent");
  flows_do_not_allocate(LumpedMass(b.lumped), b.k);
  flows_do_not_allocate(ConsistentMass(b.m), b.k);
  undamped_splittings_are_stormer_verlet(LumpedMass(b.lumped), b.k);
  undamped_splittings_are_stormer_verlet(ConsistentMass(b.m), b.k);
  // A small bar: the dense path.
  const Bar small = bar(8);
  CHECK(small.k.rows() <= kMaxDenseDim);
  flows_equal_modal(LumpedMass(small.lumped), Eigen::MatrixXd(small.lumped.asDiagonal()), small.k, "small lumped");
  flows_equal_modal(ConsistentMass(small.m), Eigen::MatrixXd(small.m), small.k, "small consistent");
  flows_do_not_allocate(LumpedMass(small.lumped), small.k);
  flows_do_not_allocate(ConsistentMass(small.m), small.k);
  undamped_splittings_are_stormer_verlet(LumpedMass(small.lumped), small.k);
  dense_flows_equal_chebyshev(LumpedMass(small.lumped), small.k, "small lumped");
  dense_flows_equal_chebyshev(ConsistentMass(small.m), small.k, "small consistent");
  CHECK(throws([&] { LumpedMass(Vec::Constant(3, -1.0)); }));
  CHECK(throws([&] { ConsistentMass(SparseColMajor(-1.0 * b.m)); }));
  SparseColMajor skew = b.k;
  skew.coeffRef(0, 1) += 1.0;
  CHECK(throws([&] { LinearStructure<LumpedMass>(LumpedMass(b.lumped), skew, Vec(), 0.1, 0.0); }));
  TEST_MAIN_RETURN();
}
