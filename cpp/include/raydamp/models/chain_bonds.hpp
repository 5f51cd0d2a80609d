// The bond potentials V(r) of a chain, in the stretch r (bond length minus its rest
// length), each with V(0) = V'(0) = 0 so that q = p = 0 is the ground state.
// Each gives energy V(r), force V'(r) and stiffness V''(r); `polynomial` says the
// force is a few multiplications, cheap enough to evaluate twice per bond (once for
// each site) in a loop the compiler vectorises, where a transcendental force is
// evaluated once per bond and carried to the next site.
#pragma once

#include <cmath>
#include <limits>

#include "raydamp/system/compiled_function.hpp"

namespace raydamp {

enum class BondKind { harmonic, fput, toda, morse, lennard_jones, expression };

// V = k r^2 / 2.
struct HarmonicBond {
  static constexpr bool polynomial = true;
  double k = 1.0;
  double energy(double r) const { return 0.5 * k * r * r; }
  double force(double r) const { return k * r; }
  double stiffness(double) const { return k; }
};

// Fermi-Pasta-Ulam-Tsingou: V = k r^2/2 + alpha r^3/3 + beta r^4/4.
struct FputBond {
  static constexpr bool polynomial = true;
  double k = 1.0, alpha = 0.0, beta = 0.0;
  double energy(double r) const { return r * r * (0.5 * k + r * (alpha / 3.0 + r * (0.25 * beta))); }
  double force(double r) const { return r * (k + r * (alpha + r * beta)); }
  double stiffness(double r) const { return k + r * (2.0 * alpha + r * (3.0 * beta)); }
};

// Toda: V = (a/b) (e^{-b r} - 1 + b r), so V'(r) = a (1 - e^{-b r}) and V''(0) = a b.
struct TodaBond {
  static constexpr bool polynomial = false;
  double a = 1.0, b = 1.0;
  double energy(double r) const { return (a / b) * (std::expm1(-b * r) + b * r); }
  double force(double r) const { return -a * std::expm1(-b * r); }
  double stiffness(double r) const { return a * b * std::exp(-b * r); }
};

// Morse: V = depth (1 - e^{-a r})^2, V''(0) = 2 depth a^2.
struct MorseBond {
  static constexpr bool polynomial = false;
  double depth = 1.0, a = 1.0;
  double energy(double r) const {
    const double u = -std::expm1(-a * r);
    return depth * u * u;
  }
  double force(double r) const {
    const double e = std::exp(-a * r);
    return 2.0 * depth * a * e * (1.0 - e);
  }
  double stiffness(double r) const {
    const double e = std::exp(-a * r);
    return 2.0 * depth * a * a * e * (2.0 * e - 1.0);
  }
};

// Lennard-Jones between neighbours at distance d = spacing + r (spacing: the
// minimum's distance): V = depth ((spacing/d)^12 - 2 (spacing/d)^6 + 1).
// V''(0) = 72 depth / spacing^2. At d <= 0 the force is not finite and the run stops.
struct LennardJonesBond {
  static constexpr bool polynomial = false;
  double depth = 1.0, spacing = 1.0;
  double energy(double r) const {
    const double s6 = six(r);
    return depth * (s6 * (s6 - 2.0) + 1.0);
  }
  double force(double r) const {
    const double s6 = six(r);
    return 12.0 * depth * s6 * (1.0 - s6) / (spacing + r);
  }
  double stiffness(double r) const {
    const double s6 = six(r), d = spacing + r;
    return depth * s6 * (156.0 * s6 - 84.0) / (d * d);
  }
  double six(double r) const {
    const double d = spacing + r;
    if (!(d > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    const double s = spacing / d, s2 = s * s;
    return s2 * s2 * s2;
  }
};

// A user's V(r): three functions of r compiled from one expression tree
// (python/raydamp/systems/chain.py through the systems' JIT).
struct ExpressionBond {
  static constexpr bool polynomial = false;
  CompiledFunction v, dv, d2v;
  double energy(double r) const { return call(v, r); }
  double force(double r) const { return call(dv, r); }
  double stiffness(double r) const { return call(d2v, r); }
  static double call(const CompiledFunction& f, double r) {
    double out;
    f(&out, &r);
    return out;
  }
};

}  // namespace raydamp
