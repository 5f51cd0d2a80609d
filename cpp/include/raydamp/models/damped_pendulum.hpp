// The damped pendulum of paper section 4.3: n = 1, M = 1, V = 1 - cos q, D = 1,
//   q' = p,  p' = -sin q - eps p.
#pragma once

#include <cmath>

#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/mass/unit_mass.hpp"
#include "raydamp/models/check.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct DampedPendulum {
  static constexpr int dim = 1;
  static constexpr int n_momenta = 0;  // no continuous symmetry
  using Vec = Vector<dim>;

  double eps;
  UnitMass mass;
  IsotropicDamping damping;

  explicit DampedPendulum(double eps_ = 0.01) : eps(eps_) {
    detail::require_nonnegative("eps", eps_);
    damping.a = eps_;  // A = eps D M^{-1} = eps
  }

  int size() const { return dim; }
  double potential(const Vec& q) const { return 1.0 - std::cos(q[0]); }
  void gradient(const Vec& q, Vec& g) const { g[0] = std::sin(q[0]); }
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const { out[0] = std::cos(q[0]) * v[0]; }
  void momenta(const Vec&, const Vec&, double*) const {}
};

}  // namespace raydamp
