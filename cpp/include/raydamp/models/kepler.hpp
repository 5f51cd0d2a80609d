// Test particles of mass m around a fixed central body, H = sum_i |p_i|^2 / (2m) - mu m / |q_i|, in
// 2 or 3 dimensions, split as H = H_kepler + V_interaction: the drift is the exact Kepler flow of each
// particle (flows/kepler.hpp), the kick the interaction (none between test particles), and the damping
// D = M (drag proportional to the velocity, A = eps I) has its exact flow. A splitting of this kind
// errs only by the commutators of the Kepler flow with the damping (and the interaction): O(eps h^2),
// where splitting Kepler itself as kinetic + potential errs by O(h^2) at every eps.
//
// `gradient` is the kick's force (the interaction, zero here), as every method's kick and
// kick_damp_rk stage need it to be; `potential` is the whole potential, so the recorded energy is H.
// A method that would step the kinetic part as a free drift (rksb's drift+damp stage, a Runge-Kutta
// method on the whole field, the implicit steps) is refused by `require_kepler_splitting`.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/flows/kepler.hpp"
#include "raydamp/mass/scalar_mass.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct Kepler {
  static constexpr const char* name = "kepler";
  static constexpr int dim = Eigen::Dynamic;
  static constexpr int n_momenta = -1;  // kDynamicMomenta: L_z in 2-D, (L_x, L_y, L_z) in 3-D
  using Vec = Vector<dim>;
  // The drift is the Kepler flow, not q += t M^{-1} p (catalogue.hpp's require_applicable).
  static constexpr bool free_drift = false;

  double mu;  // G times the central mass
  int d;      // 2 or 3
  int particles;
  double eps;
  ScalarMass mass;
  IsotropicDamping damping;

  Kepler(double mu_, double m, int d_, int particles_, double eps_)
      : mu(mu_), d(d_), particles(particles_), eps(eps_), mass(m, "mass") {
    if (!(mu > 0.0) || !std::isfinite(mu))
      throw std::invalid_argument("mu: must be a finite number > 0 (G times the central mass)");
    if (d != 2 && d != 3) throw std::invalid_argument("dim: must be 2 or 3");
    if (particles < 1) throw std::invalid_argument("particles: must be >= 1");
    if (!(eps >= 0.0) || !std::isfinite(eps)) throw std::invalid_argument("eps: must be finite and >= 0");
    damping.a = eps;  // A = eps D M^{-1} with D = M
  }

  int size() const { return d * particles; }
  int momentum_count() const { return d == 2 ? 1 : 3; }

  double potential(const Vec& q) const {
    double v = 0.0;
    for (int i = 0; i < particles; ++i) v -= mu * mass.m / q.segment(d * i, d).norm();
    return v;
  }
  // The interaction's gradient: test particles feel none (see the header).
  void gradient(const Vec&, Vec& g) const { g.setZero(); }
  void hessian_product(const Vec&, const Vec&, Vec& out) const { out.setZero(); }

  // The angular momentum about the central body, summed over the particles (a momentum map of
  // the rotations, which the Kepler flow keeps and the damping decays as e^{-eps t}).
  void momenta(const Vec& q, const Vec& p, double* out) const {
    if (d == 2) {
      double lz = 0.0;
      for (int i = 0; i < particles; ++i) lz += q[2 * i] * p[2 * i + 1] - q[2 * i + 1] * p[2 * i];
      out[0] = lz;
      return;
    }
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < particles; ++i) {
      const int k = 3 * i;
      out[0] += q[k + 1] * p[k + 2] - q[k + 2] * p[k + 1];
      out[1] += q[k + 2] * p[k] - q[k] * p[k + 2];
      out[2] += q[k] * p[k + 1] - q[k + 1] * p[k];
    }
  }

  // The exact Kepler flow of each particle over t (flows::drift calls this in place of q += t M^{-1} p).
  void drift(Vec& q, Vec& p, double t) const {
    const double inverse = mass.inverse, m = mass.m;
    if (d == 2) {
      for (int i = 0; i < particles; ++i) {
        Eigen::Vector2d x(q[2 * i], q[2 * i + 1]), v(inverse * p[2 * i], inverse * p[2 * i + 1]);
        kepler::drift(mu, t, x, v);
        q[2 * i] = x[0], q[2 * i + 1] = x[1];
        p[2 * i] = m * v[0], p[2 * i + 1] = m * v[1];
      }
      return;
    }
    for (int i = 0; i < particles; ++i) {
      const int k = 3 * i;
      Eigen::Vector3d x(q[k], q[k + 1], q[k + 2]), v(inverse * p[k], inverse * p[k + 1], inverse * p[k + 2]);
      kepler::drift(mu, t, x, v);
      for (int j = 0; j < 3; ++j) q[k + j] = x[j], p[k + j] = m * v[j];
    }
  }
  // The interaction's kick: none between test particles (a load, if any, is added by the flow).
  void kick(const Vec&, Vec&, double) const {}
};

}  // namespace raydamp
