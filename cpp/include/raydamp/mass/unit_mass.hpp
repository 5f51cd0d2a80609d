// M = I: the mass of the paper's damped pendulum (section 4.3, M = 1). The velocity
// is p itself, so a drift is q += t p with no multiplication by 1 on the path from
// p to q (ScalarMass would multiply by its runtime inverse, 1.0).
#pragma once

namespace raydamp {

struct UnitMass {
  template <class P, class V>
  void velocity(const P& p, V& v) const { v = p; }

  // p += c M^{1/2} x.
  template <class X, class P>
  void add_root_product(double c, const X& x, P& p) const { p += c * x; }

  template <class P>
  double kinetic(const P& p) const { return 0.5 * p.squaredNorm(); }
};

}  // namespace raydamp
