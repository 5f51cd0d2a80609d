// Thermal noise: Philox-4x32-10 against the published known-answer vectors (Salmon et al. 2011,
// Random123's kat_vectors), the normal stream's moments, and one exact OU damping flow's noise
// (isotropic damping, unit mass: p1 = e^{-at} p0 + sqrt(kT (1 - e^{-2at})) xi) drawn from the stream;
// the ziggurat's normals against the normal distribution function (Kolmogorov-Smirnov, tails); the noise
// factor N of a LinearStructure's alpha M + beta K damping against N N^T = M - E M E^T in closed form
// (diagonal M and K) and from a dense eigendecomposition (consistent M).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "check.hpp"
#include "raydamp/damping/chain_damping.hpp"
#include "raydamp/mass/scalar_mass.hpp"
#include "raydamp/models/linear_structure.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

int main() {
  struct Kat { Philox4x32 ctr; PhiloxKey key; Philox4x32 out; };
  const Kat kats[] = {
      {{0, 0, 0, 0}, {0, 0}, {0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}},
      {{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, {0xffffffffu, 0xffffffffu},
       {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}},
      {{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, {0xa4093822u, 0x299f31d0u},
       {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}},
  };
  for (const Kat& k : kats) CHECK(philox4x32_10(k.ctr, k.key) == k.out);

  // 10^6 normals: mean 0, variance 1, fourth moment 3 within 5 standard errors; another stream differs.
  NormalStream a(12345, 0), b(12345, 1);
  const int N = 1000000;
  double s1 = 0, s2 = 0, s4 = 0, cross = 0;
  for (int i = 0; i < N; ++i) {
    const double x = a.next(), y = b.next();
    s1 += x;
    s2 += x * x;
    s4 += x * x * x * x;
    cross += x * y;
  }
  CHECK_NEAR(s1 / N, 0.0, 5.0 / std::sqrt(N));
  CHECK_NEAR(s2 / N, 1.0, 5.0 * std::sqrt(2.0 / N));
  CHECK_NEAR(s4 / N, 3.0, 5.0 * std::sqrt(96.0 / N));
  CHECK_NEAR(cross / N, 0.0, 5.0 / std::sqrt(N));
  // Kolmogorov-Smirnov against the normal distribution: the largest gap of the empirical CDF of 10^6 draws
  // below 1.95 / sqrt(N) (the 0.1% level), and the tails beyond 3 and 4 (ziggurat's base layer) as often as
  // they should be, within 5 standard errors.
  {
    NormalStream s(2025, 7);
    std::vector<double> x(N);
    for (double& v : x) v = s.next();
    std::sort(x.begin(), x.end());
    double gap = 0.0;
    for (int i = 0; i < N; ++i) {
      const double cdf = 0.5 * std::erfc(-x[i] / std::sqrt(2.0));
      gap = std::max({gap, std::abs(cdf - double(i) / N), std::abs(cdf - double(i + 1) / N)});
    }
    CHECK(gap < 1.95 / std::sqrt(double(N)));
    for (const double cut : {3.0, 4.0}) {
      const double p = std::erfc(cut / std::sqrt(2.0));  // P(|X| > cut)
      const double seen = double(std::count_if(x.begin(), x.end(), [&](double v) { return std::abs(v) > cut; })) / N;
      CHECK_NEAR(seen, p, 5.0 * std::sqrt(p * (1 - p) / N));
    }
  }
  // restoring a state replays the same numbers
  NormalStream c(7, 3);
  c.next();
  const NormalStream::State saved = c.state();
  const double first = c.next(), second = c.next();
  c.restore(saved);
  CHECK(c.next() == first && c.next() == second);

  // One damping flow of the damped pendulum (unit mass, A = eps I) at kT = 0.3 from the stream.
  const DampedPendulum model(0.5);
  WorkspaceFor<DampedPendulum> ws(1, 1);
  ws.sigma = std::sqrt(0.3);
  ws.noise = NormalStream(99, 0);
  State<1> z{Vector<1>(0.2), Vector<1>(1.5)};
  flows::damp(model, z, 0.4, ws);
  NormalStream same(99, 0);
  const double xi = same.next();
  CHECK_NEAR(z.p[0], std::exp(-0.2) * 1.5 + std::sqrt(0.3 * (1.0 - std::exp(-0.4))) * xi, 1e-15);
  CHECK(z.q[0] == 0.2);

  // Radial damping (the elastic pendulum: A = (eps/m) u u^T, u = q/|q|) has rank-one noise: one damping flow
  // draws one normal number, along q, so the stream's next number is the second one (it drew three before).
  {
    const ElasticPendulum spring;  // eps 0.1, m 1
    WorkspaceFor<ElasticPendulum> ews(3, 1);
    ews.sigma = std::sqrt(0.3);
    ews.noise = NormalStream(5, 1);
    State<3> s{Vector<3>(0.3, -0.4, 1.2), Vector<3>(0.5, 0.25, -1.0)};
    const Vector<3> q = s.q, p = s.p, u = q / q.norm();
    flows::damp(spring, s, 0.4, ews);
    NormalStream reference(5, 1);
    const double first = reference.next(), second = reference.next();
    const double decay = std::exp(-0.1 * 0.4), radial = u.dot(p);
    const Vector<3> expected = p + ((decay - 1.0) * radial + std::sqrt(0.3 * (1.0 - decay * decay)) * first) * u;
    CHECK((s.p - expected).cwiseAbs().maxCoeff() <= 1e-15);
    CHECK(ews.noise.next() == second);
  }

  // beta K noise: N's columns from unit draws, then N N^T against the OU covariance, to 1e-11 of its largest
  // entry. Diagonal case: lumped M = diag(m), K = diag(k), so M - E M E^T = diag(m_i (1 - e^{-2t(alpha + beta
  // k_i / m_i)})); the rates k_i / m_i span 1e-4 .. 1e2, and alpha = 0 with t = 1e-3 puts psi's steep part
  // (the square root's in the symmetric factor) at the bottom of the spectrum.
  auto noise_matrix = [](const auto& s, double t) {
    const int n = s.size();
    Eigen::MatrixXd noise(n, n);
    Eigen::VectorXd xi, p, q = Eigen::VectorXd::Zero(n);
    for (int j = 0; j < n; ++j) {
      xi = Eigen::VectorXd::Unit(n, j);
      p = Eigen::VectorXd::Zero(n);
      s.damping.add_noise(q, s.damping.factors(t), s.mass, 1.0, xi, p);
      noise.col(j) = p;
    }
    return Eigen::MatrixXd(noise * noise.transpose());
  };
  {
    const int n = 7;
    Eigen::VectorXd m(n), k(n);
    SparseColMajor kd(n, n);
    for (int i = 0; i < n; ++i) {
      m[i] = 0.5 + 0.25 * i;
      k[i] = m[i] * std::pow(10.0, -4.0 + i);  // k_i / m_i = 10^{i - 4}
      kd.insert(i, i) = k[i];
    }
    for (const double alpha : {0.0, 0.3})
      for (const double t : {1e-3, 0.1, 2.0}) {
        const LinearStructure<LumpedMass> s(LumpedMass(m), kd, Eigen::VectorXd(), alpha, 0.5);
        CHECK(s.damping.has_noise());
        const Eigen::MatrixXd cov = noise_matrix(s, t);
        Eigen::VectorXd expected(n);
        for (int i = 0; i < n; ++i) expected[i] = -m[i] * std::expm1(-2.0 * t * (alpha + 0.5 * k[i] / m[i]));
        const double scale = expected.maxCoeff();
        CHECK((cov - Eigen::MatrixXd(expected.asDiagonal())).cwiseAbs().maxCoeff() <= 1e-11 * scale);
        // each variance to 1e-9 of itself, the smallest (1e-7 of the largest at alpha = 0, t = 1e-3) included
        for (int i = 0; i < n; ++i) CHECK_NEAR(cov(i, i), expected[i], 1e-9 * expected[i]);
      }
    // alpha = 0 and a singular K: no noise factor (C = beta K is not positive definite), refused.
    kd.coeffRef(0, 0) = 0.0;
    const LinearStructure<LumpedMass> free(LumpedMass(m), kd, Eigen::VectorXd(), 0.0, 0.5);
    CHECK(!free.damping.has_noise());
  }
  // Consistent mass (tridiagonal) and a supported spring chain: against L (I - e^{-2tS}) L^T, S = L^{-1} C L^{-T}.
  {
    const int n = 12;
    Eigen::MatrixXd md = Eigen::MatrixXd::Zero(n, n), kd = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) {
      md(i, i) = 4.0 / 6.0 * (1.0 + 0.1 * i);
      kd(i, i) = 2.0 * (1.0 + 0.3 * i);
      if (i + 1 < n) {
        md(i, i + 1) = md(i + 1, i) = 1.0 / 6.0;
        kd(i, i + 1) = kd(i + 1, i) = -(1.0 + 0.3 * i);
      }
    }
    const SparseColMajor ms = md.sparseView(), ks = kd.sparseView();
    const Eigen::LLT<Eigen::MatrixXd> llt(md);
    const Eigen::MatrixXd l = llt.matrixL();
    for (const double alpha : {0.0, 0.2})
      for (const double t : {0.01, 0.7}) {
        const double beta = 0.05;
        const LinearStructure<ConsistentMass> s(ConsistentMass(ms), ks, Eigen::VectorXd(), alpha, beta);
        const Eigen::MatrixXd c = alpha * md + beta * kd;
        const Eigen::MatrixXd sym = l.triangularView<Eigen::Lower>().solve(
            l.triangularView<Eigen::Lower>().solve(c).transpose());
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (sym + sym.transpose()));
        const Eigen::VectorXd w = (-(-2.0 * t * eig.eigenvalues().array()).exp() + 1.0).matrix();
        const Eigen::MatrixXd lv = l * eig.eigenvectors();
        const Eigen::MatrixXd expected = lv * w.asDiagonal() * lv.transpose();
        CHECK((noise_matrix(s, t) - expected).cwiseAbs().maxCoeff() <= 1e-11 * expected.cwiseAbs().maxCoeff());
      }
  }

  // A chain's damping (M = m I): N N^T = m (I - e^{-2tA}), A = eps D / m, D built here from its dashpots and
  // site friction, for each shape of A (blocks of adjacent dashpots; friction on some sites; on every site).
  {
    const int n = 9;
    const double m = 1.7, eps = 0.8, t = 0.35;
    struct Case { std::vector<int> bonds; std::vector<double> bond_c; std::vector<int> sites; std::vector<double> site_c; };
    const Case cases[] = {
        {{0, 2, 3, 4, 7}, {0.5, 1.0, 2.0, 0.3, 4.0}, {5}, {0.7}},  // a wall dashpot, a block of three bonds, ...
        {{}, {}, {1, 4, 8}, {0.5, 2.0, 0.1}},
        {{}, {}, {0, 1, 2, 3, 4, 5, 6, 7, 8}, {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9}},
    };
    for (const Case& c : cases) {
      const ChainDamping damping(ChainBoundary::fixed, n, m, eps, c.bonds, c.bond_c, c.sites, c.site_c);
      Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, n);
      for (std::size_t k = 0; k < c.bonds.size(); ++k) {
        Eigen::VectorXd g = Eigen::VectorXd::Zero(n);  // bond b: +1 at site b, -1 at site b - 1 (walls: none)
        if (c.bonds[k] < n) g[c.bonds[k]] += 1.0;
        if (c.bonds[k] >= 1) g[c.bonds[k] - 1] -= 1.0;
        d += c.bond_c[k] * g * g.transpose();
      }
      for (std::size_t k = 0; k < c.sites.size(); ++k) d(c.sites[k], c.sites[k]) += c.site_c[k];
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(eps / m * d);
      const Eigen::VectorXd w = (-(-2.0 * t * eig.eigenvalues().array()).exp() + 1.0).matrix();
      const Eigen::MatrixXd expected = m * eig.eigenvectors() * w.asDiagonal() * eig.eigenvectors().transpose();
      const auto f = damping.factors(t);
      Eigen::MatrixXd noise(n, n);
      const Eigen::VectorXd q = Eigen::VectorXd::Zero(n);
      for (int j = 0; j < n; ++j) {
        Eigen::VectorXd p = Eigen::VectorXd::Zero(n);
        damping.add_noise(q, f, ScalarMass(m), 1.0, Eigen::VectorXd(Eigen::VectorXd::Unit(n, j)), p);
        noise.col(j) = p;
      }
      CHECK((noise * noise.transpose() - expected).cwiseAbs().maxCoeff() <= 1e-13);
    }
  }

  if (test::failures) std::printf("%d check(s) failed\n", test::failures);
  return test::failures ? 1 : 0;
}
