// D(q) = q q^T / |q|^2 with a scalar mass: damping acts only along q (a spring's
// axis, paper section 6.2). A = eps D M^{-1} = a u u^T with u = q/|q| and a = eps/m,
// so A is a rank-one projector scaled by a and every function of A acts on the
// radial component of p alone.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "raydamp/damping/decay_factors.hpp"

namespace raydamp {

struct RadialDamping {
  double a = 0.0;  // the nonzero eigenvalue of A, along u

  DecayFactors factors(double t) const { return decay_factors(a, t); }

  // The largest eigenvalue of A = a u u^T (the amplification guard's rho).
  double spectral_radius() const { return a; }

  // p <- exp(-t A) p: only the radial component decays. Times 1/|q|^2, not divided
  // by it: the division then runs beside q.p, off the step's serial chain (the
  // elastic pendulum's 3s step, about 1% faster; the result differs by rounding).
  template <class Q, class P>
  void decay(const Q& q, const DecayFactors& f, P& p) const {
    p += (f.expm1 * q.dot(p) * (1.0 / q.squaredNorm())) * q;
  }

  // p <- exp(-t A) p - t phi1(-t A) g. Tangentially phi1(0) = 1 (a plain kick);
  // radially the exact affine decay.
  template <class Q, class G, class P>
  void decay_affine(const Q& q, const DecayFactors& f, const G& g, P& p) const {
    const double radial = (f.expm1 * q.dot(p) - f.t_phi1_m1 * q.dot(g)) * (1.0 / q.squaredNorm());
    p += radial * q - f.t * g;
  }

  // The noise of the exact OU flow: A = a u u^T, so kT (M - E M E^T) = kT m (1 - e^{-2ta}) u u^T with the
  // scalar mass m: one normal number along u.
  Eigen::Index noise_count(Eigen::Index) const { return 1; }
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q& q, const DecayFactors& f, const Mass& mass, double sigma, const X& xi, P& p) const {
    const double r = q.norm();
    if (r > 0.0) p += (sigma * f.noise * std::sqrt(mass.m) * xi[0] / r) * q;  // D(0) is undefined: no noise there
  }

  template <class Q, class P, class O>
  void rate(const Q& q, const P& p, O& out) const {
    out.noalias() = (a * q.dot(p) / q.squaredNorm()) * q;
  }

  // (I + c a u u^T)^{-1} = I - (c a / (1 + c a)) u u^T.
  template <class Q, class X>
  void solve_shifted(const Q& q, double c, X& x) const {
    const double ca = c * a;
    x -= (ca / (1.0 + ca) * q.dot(x) / q.squaredNorm()) * q;
  }
};

}  // namespace raydamp
