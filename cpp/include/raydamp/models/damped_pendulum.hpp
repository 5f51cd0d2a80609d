// The damped pendulum of paper section 4.3: n = 1, M = 1, V = 1 - cos q, D = 1,
//   q' = p,  p' = -sin q - eps p.
#pragma once

#include <array>
#include <cmath>

#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/mass/unit_mass.hpp"
#include "raydamp/models/parameters.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct DampedPendulum {
  static constexpr const char* name = "damped_pendulum";
  static constexpr int dim = 1;
  static constexpr std::array<const char*, 0> momentum_names{};  // no continuous symmetry
  static constexpr int n_momenta = 0;
  // The parameters (models/parameters.hpp): the one list Python, the service and ensembles read.
  static constexpr std::array<Parameter, 1> parameters{{
      {"eps", 0.01, Rule::nonnegative, "damping coefficient, >= 0"},
  }};
  using Values = std::array<double, value_count(parameters)>;
  using Vec = Vector<dim>;

  Values values;  // as built, in table order
  double eps;
  UnitMass mass;
  IsotropicDamping damping;

  explicit DampedPendulum(const Values& values_ = default_values<DampedPendulum>())
      : values(check_values<DampedPendulum>(values_)), eps(value_of<DampedPendulum>(values, "eps")) {
    damping.a = eps;  // A = eps D M^{-1} = eps
  }
  explicit DampedPendulum(double eps_) : DampedPendulum(leading_values<DampedPendulum>(eps_)) {}

  int size() const { return dim; }
  double potential(const Vec& q) const { return 1.0 - std::cos(q[0]); }
  void gradient(const Vec& q, Vec& g) const { g[0] = std::sin(q[0]); }
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const { out[0] = std::cos(q[0]) * v[0]; }
  void momenta(const Vec&, const Vec&, double*) const {}
};

}  // namespace raydamp
