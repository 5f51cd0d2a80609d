// On-site potentials U(q_i) of a chain: each site tied to its rest position, as in
// Klein-Gordon lattices (harmonic pinning, phi^4) and the Frenkel-Kontorova / discrete
// sine-Gordon chain. Each gives energy, force U' and stiffness U''; U(0) = U'(0) = 0.
// `none` marks the absent potential, which the sweeps skip at compile time so a chain
// without one runs exactly as before (not even a + 0.0 per site).
#pragma once

#include <cmath>

namespace raydamp {

enum class OnSiteKind { none, polynomial, sine };

struct NoOnSite {
  static constexpr bool none = true;
  double energy(double) const { return 0.0; }
  double force(double) const { return 0.0; }
  double stiffness(double) const { return 0.0; }
};

// U = k2 q^2/2 + k4 q^4/4: harmonic pinning (k4 = 0), phi^4 (k2 < 0: a double well).
struct PolynomialOnSite {
  static constexpr bool none = false;
  double k2 = 0.0, k4 = 0.0;
  double energy(double q) const { return q * q * (0.5 * k2 + 0.25 * k4 * q * q); }
  double force(double q) const { return q * (k2 + k4 * q * q); }
  double stiffness(double q) const { return k2 + 3.0 * k4 * q * q; }
};

// U = g (1 - cos q), written 2 g sin^2(q/2) so that small q loses no digits.
struct SineOnSite {
  static constexpr bool none = false;
  double g = 1.0;
  double energy(double q) const {
    const double s = std::sin(0.5 * q);
    return 2.0 * g * s * s;
  }
  double force(double q) const { return g * std::sin(q); }
  double stiffness(double q) const { return g * std::cos(q); }
};

struct ChainOnSite {
  OnSiteKind kind = OnSiteKind::none;
  PolynomialOnSite polynomial;
  SineOnSite sine;

  // f(potential) for the chain's on-site kind: one branch per call, outside every loop.
  template <class F>
  decltype(auto) visit(F&& f) const {
    switch (kind) {
      case OnSiteKind::polynomial: return f(polynomial);
      case OnSiteKind::sine: return f(sine);
      default: return f(NoOnSite{});
    }
  }
};

}  // namespace raydamp
