// The linear implicit methods (methods/linear_implicit.hpp, implicit/) on a 1-D bar of
// two-node elements with consistent mass, Rayleigh damping and a load:
// - SparseLDLT solves real SPD and complex symmetric systems like a dense solver;
// - a step of "midpoint" and of "gauss4" equals the Gauss collocation step computed
//   densely from its Butcher tableau (the coupled stage system of the first-order form);
// - the damping work of a step is the method's: H(z1) - H(z0) + W = 0 to rounding;
// - compositions: yoshida4 over midpoint runs at beta = 0 and is refused, naming why,
//   where the backward sub-step's matrix is indefinite;
// - after the factorisations the steps allocate nothing (a counting operator new);
// - an ensemble's factors: made once per sub-step length (1, or 2 with a short last step,
//   whatever the member count), shared read-only by runs on two threads, each run equal
//   bit for bit to the same run making its own factors.
// GCC 12 false positives: see test_linear_structure.cpp.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wnonnull"
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "check.hpp"
#include "counting_new.hpp"
#include "raydamp/ensemble.hpp"
#include "raydamp/implicit/linear_implicit_step.hpp"
#include "raydamp/raydamp.hpp"


using namespace raydamp;
using raydamp::test::throws;
using Vec = Eigen::VectorXd;
using Complex = std::complex<double>;

namespace {

struct Bar {
  SparseColMajor k, m;
};

// A fixed-free bar of n elements (unit length, EA = 1, rho A = 1), node 0 clamped.
Bar bar(int n) {
  const double h = 1.0 / n;
  std::vector<Eigen::Triplet<double>> kt, mt;
  for (int e = 0; e < n; ++e) {
    const int dofs[2] = {e - 1, e};
    const double ke[2][2] = {{1.0 / h, -1.0 / h}, {-1.0 / h, 1.0 / h}};
    const double me[2][2] = {{h / 3.0, h / 6.0}, {h / 6.0, h / 3.0}};
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
        if (dofs[i] >= 0 && dofs[j] >= 0) {
          kt.emplace_back(dofs[i], dofs[j], ke[i][j]);
          mt.emplace_back(dofs[i], dofs[j], me[i][j]);
        }
  }
  Bar out{SparseColMajor(n, n), SparseColMajor(n, n)};
  out.k.setFromTriplets(kt.begin(), kt.end());
  out.m.setFromTriplets(mt.begin(), mt.end());
  return out;
}

double relative(const Vec& a, const Vec& b) { return (a - b).norm() / b.norm(); }

void sparse_ldlt_solves() {
  const Bar b = bar(30);
  auto pattern = std::make_shared<const SparsePattern>(SparseColMajor(b.m.cwiseAbs() + b.k.cwiseAbs()));
  const Eigen::MatrixXd dm(b.m), dk(b.k);
  const Vec x = Vec::LinSpaced(30, -1.0, 2.0).array().sin();
  {
    const SparseColMajor a = b.m + 0.01 * b.k;
    SparseLDLT<double> ldlt(pattern, a, "A");
    Vec out(30), work(30);
    ldlt.solve(x, out, work);
    CHECK(relative(out, (dm + 0.01 * dk).ldlt().solve(x)) < 1e-12);
    CHECK(ldlt.positive_pivots());
    // An indefinite matrix factorises (no zero pivot) but says so.
    SparseLDLT<double> indefinite(pattern, SparseColMajor(b.m - 0.5 * b.k), "A");
    CHECK(!indefinite.positive_pivots());
  }
  {
    const Complex c = Complex(0.02, 0.0) / Complex(3.0, std::sqrt(3.0));
    const Eigen::SparseMatrix<Complex, Eigen::ColMajor, int> a =
        SparseColMajor(b.m).cast<Complex>() + SparseColMajor(b.k).cast<Complex>() * (c * c);
    SparseLDLT<Complex> ldlt(pattern, a, "A");
    Eigen::VectorXcd out(30), work(30);
    const Eigen::VectorXcd xc = x.cast<Complex>() * Complex(1.0, -2.0);
    ldlt.solve(xc, out, work);
    const Eigen::MatrixXcd dense = dm.cast<Complex>() + dk.cast<Complex>() * (c * c);
    const Eigen::VectorXcd expected = dense.partialPivLu().solve(xc);
    CHECK((out - expected).norm() < 1e-12 * expected.norm());
  }
}

// One step of the s-stage Gauss method on y = (q, v), y' = A y + b, from its Butcher
// tableau: the stage derivatives K solve (I - h (a (x) A)) K = 1 (x) (A y0 + b).
struct DenseStep {
  Vec q, p;
  double work;
};

DenseStep gauss_dense(const Bar& b, double alpha, double beta, const Vec& f, const Vec& q0, const Vec& p0, double h,
                      int stages) {
  const int n = static_cast<int>(q0.size());
  const Eigen::MatrixXd m(b.m), k(b.k), c = alpha * m + beta * k, minv = m.inverse();
  Eigen::MatrixXd a(2 * n, 2 * n);
  a << Eigen::MatrixXd::Zero(n, n), Eigen::MatrixXd::Identity(n, n), -minv * k, -minv * c;
  Vec rhs_b(2 * n);
  rhs_b << Vec::Zero(n), minv * f;
  Eigen::MatrixXd tab(stages, stages);
  Vec weights(stages);
  if (stages == 1) {
    tab << 0.5;
    weights << 1.0;
  } else {
    const double r = std::sqrt(3.0) / 6.0;
    tab << 0.25, 0.25 - r, 0.25 + r, 0.25;
    weights << 0.5, 0.5;
  }
  Vec y0(2 * n);
  y0 << q0, minv * p0;
  Eigen::MatrixXd big = Eigen::MatrixXd::Identity(2 * n * stages, 2 * n * stages);
  Vec rhs(2 * n * stages);
  for (int i = 0; i < stages; ++i) {
    rhs.segment(2 * n * i, 2 * n) = a * y0 + rhs_b;
    for (int j = 0; j < stages; ++j) big.block(2 * n * i, 2 * n * j, 2 * n, 2 * n) -= h * tab(i, j) * a;
  }
  const Vec kk = big.partialPivLu().solve(rhs);
  Vec y1 = y0;
  double work = 0.0;
  for (int i = 0; i < stages; ++i) {
    y1 += h * weights[i] * kk.segment(2 * n * i, 2 * n);
    const Vec v = kk.segment(2 * n * i, n);  // q' at stage i: the stage velocity
    work += h * weights[i] * v.dot(c * v);
  }
  return {y1.head(n), m * y1.tail(n), work};
}

template <class Method>
void step_matches_collocation(int stages) {
  const int n = 12;
  const Bar b = bar(n);
  const double alpha = 0.3, beta = 0.002, h = 0.05;
  const Vec f = Vec::LinSpaced(n, 0.5, -1.0);
  LinearStructure<ConsistentMass> s(ConsistentMass(b.m), b.k, f, alpha, beta);
  State<Eigen::Dynamic> z{Vec::LinSpaced(n, 0.0, 1.0).array().square(), Vec::LinSpaced(n, 1.0, -0.5)};
  const DenseStep expected = gauss_dense(b, alpha, beta, f, z.q, z.p, h, stages);
  RunSpec spec{h, 3, h, 1, true};
  typename Method::Stepper stepper(s, builtin_composition("none"), spec);
  WorkspaceFor<LinearStructure<ConsistentMass>> ws(n, 1);
  ws.track_work = true;
  const double h0 = energy(s, z);
  stepper.step(s, builtin_tableau("euler"), z, 0, ws);
  CHECK(relative(z.q, expected.q) < 1e-12);
  CHECK(relative(z.p, expected.p) < 1e-12);
  CHECK_NEAR(ws.work, expected.work, 1e-13 * expected.work);
  // H with the load's potential: H(z1) - H(z0) = -W (f constant).
  CHECK_NEAR(energy(s, z) - h0 + ws.work, 0.0, 1e-13 * std::abs(h0));
  // The steps allocate nothing once the factorisations exist.
  const long before = allocations.load();
  for (long i = 1; i < 3; ++i) stepper.step(s, builtin_tableau("euler"), z, i, ws);
  CHECK(allocations.load() == before);
}

void compositions_where_positive_definite() {
  const int n = 20;
  const Bar b = bar(n);
  const Vec q0 = 0.1 * (Vec::LinSpaced(n, 1.0, n) * (M_PI / (2 * n))).array().sin(), p0 = Vec::Zero(n);
  const Composition& yoshida = builtin_composition("yoshida4");
  // beta = 0: M + (s/2) alpha M + (s^2/4) K is SPD for |s| alpha < 2.
  LinearStructure<ConsistentMass> mass_damped(ConsistentMass(b.m), b.k, Vec(), 0.05, 0.0);
  CHECK(!throws([&] { ImplicitMidpoint::Stepper(mass_damped, yoshida, RunSpec{0.01, 10, 0.01, 1}); }));
  // beta K with |s| < 2 beta: the backward sub-step's matrix is indefinite.
  LinearStructure<ConsistentMass> stiff(ConsistentMass(b.m), b.k, Vec(), 0.0, 0.1);
  CHECK(throws([&] { ImplicitMidpoint::Stepper(stiff, yoshida, RunSpec{0.01, 10, 0.01, 1}); }));
  // Composed midpoint is order 4: the error at t = 1 drops about 16-fold per halving of h.
  auto final_q = [&](double h) {
    const long steps = std::lround(1.0 / h);
    RunSpec spec{h, steps, h, steps};
    return integrate<ImplicitMidpoint>(mass_damped, builtin_tableau("euler"), yoshida, State<Eigen::Dynamic>{q0, p0},
                                       spec)
        .trajectory.q;
  };
  const std::vector<double> reference = final_q(1.0 / 1600), coarse = final_q(1.0 / 50), fine = final_q(1.0 / 100);
  double e1 = 0.0, e2 = 0.0;
  for (int i = 0; i < n; ++i) {  // the last saved row
    e1 = std::max(e1, std::abs(coarse[n + i] - reference[n + i]));
    e2 = std::max(e2, std::abs(fine[n + i] - reference[n + i]));
  }
  CHECK(e1 / e2 > 12.0 && e1 / e2 < 20.0);
}


template <class Method>
void ensemble_shares_factors() {
  const int n = 40;
  const Bar b = bar(n);
  const Vec f = Vec::LinSpaced(n, 0.2, -0.3);
  LinearStructure<ConsistentMass> s(ConsistentMass(b.m), b.k, f, 0.3, 0.002);
  const ButcherTableau& euler = builtin_tableau("euler");
  const Composition& none = builtin_composition("none");
  // 24 steps of h and a last one of h / 2 (t_end = 0.6125), saved every 4.
  RunSpec spec{0.025, 25, 0.0125, 4};
  RunSpec even = spec;
  even.h_last = spec.h;
  CHECK(Method::Stepper::prepare(s, none, even)->count() == 1);
  const std::shared_ptr<const LinearImplicitFactors> shared = Method::Stepper::prepare(s, none, spec);
  CHECK(shared->count() == 2);
  const int members = 9;
  std::vector<State<Eigen::Dynamic>> z0;
  for (int i = 0; i < members; ++i)
    z0.push_back({(Vec::LinSpaced(n, 0.0, 1.0) * (i + 1.0)).array().sin().matrix(),
                  Vec::LinSpaced(n, 1.0, -0.5) * (0.1 * i)});
  std::vector<RunResult> own(members), ensemble(members);
  for (int i = 0; i < members; ++i) own[i] = integrate<Method>(s, euler, none, z0[i], spec);
  RunSpec member_spec = spec;
  member_spec.implicit_factors = shared;
  for_each_member(members, 2, [&](long i) { ensemble[i] = integrate<Method>(s, euler, none, z0[i], member_spec); });
  CHECK(shared->count() == 2);  // the members made none of their own
  for (int i = 0; i < members; ++i) {
    CHECK(ensemble[i].status == Status::completed && ensemble[i].steps == 25);
    CHECK(ensemble[i].trajectory.t == own[i].trajectory.t);
    CHECK(ensemble[i].trajectory.q == own[i].trajectory.q);
    CHECK(ensemble[i].trajectory.p == own[i].trajectory.p);
  }
  // The run really moved: the last state is not the first.
  CHECK(std::abs(own[3].trajectory.q.back() - z0[3].q[n - 1]) > 1e-3);
  // Factors of another structure (the same K, another damping) are refused.
  LinearStructure<ConsistentMass> other(ConsistentMass(b.m), b.k, f, 0.1, 0.002);
  bool refused = false;
  try {
    integrate<Method>(other, euler, none, z0[0], member_spec);
  } catch (const std::logic_error&) {
    refused = true;
  }
  CHECK(refused);
}

}  // namespace

int main() {
  sparse_ldlt_solves();
  step_matches_collocation<ImplicitMidpoint>(1);
  step_matches_collocation<Gauss4>(2);
  compositions_where_positive_definite();
  ensemble_shares_factors<ImplicitMidpoint>();
  ensemble_shares_factors<Gauss4>();
  TEST_MAIN_RETURN();
}
