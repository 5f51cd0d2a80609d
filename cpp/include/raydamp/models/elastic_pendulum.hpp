// The elastic 3-D pendulum of paper section 6.2 (equation elastic_pendulum):
//   q' = p/m,  p' = -k (1 - l/|q|) q + m g - eps q q^T p / (m |q|^2),
// M = m I, V = k/2 (l - |q|)^2 - m g.q, D(q) = q q^T/|q|^2 (damping only along
// the spring). Rotation about the z axis is a symmetry when g is vertical; its
// momentum map is J3 = q_x p_y - q_y p_x.
#pragma once

#include <array>
#include <cmath>

#include "raydamp/damping/radial_damping.hpp"
#include "raydamp/mass/scalar_mass.hpp"
#include "raydamp/models/check.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct ElasticPendulum {
  static constexpr int dim = 3;
  static constexpr int n_momenta = 1;  // J3
  using Vec = Vector<dim>;

  double eps, k, l;
  Vec g;
  ScalarMass mass;
  RadialDamping damping;
  Vec mg;  // m g, the constant part of -grad V

  ElasticPendulum(double eps_ = 0.1, double m_ = 1.0, double k_ = 1.0, double l_ = 1.0,
                  std::array<double, 3> g_ = {0.0, 0.0, -1.0})
      : eps(eps_), k(k_), l(l_), g(g_[0], g_[1], g_[2]), mass(m_) {
    detail::require_nonnegative("eps", eps_);
    detail::require_nonnegative("k", k_);
    detail::require_nonnegative("l", l_);
    for (int i = 0; i < 3; ++i)
      detail::require(std::isfinite(g_[i]), "g[" + std::to_string(i) + "]", "finite", g_[i]);
    damping.a = eps_ / m_;
    mg = m_ * g;
  }

  int size() const { return dim; }

  double potential(const Vec& q) const {
    const double stretch = q.norm() - l;
    return 0.5 * k * stretch * stretch - mg.dot(q);
  }

  void gradient(const Vec& q, Vec& grad) const {
    grad = (k * (1.0 - l / q.norm())) * q - mg;
  }

  // Hess V = k [(1 - l/r) I + l q q^T / r^3].
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const {
    const double r = q.norm();
    out = (k * (1.0 - l / r)) * v + (k * l * q.dot(v) / (r * r * r)) * q;
  }

  void momenta(const Vec& q, const Vec& p, double* out) const { out[0] = q[0] * p[1] - q[1] * p[0]; }
};

}  // namespace raydamp
