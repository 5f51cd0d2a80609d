// Interacting planets around a central body, in Jacobi coordinates, with drag on chosen planets.
//
// Bodies 0 (the central body, mass m_0) and 1..N (planets, m_i), gravitational constant G. With
// eta_i = m_0 + ... + m_i, Jacobi coordinates put planet i relative to the centre of mass of the bodies
// inside it: Q_i = x_i - X_{i-1}, X_{i-1} = (m_0 x_0 + ... + m_{i-1} x_{i-1}) / eta_{i-1}, and
// P_i = m'_i dQ_i/dt with the reduced mass m'_i = m_i eta_{i-1} / eta_i. The transformation is linear and
// point-wise, so (Q, P) are canonical, and with the centre of mass at rest (dropped from the state)
//   H = sum_i |P_i|^2 / (2 m'_i) + V(x(Q)),   V = -sum_{j<k} G m_j m_k / |x_j - x_k|.
// Wisdom & Holman (1991) split H = H_kepler + H_interaction with
//   H_kepler = sum_i |P_i|^2 / (2 m'_i) - G m_i eta_{i-1} / |Q_i|   (a Kepler problem per planet,
//              mu_i = G m_i eta_{i-1} / m'_i = G eta_i),
//   H_interaction = V(x(Q)) + sum_i G m_i eta_{i-1} / |Q_i|         (a function of Q alone).
// Jacobi rather than democratic heliocentric coordinates because this is a two-part split, a drift and
// a kick, which is what 3s, 2s and their compositions step; democratic heliocentric coordinates add a
// third part, |sum P|^2 / (2 m_0), a flow of Q by the momenta that is neither.
//
// Drag: planet i's Jacobi momentum decays at its own rate, P_i' = ... - eps_i P_i (D = M, A diagonal):
// in the inertial frame that is the force -eps_i P_i on planet i and +eps_i P_i m_j / eta_{i-1} on each
// inner body j (drag relative to the inner bodies' centre of mass, the total momentum kept). For the
// innermost planet it is drag on the heliocentric velocity, its reaction on the central body.
// The exact damping flow scales each planet's block of P by e^{-t eps_i}.
//
// `gradient` is the kick's force, grad H_interaction; `potential` the whole V, so the recorded energy is H.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/damping/decay_factors.hpp"
#include "raydamp/flows/kepler.hpp"
#include "raydamp/flows/kepler_lanes.hpp"
#include "raydamp/state.hpp"
#include "raydamp/thread_scratch.hpp"

namespace raydamp {

// M = diag(m'_i I_d): each planet's block has its reduced mass.
struct JacobiMass {
  Eigen::VectorXd m, inverse;  // per coordinate

  template <class P, class V>
  void velocity(const P& p, V& v) const { v.noalias() = inverse.cwiseProduct(p); }
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const { p += c * m.cwiseSqrt().cwiseProduct(x); }
  template <class P>
  double kinetic(const P& p) const { return 0.5 * p.cwiseProduct(inverse).dot(p); }
};

// The drag's directions (Planets::drag): along each planet's whole momentum (isotropic, D = M), or only
// its component along Q_i (a radial dashpot) or across it (a tangential one). Radial drag exerts no torque
// about the centre, so the angular momentum decays at the tangential rate alone. Or along fixed axes:
// P_i' = -eps_i A P_i with A a symmetric positive semi-definite d x d matrix in the inertial frame
// (D = eps_i m'_i A per planet, symmetric since each block's mass is a scalar); A = e_z e_z^T damps the
// vertical momentum alone, and so the inclination, exerting no torque about z (L_z is kept).
enum class DragDirection { isotropic = 0, radial = 1, tangential = 2, axes = 3 };

inline DragDirection drag_direction(int code) {
  if (code < 0 || code > 3)
    throw std::invalid_argument("drag: must be isotropic (0), radial (1), tangential (2) or a matrix (3)");
  return static_cast<DragDirection>(code);
}

// A = V diag(lambda) V^T of a drag matrix, checked: d x d, finite, symmetric to 1e-12 of its largest entry,
// and its eigenvalues >= -1e-12 of the largest (those within it are taken as 0).
struct DragAxes {
  Eigen::Matrix3d V = Eigen::Matrix3d::Identity();
  Eigen::Vector3d lambda = Eigen::Vector3d::Zero();

  static DragAxes of(const Eigen::MatrixXd& A, int d) {
    if (A.rows() != d || A.cols() != d)
      throw std::invalid_argument("drag: a matrix must be " + std::to_string(d) + " x " + std::to_string(d) + ", got " +
                                  std::to_string(A.rows()) + " x " + std::to_string(A.cols()));
    if (!A.allFinite()) throw std::invalid_argument("drag: the matrix must be finite");
    const double size = A.cwiseAbs().maxCoeff();
    if ((A - A.transpose()).cwiseAbs().maxCoeff() > 1e-12 * size)
      throw std::invalid_argument("drag: the matrix must be symmetric (D = eps m A is a damping matrix)");
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (A + A.transpose()));
    if (eig.eigenvalues().minCoeff() < -1e-12 * size)
      throw std::invalid_argument("drag: the matrix must be positive semi-definite (an eigenvalue is " +
                                  std::to_string(eig.eigenvalues().minCoeff()) + "); a negative one would feed energy in");
    DragAxes axes;
    axes.V.topLeftCorner(d, d) = eig.eigenvectors();
    for (int k = 0; k < d; ++k) {
      const double lambda = eig.eigenvalues()[k];
      axes.lambda[k] = std::abs(lambda) <= 1e-12 * size ? 0.0 : lambda;
    }
    return axes;
  }
};

// A = eps_i (a_r r r^T + a_t (I - r r^T)) on planet i's block, r = Q_i / |Q_i| at the frozen q: planet i's
// momentum decays at `rates[i]` across r (and along it too when isotropic) and at `radial[i]` along r. The
// two projectors commute with A, so each flow is its scalar flow on each part: p's part along r with the
// radial factors, the rest with the tangential ones.
struct PlanetDrag {
  std::vector<double> rates;   // per planet: across Q_i (all of P_i when isotropic; eps_i with axes)
  std::vector<double> radial;  // per planet: along Q_i
  int d = 2;
  bool same = false;          // isotropic, every rate equal: one factor for all of p (1,000 test particles: one exp)
  bool isotropic = true;
  bool fixed_axes = false;    // P_i' = -eps_i A P_i, A = V diag(lambda) V^T (DragAxes)
  DragAxes axes;

  void set(std::vector<double> r, int d_, DragDirection direction = DragDirection::isotropic,
           const Eigen::MatrixXd& A = Eigen::MatrixXd()) {
    d = d_;
    fixed_axes = direction == DragDirection::axes;
    if (fixed_axes) axes = DragAxes::of(A, d);
    isotropic = direction == DragDirection::isotropic;
    radial = direction == DragDirection::tangential ? std::vector<double>(r.size(), 0.0) : r;
    rates = direction == DragDirection::radial ? std::vector<double>(r.size(), 0.0) : std::move(r);
    same = isotropic && uniform();
  }

  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();
    std::vector<DecayFactors> planet;  // one per planet, or one for all when `same`
    std::vector<DecayFactors> along;   // along Q_i, one per planet (none when isotropic); d per planet, one per axis
  };
  Factors factors(double t) const {
    Factors f;
    f.t = t;
    if (same) {
      f.planet.assign(1, decay_factors(rates.front(), t));
      return f;
    }
    if (fixed_axes) {
      for (double a : rates)
        for (int k = 0; k < d; ++k) f.along.push_back(decay_factors(a * axes.lambda[k], t));
      return f;
    }
    f.planet.reserve(rates.size());
    for (double a : rates) f.planet.push_back(decay_factors(a, t));
    if (!isotropic)
      for (double a : radial) f.along.push_back(decay_factors(a, t));
    return f;
  }
  double spectral_radius() const {
    const double scale = fixed_axes ? axes.lambda.maxCoeff() : 1.0;
    double rho = 0.0;
    for (const auto* v : {&rates, &radial})
      for (double a : *v) rho = std::max(rho, a * scale);
    return rho;
  }
  // With one tangential rate for every planet, L = sum Q_i x P_i decays as e^{-eps t} under the exact flow.
  double momentum_decay_rate() const { return rates.front(); }
  // Whether L has that law: not along fixed axes (A = e_z e_z^T keeps L_z and not L_x, L_y).
  bool uniform() const {
    return !fixed_axes &&
           std::all_of(rates.begin(), rates.end(), [this](double a) { return a == rates.front(); });
  }

  template <class Q, class P>
  void decay(const Q& q, const Factors& f, P& p) const {
    // p + (e^{-ta} - 1) p, not e^{-ta} p: unbiased (damping/isotropic_damping.hpp)
    if (same) {
      p += f.planet[0].expm1 * p;
      return;
    }
    for (std::size_t i = 0; i < rates.size(); ++i) {
      auto pi = p.segment(d * i, d);
      if (fixed_axes) {
        Small y = axes_of(pi);
        for (int k = 0; k < d; ++k) y[k] *= f.along[d * i + k].expm1;
        pi += from_axes(y);
        continue;
      }
      if (isotropic) {
        pi += f.planet[i].expm1 * pi;
        continue;
      }
      const auto r = unit(q, i);
      const double along = pi.dot(r);
      pi += f.planet[i].expm1 * pi + ((f.along[i].expm1 - f.planet[i].expm1) * along) * r;
    }
  }
  template <class Q, class G, class P>
  void decay_affine(const Q& q, const Factors& f, const G& g, P& p) const {
    if (same) {
      p += f.planet[0].expm1 * p - f.planet[0].t_phi1 * g;
      return;
    }
    for (std::size_t i = 0; i < rates.size(); ++i) {
      auto pi = p.segment(d * i, d);
      const auto gi = g.segment(d * i, d);
      if (fixed_axes) {
        Small y = axes_of(pi);
        const Small gy = axes_of(gi);
        for (int k = 0; k < d; ++k) y[k] = f.along[d * i + k].expm1 * y[k] - f.along[d * i + k].t_phi1 * gy[k];
        pi += from_axes(y);
        continue;
      }
      const DecayFactors& k = f.planet[i];
      if (isotropic) {
        pi += k.expm1 * pi - k.t_phi1 * gi;
        continue;
      }
      const DecayFactors& a = f.along[i];
      const auto r = unit(q, i);
      const double p_along = pi.dot(r), g_along = gi.dot(r);
      pi += k.expm1 * pi - k.t_phi1 * gi + ((a.expm1 - k.expm1) * p_along - (a.t_phi1 - k.t_phi1) * g_along) * r;
    }
  }
  // Noise of the exact OU flow per planet: covariance kT (1 - e^{-2 t a}) m'_i along each direction.
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q& q, const Factors& f, const Mass& mass, double sigma, const X& xi, P& p) const {
    for (std::size_t i = 0; i < rates.size(); ++i) {
      if (fixed_axes) {
        // V diag(noise_k) V^T xi_i: covariance V diag(noise_k^2) V^T = kT (I - e^{-2 t eps_i A}) per unit mass
        Small y = axes_of(xi.segment(d * i, d));
        for (int k = 0; k < d; ++k) y[k] *= f.along[d * i + k].noise;
        const Small n = from_axes(y);
        for (int j = 0; j < d; ++j) {
          const int k = d * static_cast<int>(i) + j;
          p[k] += sigma * std::sqrt(mass.m[k]) * n[j];
        }
        continue;
      }
      const double across = f.planet[same ? 0 : i].noise;
      if (isotropic) {
        for (int j = 0; j < d; ++j) {
          const int k = d * static_cast<int>(i) + j;
          p[k] += sigma * across * std::sqrt(mass.m[k]) * xi[k];
        }
        continue;
      }
      const Small r = unit(q, i);
      const double along_xi = xi.segment(d * i, d).dot(r), extra = f.along[i].noise - across;
      for (int j = 0; j < d; ++j) {
        const int k = d * static_cast<int>(i) + j;
        p[k] += sigma * std::sqrt(mass.m[k]) * (across * xi[k] + extra * along_xi * r[j]);
      }
    }
  }
  template <class Q, class P, class O>
  void rate(const Q& q, const P& p, O& out) const {
    for (std::size_t i = 0; i < rates.size(); ++i) {
      if (fixed_axes) {
        Small y = axes_of(p.segment(d * i, d));
        for (int k = 0; k < d; ++k) y[k] *= rates[i] * axes.lambda[k];
        out.segment(d * i, d) = from_axes(y);
        continue;
      }
      out.segment(d * i, d) = rates[i] * p.segment(d * i, d);
      if (isotropic) continue;
      const auto r = unit(q, i);
      out.segment(d * i, d) += ((radial[i] - rates[i]) * p.segment(d * i, d).dot(r)) * r;
    }
  }
  template <class Q, class X>
  void solve_shifted(const Q& q, double c, X& x) const {
    for (std::size_t i = 0; i < rates.size(); ++i) {
      auto xi = x.segment(d * i, d);
      if (fixed_axes) {
        Small y = axes_of(xi);
        for (int k = 0; k < d; ++k) y[k] /= 1.0 + c * rates[i] * axes.lambda[k];
        xi = from_axes(y);
        continue;
      }
      if (isotropic) {
        xi /= 1.0 + c * rates[i];
        continue;
      }
      const double across = 1.0 / (1.0 + c * rates[i]);
      const auto r = unit(q, i);
      const double along = xi.dot(r);
      xi = across * xi + ((1.0 / (1.0 + c * radial[i]) - across) * along) * r;
    }
  }

 private:
  // Q_i / |Q_i|: the direction of planet i's radial dashpot, on the stack (at most 3 components). Copied,
  // then normalised in place: normalized() of a run-time-size segment makes a heap VectorXd first.
  using Small = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;
  template <class Q>
  Small unit(const Q& q, std::size_t i) const {
    Small r = q.segment(d * i, d);
    r.normalize();
    return r;
  }
  // V^T x and V y for one planet's block, on the stack
  template <class X>
  Small axes_of(const X& x) const {
    Small y(d);
    for (int k = 0; k < d; ++k) {
      double s = 0.0;
      for (int j = 0; j < d; ++j) s += axes.V(j, k) * x[j];
      y[k] = s;
    }
    return y;
  }
  Small from_axes(const Small& y) const {
    Small x(d);
    for (int j = 0; j < d; ++j) {
      double s = 0.0;
      for (int k = 0; k < d; ++k) s += axes.V(j, k) * y[k];
      x[j] = s;
    }
    return x;
  }
};

// Test particles (models/kepler.hpp) are this kind too, with `interacting` false: each body its own
// Kepler problem about mu, no kick, one drag rate. One C++ kind for both instantiates the step loop
// (every method, single runs and ensembles) once: a second kind cost bind_kepler.cpp 10 s of compile.
struct TestParticles {};

struct Planets {
  static constexpr const char* name = "kepler";  // its drift is the Kepler flow (catalogue.hpp's refusals name it)
  static constexpr int dim = Eigen::Dynamic;
  static constexpr int n_momenta = -1;  // kDynamicMomenta: the angular momentum when the drag is uniform
  using Vec = Vector<dim>;
  static constexpr bool free_drift = false;  // the drift is the Kepler flow (catalogue.hpp)

  double G;
  int d;
  int planets;
  std::vector<double> masses;  // m_0 (the central body), m_1..m_N
  std::vector<double> eta;     // eta_i = m_0 + ... + m_i
  std::vector<double> mu;      // per planet, G eta_i
  double eps;                  // the largest drag rate (0: no drag; the methods that ignore damping check it)
  bool interacting = true;     // false: test particles about a fixed central body (no kick)
  // The momentum maps are listed per group of planets / groups consecutive bodies: an ensemble's members
  // that run as one model's particles (ensemble/lanes_kepler.hpp) each keep their own L, so the step
  // loop's drift from the law is the largest of the members' own.
  int groups = 1;
  JacobiMass mass;
  PlanetDrag damping;
  DragDirection drag = DragDirection::isotropic;
  Eigen::MatrixXd drag_matrix;  // A, with drag == axes (else empty)

  // `particles` test particles of mass m about a fixed central body of G M = mu, drag eps on each:
  // H = sum_i |p_i|^2 / (2 m) - mu m / |q_i|.
  Planets(TestParticles, double mu_, double m, int d_, int particles, double eps_,
          DragDirection drag_ = DragDirection::isotropic, Eigen::MatrixXd matrix = Eigen::MatrixXd())
      : G(mu_), d(d_), planets(particles), eps(eps_), interacting(false), drag(drag_), drag_matrix(std::move(matrix)) {
    if (!(mu_ > 0.0) || !std::isfinite(mu_))
      throw std::invalid_argument("mu: must be a finite number > 0 (G times the central mass)");
    if (!(m > 0.0) || !std::isfinite(m)) throw std::invalid_argument("mass: must be a finite number > 0");
    if (d != 2 && d != 3) throw std::invalid_argument("dim: must be 2 or 3");
    if (planets < 1) throw std::invalid_argument("particles: must be >= 1");
    if (!(eps >= 0.0) || !std::isfinite(eps)) throw std::invalid_argument("eps: must be finite and >= 0");
    mu.assign(planets, mu_);
    mass.m = Eigen::VectorXd::Constant(d * planets, m);
    mass.inverse = Eigen::VectorXd::Constant(d * planets, 1.0 / m);
    damping.set(std::vector<double>(planets, eps), d, drag, drag_matrix);
  }

  Planets(double G_, double central, std::vector<double> planet_masses, int d_, std::vector<double> rates,
          DragDirection drag_ = DragDirection::isotropic, Eigen::MatrixXd matrix = Eigen::MatrixXd())
      : G(G_), d(d_), planets(static_cast<int>(planet_masses.size())), drag(drag_), drag_matrix(std::move(matrix)) {
    if (!(G > 0.0) || !std::isfinite(G)) throw std::invalid_argument("G: must be a finite number > 0");
    if (!(central > 0.0) || !std::isfinite(central))
      throw std::invalid_argument("central_mass: must be a finite number > 0");
    if (d != 2 && d != 3) throw std::invalid_argument("dim: must be 2 or 3");
    if (planets < 1) throw std::invalid_argument("masses: at least one planet");
    for (int i = 0; i < planets; ++i)
      if (!(planet_masses[i] > 0.0) || !std::isfinite(planet_masses[i]))
        throw std::invalid_argument("masses[" + std::to_string(i) + "]: must be a finite number > 0");
    if (static_cast<int>(rates.size()) != planets)
      throw std::invalid_argument("eps: expected one drag rate per planet (" + std::to_string(planets) + ")");
    for (int i = 0; i < planets; ++i)
      if (!(rates[i] >= 0.0) || !std::isfinite(rates[i]))
        throw std::invalid_argument("eps[" + std::to_string(i) + "]: must be finite and >= 0");
    masses.push_back(central);
    masses.insert(masses.end(), planet_masses.begin(), planet_masses.end());
    eta.push_back(central);
    for (int i = 1; i <= planets; ++i) eta.push_back(eta.back() + masses[i]);
    mass.m.resize(d * planets);
    for (int i = 1; i <= planets; ++i) {
      mu.push_back(G * eta[i]);
      mass.m.segment(d * (i - 1), d).setConstant(masses[i] * eta[i - 1] / eta[i]);
    }
    mass.inverse = mass.m.cwiseInverse();
    damping.set(std::move(rates), d, drag, drag_matrix);
    eps = damping.spectral_radius();
  }

  int size() const { return d * planets; }
  int momentum_count() const { return damping.uniform() ? (d == 2 ? 1 : 3) * groups : 0; }

  // Positions relative to the central body, x_0 = 0, from Jacobi Q: x_i = X_{i-1} + Q_i with
  // X_i = X_{i-1} + (m_i / eta_i) Q_i (the inner centre of mass, relative to body 0).
  template <class Out>
  void heliocentric(const Vec& q, Out& x) const {
    double centre[3] = {0.0, 0.0, 0.0};
    for (int j = 0; j < d; ++j) x[j] = 0.0;
    for (int i = 1; i <= planets; ++i) {
      const double w = masses[i] / eta[i];
      for (int j = 0; j < d; ++j) {
        const double qi = q[d * (i - 1) + j];
        x[d * i + j] = centre[j] + qi;
        centre[j] += w * qi;
      }
    }
  }

  double potential(const Vec& q) const {
    if (!interacting) {
      double v = 0.0;
      for (int i = 0; i < planets; ++i) v -= mu[i] * mass.m[d * i] / q.segment(d * i, d).norm();
      return v;
    }
    Eigen::VectorXd& x = thread_scratch(kScratchT0, d * (planets + 1));
    heliocentric(q, x);
    double v = 0.0;
    for (int a = 0; a <= planets; ++a)
      for (int b = a + 1; b <= planets; ++b) v -= G * masses[a] * masses[b] / (x.segment(d * b, d) - x.segment(d * a, d)).norm();
    return v;
  }

  // grad_Q H_interaction. The inertial accelerations a_j of every body, turned into Jacobi ones,
  // A_i = a_i - (m_0 a_0 + ... + m_{i-1} a_{i-1}) / eta_{i-1}, are Q_i'' under V; less the Kepler part
  // -mu_i Q_i / |Q_i|^3 they are the interaction's, and grad_{Q_i} H_interaction = -m'_i (A_i + mu_i Q_i / |Q_i|^3).
  // For one planet the two cancel: no kick.
  void gradient(const Vec& q, Vec& g) const {
    if (!interacting) {
      g.setZero();
      return;
    }
    Eigen::VectorXd& x = thread_scratch(kScratchT0, d * (planets + 1));
    Eigen::VectorXd& a = thread_scratch(kScratchT1, d * (planets + 1));
    heliocentric(q, x);
    a.setZero();
    for (int j = 0; j <= planets; ++j)
      for (int k = j + 1; k <= planets; ++k) {
        double r2 = 0.0;
        for (int c = 0; c < d; ++c) {
          const double dx = x[d * k + c] - x[d * j + c];
          r2 += dx * dx;
        }
        const double inv3 = G / (r2 * std::sqrt(r2));
        for (int c = 0; c < d; ++c) {
          const double dx = (x[d * k + c] - x[d * j + c]) * inv3;
          a[d * j + c] += masses[k] * dx;
          a[d * k + c] -= masses[j] * dx;
        }
      }
    double sum[3] = {0.0, 0.0, 0.0};  // m_0 a_0 + ... + m_{i-1} a_{i-1}
    for (int c = 0; c < d; ++c) sum[c] = masses[0] * a[c];
    for (int i = 1; i <= planets; ++i) {
      const int k = d * (i - 1);
      double r2 = 0.0;
      for (int c = 0; c < d; ++c) r2 += q[k + c] * q[k + c];
      const double kepler = mu[i - 1] / (r2 * std::sqrt(r2));
      for (int c = 0; c < d; ++c) {
        const double jacobi = a[d * i + c] - sum[c] / eta[i - 1];
        g[k + c] = -mass.m[k] * (jacobi + kepler * q[k + c]);
        sum[c] += masses[i] * a[d * i + c];
      }
    }
  }
  // The kick: test particles have none (and skip forming a zero force).
  void kick(const Vec& q, Vec& p, double t) const {
    if (!interacting) return;
    Eigen::VectorXd& g = thread_scratch(kScratchT2, size());
    gradient(q, g);
    p -= t * g;
  }
  void hessian_product(const Vec&, const Vec&, Vec& out) const {
    if (!interacting) {
      out.setZero();
      return;
    }
    throw std::invalid_argument("hessian_product: not provided for planets (the sv modified energy it serves is that "
                                "of a kinetic + potential split, and this kind's split is Kepler + interaction)");
  }

  // The total angular momentum, sum_i Q_i x P_i (the Jacobi map is a point transformation, so this is
  // the barycentric one), listed when every planet has the same drag (then L(t) = L(0) e^{-eps t}); one
  // per group (see groups), each summed over its bodies in order.
  void momenta(const Vec& q, const Vec& p, double* out) const {
    if (!damping.uniform()) return;
    const int per = planets / groups;
    for (int g = 0; g < groups; ++g) {
      const int first = g * per, last = first + per;
      if (d == 2) {
        double lz = 0.0;
        for (int i = first; i < last; ++i) lz += q[2 * i] * p[2 * i + 1] - q[2 * i + 1] * p[2 * i];
        out[g] = lz;
        continue;
      }
      double* l = out + 3 * g;
      l[0] = l[1] = l[2] = 0.0;
      for (int i = first; i < last; ++i) {
        const int k = 3 * i;
        l[0] += q[k + 1] * p[k + 2] - q[k + 2] * p[k + 1];
        l[1] += q[k + 2] * p[k] - q[k] * p[k + 2];
        l[2] += q[k] * p[k + 1] - q[k + 1] * p[k];
      }
    }
  }

  // H_kepler's exact flow: each planet's Kepler flow with mu_i = G eta_i (in blocks of SIMD lanes,
  // flows/kepler_lanes.hpp, with the bits of one at a time).
  void drift(Vec& q, Vec& p, double t) const {
    kepler::drift_bodies(mu.data(), mass.m.data(), mass.inverse.data(), t, d, planets, q.data(), p.data());
  }
};

}  // namespace raydamp
