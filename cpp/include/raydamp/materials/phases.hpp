// The smooth pieces of each material's force, for a step loop that locates kinks (materials/kinks.hpp).
//
// Between two kinks a material follows one smooth law sigma(d), its phase: elastic (phase 0), or yielding
// while d moves in direction s = +-1 (phase s for ElasticPlastic and Bilinear; Bouc-Wen, which has no
// elastic phase, has s * 1 while w = s z < 0 and s * 2 while w >= 0, the two sides of its rate's |z|). A
// phase holds while d stays in phase_range() and, for a yielding phase, while d moves in direction s; where
// either ends, the force has a kink and the phase changes (phase_after_exit, phase_after_reversal).
//
// Within a step the kicks read phase_force(): the phase's law, extended smoothly past its range. So every
// stage of a step, a composition's backward and overshooting ones included, sees one smooth force, and a
// step that ends at the kink keeps the method's order; the return map (materials.hpp) instead switches law
// wherever a stage's d falls. phase_state() is the state the phase's law reaches at d: what a located step
// commits. The laws of each phase:
//   ElasticPlastic: 0: k (d - d_p);  s: s fy.
//   Bilinear:       0: k (d - d_p);  s: b k d + s (1 - b) fy (the asymptote: |sigma - H d_p| = fy).
//   BoucWen:        s z(d) = w(s (d - d0) / d_y), w' = 1 - c w, c = beta - gamma (w < 0) or beta + gamma.
#pragma once

#include <cmath>
#include <limits>

#include "raydamp/materials/materials.hpp"

namespace raydamp::materials {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

inline int direction_of(int phase) { return phase > 0 ? 1 : -1; }

// --- ElasticPlastic -----------------------------------------------------------------------------------
inline int initial_phase(const ElasticPlastic&) { return 0; }

inline double phase_force(const ElasticPlastic& m, const ElasticPlastic::State& c, int phase, double d) {
  return phase == 0 ? m.k * (d - c.plastic) : direction_of(phase) * m.fy;
}

inline ElasticPlastic::State phase_state(const ElasticPlastic& m, const ElasticPlastic::State& c, int phase,
                                         double d) {
  if (phase == 0) return c;
  return {d - direction_of(phase) * m.fy / m.k};
}

inline Range phase_range(const ElasticPlastic& m, const ElasticPlastic::State& c, int phase) {
  return phase == 0 ? m.elastic_range(c) : Range{-kInfinity, kInfinity};
}

// --- Bilinear -----------------------------------------------------------------------------------------
inline int initial_phase(const Bilinear&) { return 0; }

inline double phase_force(const Bilinear& m, const Bilinear::State& c, int phase, double d) {
  return phase == 0 ? m.k * (d - c.plastic) : m.b * m.k * d + direction_of(phase) * (1.0 - m.b) * m.fy;
}

inline Bilinear::State phase_state(const Bilinear& m, const Bilinear::State& c, int phase, double d) {
  if (phase == 0) return c;
  const double sigma = phase_force(m, c, phase, d);
  return {d - sigma / m.k, sigma - direction_of(phase) * m.fy};  // d_p, and the back force a on |sigma - a| = fy
}

inline Range phase_range(const Bilinear& m, const Bilinear::State& c, int phase) {
  return phase == 0 ? m.elastic_range(c) : Range{-kInfinity, kInfinity};
}

// Elastic-plastic kinds: leaving the elastic range through its upper end yields upward; a yielding phase
// ends only where the drift reverses, and unloads elastically.
inline int phase_after_exit(const ElasticPlastic&, const ElasticPlastic::State&, int, bool upper) {
  return upper ? 1 : -1;
}
inline int phase_after_exit(const Bilinear&, const Bilinear::State&, int, bool upper) { return upper ? 1 : -1; }
inline int phase_after_reversal(const ElasticPlastic&, const ElasticPlastic::State&, int) { return 0; }
inline int phase_after_reversal(const Bilinear&, const Bilinear::State&, int) { return 0; }

// --- BoucWen ------------------------------------------------------------------------------------------
// A virgin Bouc-Wen spring (z = 0) starts loading upward on the w >= 0 side; a first motion downward is a
// reversal at the run's first instant (kinks.hpp checks the direction at each phase's start).
inline int initial_phase(const BoucWen&) { return 2; }

inline double bouc_wen_rate(const BoucWen& m, int phase) {
  return (phase == 2 || phase == -2) ? m.beta + m.gamma : m.beta - m.gamma;
}

// z at d on the phase's law (the closed form of BoucWen::relax, for a signed distance).
inline double phase_z(const BoucWen& m, const BoucWen::State& c, int phase, double d) {
  const double s = direction_of(phase);
  return s * BoucWen::relax(s * c.z, bouc_wen_rate(m, phase), s * (d - c.d) * m.per_yield);
}

inline double phase_force(const BoucWen& m, const BoucWen::State& c, int phase, double d) {
  return m.elastic * d + m.hysteretic * phase_z(m, c, phase, d);
}

inline BoucWen::State phase_state(const BoucWen& m, const BoucWen::State& c, int phase, double d) {
  return {d, phase_z(m, c, phase, d)};
}

// On the w < 0 side the phase ends where w reaches 0, after a distance log(1 - c w0) / c (in d_y).
inline Range phase_range(const BoucWen& m, const BoucWen::State& c, int phase) {
  if (phase == 2 || phase == -2) return {-kInfinity, kInfinity};
  const double s = direction_of(phase), w = s * c.z;
  if (w >= 0.0) return {c.d, c.d};  // already at w = 0: the phase ends at once
  const double x = -bouc_wen_rate(m, phase) * w;
  const double to_zero = (x == 0.0 ? -w : -w * std::log1p(x) / x) / m.per_yield;
  return s > 0 ? Range{-kInfinity, c.d + to_zero} : Range{c.d - to_zero, kInfinity};
}

inline int phase_after_exit(const BoucWen&, const BoucWen::State&, int phase, bool) { return 2 * direction_of(phase); }

inline int phase_after_reversal(const BoucWen&, const BoucWen::State& c, int phase) {
  const int s = -direction_of(phase);
  return s * (s * c.z >= 0.0 ? 2 : 1);
}

}  // namespace raydamp::materials
