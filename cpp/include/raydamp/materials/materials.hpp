// Hysteretic materials of a spring: force sigma(d, state) of a deformation d with an internal state.
//
// Each material keeps two states, as OpenSees' uniaxial materials do: the committed one (at the end of
// the last full step) and a trial one (at the last deformation asked for). force(c, d, t) answers from a
// committed state c and writes the trial state t, by a return map that is exact for a monotonic drift
// from the committed deformation to d. Nothing moves the committed state but a commit, once per full
// step (materials/springs.hpp): the sub-steps of a composed step, backward ones included, all answer from
// the state of the step's start and so never create plastic flow of their own.
//
// A material is plain data (its parameters) with inline, non-virtual functions; the springs of one kind
// are a struct-of-arrays bound once per kind (materials/springs.hpp).
//
// Kinks. sigma is smooth between kinks: where d leaves elastic_range() moving outward (yield) and where
// the drift reverses on an end of the range or in a plastic flow (unloading). elastic_range(state) gives
// the deformations at which a material in that state next yields, for a caller that locates kinks as
// events of the deformation; Bouc-Wen, smooth at every d, has only its reversals.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "raydamp/phi.hpp"

namespace raydamp::materials {

// Bouc-Wen's common step (below): |x| = |c D| at most this.
inline constexpr double kPadeBound = 0.5;

// phi1(x) = (e^x - 1) / x from the [6/6] Pade approximant e^x = (E(x^2) + x O(x^2)) / (E(x^2) - x O(x^2)):
// phi1 = 2 O / (E - x O). The approximant errs by about (6!)^2 / (12! 13!) |x|^13 in e^x, 2e-17 at |x| = 1/2,
// so rounding sets the error (within 2.2 ulp of expm1 there: test_materials.cpp). Fewer operations than phi.hpp's
// 9-term series, and one formula on the whole range where phi.hpp's phi1 switches between three. V: double, or
// a vector of doubles (bouc_wen_lanes.hpp), which then takes the same operations lane by lane.
template <class V>
inline __attribute__((always_inline)) V pade_phi1(V x) {
  const V y = x * x;
  const V odd = 0.5 + y * (1.0 / 66.0 + y * (1.0 / 15840.0));
  const V even = 1.0 + y * (5.0 / 44.0 + y * (1.0 / 792.0 + y * (1.0 / 665280.0)));
  return (odd + odd) / (even - x * odd);
}

// The deformations [lower, upper] within which a material answers elastically from its state.
struct Range {
  double lower, upper;
};

// Elastic-perfectly-plastic: sigma = k (d - d_p) with |sigma| <= fy; d_p the plastic deformation.
struct ElasticPlastic {
  static constexpr const char* name = "elastic_plastic";
  double k, fy;

  struct State {
    double plastic = 0.0;
  };

  double stiffness() const { return k; }

  double force(const State& c, double d, State& t) const {
    const double s = k * (d - c.plastic);
    t = c;
    if (s > fy) {
      t.plastic = d - fy / k;
      return fy;
    }
    if (s < -fy) {
      t.plastic = d + fy / k;
      return -fy;
    }
    return s;
  }

  // The elastic energy stored at d (recoverable): 1/2 k (d - d_p)^2 after the return map.
  double stored(const State& t, double d) const {
    const double e = d - t.plastic;
    return 0.5 * k * e * e;
  }

  // d sigma / d d on loading from state t at d: k inside the elastic range, 0 on its ends.
  double tangent(const State& t, double d) const {
    const double s = k * (d - t.plastic);
    return std::abs(s) < fy ? k : 0.0;
  }

  Range elastic_range(const State& s) const { return {s.plastic - fy / k, s.plastic + fy / k}; }
};

// Bilinear with kinematic hardening (Steel01's rule without its isotropic terms): elastic stiffness k,
// post-yield stiffness b k. Plastic deformation d_p and back force a = H d_p with H = b k / (1 - b);
// |sigma - a| <= fy. Its loops lie between the lines sigma = b k d +- (1 - b) fy. A negative b (> -1)
// softens: H < 0, the post-yield stiffness b k is negative, and a structure can lose its stability.
struct Bilinear {
  static constexpr const char* name = "bilinear";
  double k, fy, b;
  double hardening;  // H = b k / (1 - b)

  Bilinear(double k_, double fy_, double b_) : k(k_), fy(fy_), b(b_), hardening(b_ * k_ / (1.0 - b_)) {}

  struct State {
    double plastic = 0.0, back = 0.0;
  };

  double stiffness() const { return k; }

  double force(const State& c, double d, State& t) const {
    const double s = k * (d - c.plastic);
    const double xi = s - c.back;
    const double excess = std::abs(xi) - fy;
    t = c;
    if (excess <= 0.0) return s;
    // The consistency condition |sigma - a| = fy after the flow: excess = (k + H) dg, k + H = k / (1 - b).
    const double flow = std::copysign(excess * (1.0 - b) / k, xi);
    t.plastic = c.plastic + flow;
    t.back = c.back + hardening * flow;
    return s - k * flow;
  }

  double stored(const State& t, double d) const {
    const double e = d - t.plastic;
    return 0.5 * k * e * e;
  }

  double tangent(const State& t, double d) const {
    const double xi = k * (d - t.plastic) - t.back;
    return std::abs(xi) < fy ? k : b * k;
  }

  Range elastic_range(const State& s) const {
    return {s.plastic + (s.back - fy) / k, s.plastic + (s.back + fy) / k};
  }
};

// Bouc-Wen with n = 1 (A = 1): sigma = alpha k d + (1 - alpha) fy z, and along d
//   dz/dd = (1 / d_y) (1 - (beta sgn(z dd) + gamma) |z|),   d_y = fy / k.
// With s = sgn(dd) and w = s z over the distance D = |d - d0| / d_y this is w' = 1 - c w, c = beta + gamma
// where w >= 0 and c = beta - gamma where w < 0: a linear ODE on each side of w = 0, whose exact solution
// w(D) = w0 e^{-c D} + D phi1(-c D) the return map takes (crossing w = 0 where the drift reaches it).
// Bounded (|z| <= max(|z0|, 1 / (beta + gamma))) when beta > 0 and beta + gamma > 0: the Python layer
// refuses other values.
struct BoucWen {
  static constexpr const char* name = "bouc_wen";
  double k, fy, alpha, beta, gamma;
  double per_yield, elastic, hysteretic;  // 1 / d_y, alpha k, (1 - alpha) fy: no division in a kick

  BoucWen(double k_, double fy_, double alpha_, double beta_, double gamma_)
      : k(k_), fy(fy_), alpha(alpha_), beta(beta_), gamma(gamma_), per_yield(k_ / fy_), elastic(alpha_ * k_),
        hysteretic((1.0 - alpha_) * fy_) {}

  struct State {
    double d = 0.0, z = 0.0;  // the deformation the state belongs to, and z there
  };

  double stiffness() const { return k; }

  // w' = 1 - c w over a distance D from w: w e^{-cD} + D phi1(-cD), with e^{-cD} = 1 + x phi1(x), x = -cD,
  // so one phi1 (a short series, no library call, for the small |x| of one step) gives both terms.
  static double relax(double w, double c, double distance) {
    const double x = -c * distance;
    const double p = phi1(x);
    return w + w * x * p + distance * p;
  }

  // w after a drift of D >= 0 (in units of d_y) from w0, in the direction that w counts positive.
  double evolve(double w, double distance) const {
    if (w < 0.0) {
      const double c = beta - gamma;
      const double end = relax(w, c, distance);
      if (end <= 0.0) return end;  // w rises monotonically (1 - c w > 0 while bounded): it did not reach 0
      // It reached 0 after log(1 - c w0) / c, i.e. -w0 log1p(x) / x with x = -c w0.
      const double x = -c * w;
      const double to_zero = x == 0.0 ? -w : -w * std::log1p(x) / x;
      distance = std::max(0.0, distance - to_zero);
      w = 0.0;
    }
    return relax(w, beta + gamma, distance);
  }

  // z at d from the committed c on the common step: one side of w = 0 (w = s z, s the step's sign) and
  // |x| = |c D| <= kPadeBound, where w + (1 - c w) D phi1(-c D) needs no branch on the data. False otherwise
  // (w reaches 0 from below, a longer step, a non-finite one). bouc_wen_lanes.hpp takes these operations, in
  // this order, two springs at a time, so that a kick's z and every other reader's (the recorder's forces, the
  // energy, the work) are the same bits.
  bool common_step(const State& c, double d, double& z) const {
    const double step = d - c.d;
    const bool down = std::signbit(step);
    const double w = down ? -c.z : c.z;
    const double distance = std::abs(step) * per_yield;
    const bool below = w < 0.0;
    const double rate = below ? beta - gamma : beta + gamma;
    const double x = -rate * distance;
    const double end = w + (1.0 - rate * w) * (distance * pade_phi1(x));
    z = down ? -end : end;
    return !(below && end > 0.0) && std::abs(x) <= kPadeBound;
  }

  double trial_z(const State& c, double d) const {
    double z;
    if (common_step(c, d, z)) return z;
    const double step = d - c.d;
    if (step == 0.0) return c.z;
    const double s = step > 0.0 ? 1.0 : -1.0;
    return s * evolve(s * c.z, std::abs(step) * per_yield);
  }

  double force(const State& c, double d, State& t) const {
    t.d = d;
    t.z = trial_z(c, d);
    return elastic * d + hysteretic * t.z;
  }

  // The elastic part 1/2 alpha k d^2 and the hysteretic part's recoverable 1/2 (1 - alpha) fy d_y z^2.
  double stored(const State& t, double d) const {
    return 0.5 * alpha * k * d * d + 0.5 * (1.0 - alpha) * fy * (fy / k) * t.z * t.z;
  }

  // d sigma / d d on loading in the direction of z.
  double tangent(const State& t, double) const {
    return alpha * k + (1.0 - alpha) * k * (1.0 - (beta + gamma) * std::abs(t.z));
  }

  Range elastic_range(const State&) const {
    return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  }
};

}  // namespace raydamp::materials
