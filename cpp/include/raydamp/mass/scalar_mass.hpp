// M = m I: the mass matrix of a particle system in Cartesian coordinates.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "raydamp/state.hpp"

namespace raydamp {

struct ScalarMass {
  double m = 1.0;
  double inverse = 1.0;

  explicit ScalarMass(double mass, const char* argument = "m") : m(mass), inverse(1.0 / mass) {
    if (!(mass > 0.0) || !std::isfinite(mass))
      throw std::invalid_argument(std::string(argument) + " must be a finite number > 0 (the mass), got " +
                                  std::to_string(mass));
  }

  // v = M^{-1} p (the velocity qdot = dH/dp).
  template <class P, class V>
  void velocity(const P& p, V& v) const { v.noalias() = inverse * p; }

  // p += c M^{1/2} x.
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const { p += (c * std::sqrt(m)) * x; }

  // T(p) = 1/2 p^T M^{-1} p.
  template <class P>
  double kinetic(const P& p) const { return 0.5 * inverse * p.squaredNorm(); }
};

}  // namespace raydamp
