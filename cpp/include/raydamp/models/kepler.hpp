// Test particles of mass m around a fixed central body, H = sum_i |p_i|^2 / (2m) - mu m / |q_i|, in
// 2 or 3 dimensions, split as H = H_kepler + V_interaction: the drift is the exact Kepler flow of each
// particle (flows/kepler.hpp), the kick the interaction (none between test particles), and the damping
// D = M (drag proportional to the velocity, A = eps I) has its exact flow. A splitting of this kind
// errs only by the commutators of the Kepler flow with the damping (and the interaction): O(eps h^2),
// where splitting Kepler itself as kinetic + potential errs by O(h^2) at every eps.
//
// The kind is Planets (models/planets.hpp) with `interacting` false: its `gradient` is the kick's force
// (the interaction, zero here), as every method's kick and kick_damp_rk stage need it to be; `potential`
// is the whole potential, so the recorded energy is H. A method that would step the kinetic part as a
// free drift (rksb's drift+damp stage, a Runge-Kutta method on the whole field, the implicit steps) is
// refused (catalogue.hpp's require_applicable).
#pragma once

#include "raydamp/models/planets.hpp"

namespace raydamp {

// Test particles of mass m about G M = mu, in d = 2 or 3 dimensions, drag eps on each (bindings build
// the same Planets directly).
struct Kepler : Planets {
  Kepler(double mu, double m, int d, int particles, double eps) : Planets(TestParticles{}, mu, m, d, particles, eps) {}
};

}  // namespace raydamp
