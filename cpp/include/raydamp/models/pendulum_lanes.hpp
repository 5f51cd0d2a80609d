// Many damped pendulums (paper section 4.3) with one eps, laid out as lanes: q and p
// hold one member per component, so the members are the inner, contiguous axis and
// the one step loop (integrate.hpp) advances all of them at once. The pendulums are
// uncoupled (M = I, D = I, V = sum_i 1 - cos q_i), so every exact sub-flow acts on
// each lane exactly as on one DampedPendulum: drift q += t p, kick p -= t sin q,
// damp p += (e^{-t eps} - 1) p with the same factors. The mass and damping kinds are the
// single pendulum's, and by default each lane's sin is the same std::sin call, so
// lane i of a run equals the single run of member i bit for bit (no lane sees
// another, and with the baseline x86-64 flags no fused multiply-add changes a
// rounding). Then only the multiplications and additions run as SIMD across lanes.
//
// vector_sine (integrate_ensemble's opt-in): the sines run as SIMD too, through
// math/sine_lanes.hpp (math::sin's arithmetic, two or four lanes per register). That
// sine differs from libm's in the last bit for about 3% of arguments, so the members
// then differ from their single runs by rounding; they stay independent of the lane
// count, of the register width and of the other members (each lane's sine is
// math::sin's bits), so a member's result does not depend on how the ensemble was cut
// into runs or threads, nor on the machine.
#pragma once

#include <cmath>

#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/mass/unit_mass.hpp"
#include "raydamp/math/sine_lanes.hpp"
#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct PendulumLanes {
  static constexpr int dim = Eigen::Dynamic;
  // A lane's step is a few multiplications and a sine: flattened like a fixed-size
  // model's (integrate.hpp, flattens_step_loop).
  static constexpr bool flatten_step_loop = true;
  static constexpr int n_momenta = 0;
  using Vec = Vector<dim>;

  double eps;
  UnitMass mass;
  IsotropicDamping damping;
  int lanes;
  bool vector_sine;
  // vector_sine's registers: four lanes where the processor has AVX2 (found here, once per
  // run), else two; the same bits either way (math/sine_lanes.hpp). Tests force each.
  math::SineWidth width;

  // Lanes of `member`'s kind: its eps, and so its damping rate.
  PendulumLanes(const DampedPendulum& member, int lanes_, bool vector_sine_ = false,
                math::SineWidth width_ = math::best_sine_width())
      : eps(member.eps), damping(member.damping), lanes(lanes_), vector_sine(vector_sine_), width(width_) {}

  int size() const { return lanes; }
  // The step loop saves V summed over lanes; the ensemble recomputes each member's
  // energy from its saved (q, p) with DampedPendulum's own formula.
  double potential(const Vec& q) const { return (1.0 - q.array().cos()).sum(); }
  void gradient(const Vec& q, Vec& g) const {
    if (vector_sine) {
      math::sine_lanes(width, q.data(), g.data(), lanes);
    } else {
      for (int i = 0; i < lanes; ++i) g[i] = std::sin(q[i]);
    }
  }
  // The drift and the kick in one pass each (flows/exact.hpp's has_drift/has_kick),
  // with the single run's operations: q + t p (M = I, so v = p) and p - t sin q.
  void drift(Vec& q, const Vec& p, double t) const { q += t * p; }
  void kick(const Vec& q, Vec& p, double t) const {
    if (vector_sine) {
      math::kick_sine_lanes(width, q.data(), p.data(), t, lanes);
    } else {
      for (int i = 0; i < lanes; ++i) p[i] -= t * std::sin(q[i]);
    }
  }
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const { out = q.array().cos() * v.array(); }
  void momenta(const Vec&, const Vec&, double*) const {}
};

}  // namespace raydamp
