// D = c M with a scalar mass: the damping operator A = eps D M^{-1} is a I with
// a = eps c. Every direction of p decays at the same rate.
#pragma once

#include "raydamp/damping/decay_factors.hpp"

namespace raydamp {

struct IsotropicDamping {
  double a = 0.0;  // the single eigenvalue of A = eps D M^{-1}

  DecayFactors factors(double t) const { return decay_factors(a, t); }

  // The largest eigenvalue of A (the amplification guard's rho).
  double spectral_radius() const { return a; }
  // A = a I decays every direction of p alike, so a momentum map J = p . xi(q) of a
  // symmetry of V decays under the exact flow as J(t) = J(0) e^{-a t}
  // (the step loop's momentum drift measures the distance from that law).
  double momentum_decay_rate() const { return a; }

  // p <- exp(-t A) p: the exact flow of eps Y (f = factors(t)), as p + (e^{-ta} - 1) p. The factor
  // e^{-ta} rounded to a double is off by up to half an ulp, the same way at every step: over 10^6 steps
  // p would decay at a rate off by 1e-16 / (t a) relative (L_z of a damped pendulum 1e-10 from its law);
  // e^{-ta} - 1 rounds relative to its own small size, so the decay's only error is the addition's
  // rounding, unbiased (2e-14 after those 10^6 steps).
  template <class Q, class P>
  void decay(const Q&, const DecayFactors& f, P& p) const { p += f.expm1 * p; }

  // p <- exp(-t A) p - t phi1(-t A) g: the exact flow of p' = -g - A p with q
  // (and so g = grad V(q)) frozen; exp(-tA) p as in decay().
  template <class Q, class G, class P>
  void decay_affine(const Q&, const DecayFactors& f, const G& g, P& p) const { p += f.expm1 * p - f.t_phi1 * g; }

  // p += sigma sqrt(1 - e^{-2ta}) M^{1/2} xi: the noise of the exact OU flow with A = a I, whose
  // covariance is kT (M - E M E^T) = kT (1 - e^{-2ta}) M (sigma = sqrt(kT), xi standard normal).
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q&, const DecayFactors& f, const Mass& mass, double sigma, const X& xi, P& p) const {
    mass.add_root_product(sigma * f.noise, xi, p);
  }

  // out = A p: the damping force is -out.
  template <class Q, class P, class O>
  void rate(const Q&, const P& p, O& out) const { out.noalias() = a * p; }

  // x <- (I + c A)^{-1} x: the one linear solve of an implicit Runge-Kutta stage.
  template <class Q, class X>
  void solve_shifted(const Q&, double c, X& x) const { x /= 1.0 + c * a; }
};

}  // namespace raydamp
