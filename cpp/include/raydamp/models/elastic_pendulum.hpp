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
#include "raydamp/models/parameters.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct ElasticPendulum {
  static constexpr const char* name = "elastic_pendulum";
  static constexpr int dim = 3;
  static constexpr std::array<const char*, 1> momentum_names{"J3"};
  static constexpr int n_momenta = 1;
  // The parameters (models/parameters.hpp): the one list Python, the service and ensembles read.
  static constexpr std::array<Parameter, 5> parameters{{
      {"eps", 0.1, Rule::nonnegative, "damping coefficient along the spring, >= 0"},
      {"m", 1.0, Rule::positive, "mass, > 0"},
      {"k", 1.0, Rule::nonnegative, "spring stiffness, >= 0"},
      {"l", 1.0, Rule::nonnegative, "spring rest length, >= 0"},
      {"g", {0.0, 0.0, -1.0}, Rule::finite, "gravity vector (3 components)"},
  }};
  using Values = std::array<double, value_count(parameters)>;
  using Vec = Vector<dim>;

  Values values;  // as built, in table order
  double eps, k, l;
  Vec g;
  ScalarMass mass;
  RadialDamping damping;
  Vec mg;  // m g, the constant part of -grad V

  explicit ElasticPendulum(const Values& values_ = default_values<ElasticPendulum>())
      : values(check_values<ElasticPendulum>(values_)),
        eps(value_of<ElasticPendulum>(values, "eps")),
        k(value_of<ElasticPendulum>(values, "k")),
        l(value_of<ElasticPendulum>(values, "l")),
        g(vector_of<ElasticPendulum, 3>(values, "g")),
        mass(value_of<ElasticPendulum>(values, "m")) {
    damping.a = eps / mass.m;
    mg = mass.m * g;
  }
  // Positionally, in table order, the parameters left out taking the table's defaults.
  explicit ElasticPendulum(double eps_) : ElasticPendulum(leading_values<ElasticPendulum>(eps_)) {}
  ElasticPendulum(double eps_, double m_, double k_, double l_, const std::array<double, 3>& g_)
      : ElasticPendulum(leading_values<ElasticPendulum>(eps_, m_, k_, l_, g_)) {}

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
