// The exact Kepler drift (flows/kepler.hpp) and the Kepler kind (models/kepler.hpp): a circular orbit
// against its closed form, a drift undone by the drift back, the invariants a drift keeps, the drag's
// exact law for the angular momentum through the step loop, and the methods the kind refuses.
#include <cmath>
#include <tuple>

#include <unsupported/Eigen/MatrixFunctions>

#include "check.hpp"
#include "raydamp/models/kepler.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

namespace {

double energy(double mu, const Eigen::Vector2d& q, const Eigen::Vector2d& v) { return 0.5 * v.squaredNorm() - mu / q.norm(); }
double angular(const Eigen::Vector2d& q, const Eigen::Vector2d& v) { return q[0] * v[1] - q[1] * v[0]; }

// The OU noise p += sigma N xi of planet `planet`'s block (3 coordinates, every mass 1.7): N's columns from
// unit xi, so N N^T is the noise's covariance.
Eigen::Matrix3d noise_matrix(const PlanetDrag& drag, const Eigen::VectorXd& q, const PlanetDrag::Factors& f,
                             int planet) {
  const int n = static_cast<int>(q.size());
  struct Mass {
    Eigen::VectorXd m;
  } mass{Eigen::VectorXd::Constant(n, 1.7)};
  Eigen::Matrix3d N;
  for (int j = 0; j < 3; ++j) {
    Eigen::VectorXd column = Eigen::VectorXd::Zero(n);
    drag.add_noise(q, f, mass, 1.0, Eigen::VectorXd(Eigen::VectorXd::Unit(n, 3 * planet + j)), column);
    N.col(j) = column.segment<3>(3 * planet);
  }
  return N;
}

}  // namespace

int main() {
  // Stumpff functions against their closed forms, on both sides of 0 and across the series' reach.
  for (double x : {-300.0, -30.0, -3.9, -2.0, -0.05, 1e-9, 0.05, 0.3, 3.9, 7.0, 38.0}) {
    const kepler::Stumpff c = kepler::stumpff(x);
    const double s = std::sqrt(std::abs(x));
    const double c0 = x > 0 ? std::cos(s) : std::cosh(s);
    const double c1 = x > 0 ? std::sin(s) / s : std::sinh(s) / s;
    CHECK_NEAR(c.c0, c0, 1e-14 * std::max(1.0, std::abs(c0)));
    CHECK_NEAR(c.c1, c1, 1e-14 * std::max(1.0, std::abs(c1)));
    if (std::abs(x) > 0.01) {
      CHECK_NEAR(c.c2, (1.0 - c0) / x, 1e-13 * std::abs((1.0 - c0) / x));
      CHECK_NEAR(c.c3, (1.0 - c1) / x, 1e-13 * std::abs((1.0 - c1) / x));
    }
  }

  // A circular orbit of radius 1 (mu = 1): q(t) = (cos t, sin t), for steps short and long.
  for (double t : {1e-8, 0.01, 1.0, 3.0, -2.5, 100.0}) {
    Eigen::Vector2d q(1.0, 0.0), v(0.0, 1.0);
    kepler::drift(1.0, t, q, v);
    CHECK_NEAR(q[0], std::cos(t), 4e-14 * std::max(1.0, std::abs(t)));
    CHECK_NEAR(q[1], std::sin(t), 4e-14 * std::max(1.0, std::abs(t)));
    CHECK_NEAR(v[0], -std::sin(t), 4e-14 * std::max(1.0, std::abs(t)));
  }

  // Elliptic, near-parabolic, parabolic and hyperbolic orbits: the drift keeps energy and angular
  // momentum, and the drift back returns to the start.
  for (double e : {0.0, 0.5, 0.99, 1.0, 1.5, 4.0}) {
    const Eigen::Vector2d q0(1.0, 0.0), v0(0.0, std::sqrt(1.0 + e));
    for (double t : {0.01, 0.7, 5.0}) {
      Eigen::Vector2d q = q0, v = v0;
      kepler::drift(1.0, t, q, v);
      CHECK_NEAR(energy(1.0, q, v), energy(1.0, q0, v0), 1e-14 * std::max(1.0, std::abs(energy(1.0, q0, v0))));
      CHECK_NEAR(angular(q, v), angular(q0, v0), 1e-14);
      const double reach = 1.0 + q.norm();  // rounding on the way out is relative to how far it went
      kepler::drift(1.0, -t, q, v);
      CHECK_NEAR(q[0], q0[0], 2e-14 * reach);
      CHECK_NEAR(q[1], q0[1], 2e-14 * reach);
      CHECK_NEAR(v[1], v0[1], 2e-14 * reach);
    }
  }

  // Through the step loop: 3s with drag D = M on two particles keeps L = L0 e^{-eps t} to rounding.
  {
    const double eps = 1e-3;
    Kepler model(1.0, 2.0, 2, 2, eps);
    Eigen::VectorXd q(4), p(4);
    q << 1.0, 0.0, -2.0, 0.5;
    p << 0.0, 2.2, 0.3, -1.0;
    const double l0 = 2.0 * 1.1 + (-2.0 * -1.0 - 0.5 * 0.3);
    const ButcherTableau& heun = builtin_tableau("heun");
    RunResult r = integrate<ThreeTermSplitting>(model, heun, State<Eigen::Dynamic>{q, p}, RunSpec{0.05, 20000, 0.05, 2000});
    CHECK(r.status == Status::completed);
    const Trajectory& tr = r.trajectory;
    for (long i = 0; i < static_cast<long>(tr.rows()); ++i)
      CHECK_NEAR(tr.momentum[i], l0 * std::exp(-eps * tr.t[i]), 1e-12 * l0);
  }

  // A method that steps the kinetic part as a free drift would integrate another system: refused.
  {
    Kepler model(1.0, 1.0, 2, 1, 0.01);
    CHECK(test::throws([&] { require_applicable(method_entry("rksb"), model); }));
    CHECK(test::throws([&] { require_applicable(method_entry("rk4"), model); }));
    CHECK(test::throws([&] { require_applicable(method_entry("midpoint"), model); }));
    require_applicable(method_entry("3s"), model);
    require_applicable(method_entry("2s"), model);
    require_applicable(method_entry("rks"), model);
    require_applicable(method_entry("baoab"), model);
    CHECK(test::throws([] { Kepler(0.0, 1.0, 2, 1, 0.0); }));
    CHECK(test::throws([] { Kepler(1.0, -1.0, 2, 1, 0.0); }));
    CHECK(test::throws([] { Kepler(1.0, 1.0, 4, 1, 0.0); }));
  }

  // Radial and tangential drag: the damping flows against the matrix exponential of A = a_r r r^T +
  // a_t (I - r r^T) at the frozen q (p(t) = e^{-tA} p - t phi1(-tA) g, closed form per direction), the rate
  // A p and the shifted solve (I + cA)^{-1}.
  {
    const Eigen::VectorXd q = (Eigen::VectorXd(3) << 0.3, -1.1, 0.7).finished();
    const Eigen::VectorXd p0 = (Eigen::VectorXd(3) << 0.9, 0.2, -0.4).finished();
    const Eigen::VectorXd g = (Eigen::VectorXd(3) << -0.5, 0.8, 0.1).finished();
    const Eigen::Vector3d r = q.normalized();
    const Eigen::Matrix3d along = r * r.transpose(), across = Eigen::Matrix3d::Identity() - along;
    const double t = 0.7, c = 0.3;
    for (auto [direction, a_r, a_t] : {std::tuple{DragDirection::radial, 0.2, 0.0},
                                       std::tuple{DragDirection::tangential, 0.0, 0.2},
                                       std::tuple{DragDirection::isotropic, 0.2, 0.2}}) {
      PlanetDrag drag;
      drag.set({0.2}, 3, direction);
      const PlanetDrag::Factors f = drag.factors(t);
      auto phi = [&](double a) { return a == 0.0 ? t : -std::expm1(-a * t) / a; };
      const Eigen::Matrix3d e = std::exp(-a_r * t) * along + std::exp(-a_t * t) * across;
      const Eigen::Matrix3d tphi = phi(a_r) * along + phi(a_t) * across;
      Eigen::VectorXd p = p0;
      drag.decay(q, f, p);
      CHECK((p - e * p0).norm() <= 1e-15);
      p = p0;
      drag.decay_affine(q, f, g, p);
      CHECK((p - (e * p0 - tphi * g)).norm() <= 1e-15);
      Eigen::VectorXd out(3);
      drag.rate(q, p0, out);
      CHECK((out - (a_r * along + a_t * across) * p0).norm() <= 1e-15);
      Eigen::VectorXd x = p0;
      drag.solve_shifted(q, c, x);
      CHECK((x - (Eigen::Matrix3d::Identity() + c * (a_r * along + a_t * across)).inverse() * p0).norm() <= 1e-15);
      CHECK(drag.momentum_decay_rate() == a_t && drag.spectral_radius() == 0.2);
      // The OU noise's covariance N N^T is M - E M E^T, M = m I.
      const Eigen::Matrix3d N = noise_matrix(drag, q, f, 0);
      CHECK((N * N.transpose() - 1.7 * (Eigen::Matrix3d::Identity() - e * e.transpose())).norm() <= 1e-15);
    }
    // Two planets of different rates, isotropic: each block its own factor (the per-planet path, not `same`).
    {
      PlanetDrag drag;
      drag.set({0.2, 0.05}, 3);
      const PlanetDrag::Factors f = drag.factors(t);
      const Eigen::VectorXd q6 = (Eigen::VectorXd(6) << q, -q).finished();
      Eigen::VectorXd p6 = (Eigen::VectorXd(6) << p0, 2.0 * p0).finished();
      drag.decay(q6, f, p6);
      CHECK((p6.head(3) - std::exp(-0.2 * t) * p0).norm() <= 1e-15);
      CHECK((p6.tail(3) - std::exp(-0.05 * t) * 2.0 * p0).norm() <= 1e-15);
    }
    CHECK(test::throws([] { drag_direction(4); }));
  }

  // Drag along fixed axes, P_i' = -eps_i A P_i: the flows against Eigen's matrix exponential of -t eps_i A
  // (Pade, independent of the eigen-decomposition the flows use), on two planets with their own eps_i, for
  // a positive definite A (p(t) = e^{-tB} p - B^{-1} (I - e^{-tB}) g, B = eps A) and one with a zero
  // eigenvalue (A = e_z e_z^T: only the vertical momentum decays).
  {
    Eigen::MatrixXd spd(3, 3);
    spd << 2.0, 0.3, -0.4, 0.3, 1.0, 0.2, -0.4, 0.2, 0.5;
    const Eigen::MatrixXd vertical = Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose();
    const Eigen::VectorXd q = (Eigen::VectorXd(6) << 0.3, -1.1, 0.7, 1.5, 0.2, -0.3).finished();
    const Eigen::VectorXd p0 = (Eigen::VectorXd(6) << 0.9, 0.2, -0.4, -0.3, 0.6, 0.25).finished();
    const Eigen::VectorXd g = (Eigen::VectorXd(6) << -0.5, 0.8, 0.1, 0.2, -0.1, 0.4).finished();
    const double t = 0.7, c = 0.3, rates[2] = {0.2, 0.05};
    for (bool definite : {true, false}) {
      const Eigen::MatrixXd& A = definite ? spd : vertical;
      PlanetDrag drag;
      drag.set({rates[0], rates[1]}, 3, DragDirection::axes, A);
      CHECK(!drag.uniform());
      const PlanetDrag::Factors f = drag.factors(t);
      Eigen::VectorXd p = p0, pa = p0, out(6), x = p0;
      drag.decay(q, f, p);
      drag.decay_affine(q, f, g, pa);
      drag.rate(q, p0, out);
      drag.solve_shifted(q, c, x);
      for (int i = 0; i < 2; ++i) {
        const Eigen::Matrix3d B = rates[i] * A;
        const Eigen::Matrix3d e = (-t * B).exp();
        const Eigen::Vector3d pi = p0.segment<3>(3 * i), gi = g.segment<3>(3 * i);
        CHECK((p.segment<3>(3 * i) - e * pi).norm() <= 1e-15);
        CHECK((out.segment<3>(3 * i) - B * pi).norm() <= 1e-15);
        CHECK((x.segment<3>(3 * i) - (Eigen::Matrix3d::Identity() + c * B).inverse() * pi).norm() <= 1e-15);
        if (definite) CHECK((pa.segment<3>(3 * i) - (e * pi - B.inverse() * (Eigen::Matrix3d::Identity() - e) * gi)).norm() <= 1e-14);
        else CHECK((pa.segment<3>(3 * i) - (e * pi - Eigen::Vector3d(t * gi[0], t * gi[1], (1.0 - e(2, 2)) / rates[i] * gi[2]))).norm() <= 1e-15);
        // the OU noise's covariance N N^T is M - E M E^T, M = m I
        const Eigen::Matrix3d N = noise_matrix(drag, q, f, i);
        CHECK((N * N.transpose() - 1.7 * (Eigen::Matrix3d::Identity() - e * e.transpose())).norm() <= 4e-15);
      }
      CHECK(std::abs(drag.spectral_radius() - 0.2 * Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().maxCoeff()) <= 1e-15);
    }
    // refused: not square, not symmetric, indefinite, not finite
    PlanetDrag drag;
    CHECK(test::throws([&] { drag.set({0.1}, 3, DragDirection::axes, Eigen::MatrixXd::Identity(2, 2)); }));
    Eigen::MatrixXd bad = spd;
    bad(0, 1) = 0.31;
    CHECK(test::throws([&] { drag.set({0.1}, 3, DragDirection::axes, bad); }));
    bad = spd;
    bad(2, 2) = -1.0;
    CHECK(test::throws([&] { drag.set({0.1}, 3, DragDirection::axes, bad); }));
    bad = spd;
    bad(1, 1) = std::nan("");
    CHECK(test::throws([&] { drag.set({0.1}, 3, DragDirection::axes, bad); }));
  }
  return test::failures == 0 ? 0 : 1;
}
