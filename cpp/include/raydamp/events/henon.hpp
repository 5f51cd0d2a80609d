// Hénon's step for a section g = 0 (M. Hénon, "On the numerical computation of Poincaré maps",
// Physica D 5, 412-414, 1982): with u = g as the independent variable the system reads
//   dt/du = 1 / gdot,  dq/du = M^{-1} p / gdot,  dp/du = pdot / gdot,   gdot = dg/dt along the flow,
// so one step in u of length -g from a state lands on g = 0, within that step's error of the flow's
// own crossing: not the interpolant's. The step here is the classical Runge-Kutta method in u, split
// in `substeps` equal parts; a g that is affine in (t, q, p) lands on 0 to rounding (a Runge-Kutta
// step keeps linear invariants), any other g is polished by further steps of -g from where it landed.
//
// It runs only at a crossing (events/watcher.hpp), from a stepped state at an end of the crossing
// step between which and the crossing g is monotone, so gdot keeps its sign along the way.
#pragma once

#include <cmath>
#include <utility>

namespace raydamp::henon {

// Scratch for land(): sized once, when the run starts (no allocation at a crossing).
template <class Vec>
struct Work {
  Vec q, p, v, f, kq[4], kp[4], q_was, p_was;
  void resize(int n) {
    for (Vec* x : {&q, &p, &v, &f, &kq[0], &kq[1], &kq[2], &kq[3], &kp[0], &kp[1], &kp[2], &kp[3], &q_was, &p_was})
      x->setZero(n);
  }
};

// (t, q, p) with g(t, q, p) = g0 becomes the state where g = 0. rates(t, q, p, v, f) sets v = M^{-1} p
// and f = pdot at that state and returns {g, gdot} there. False where gdot vanishes or anything is not
// finite on the way (then (t, q, p) are left part-way: the caller keeps its own point instead).
template <class Vec, class Rates>
bool land(double& t, Vec& q, Vec& p, Work<Vec>& w, const Rates& rates, int substeps) {
  double kt[4];
  // The stage s of a step: the slopes in u at (ts, qs, ps).
  auto stage = [&](int s, double ts, const Vec& qs, const Vec& ps) {
    const std::pair<double, double> g = rates(ts, qs, ps, w.v, w.f);
    const double rate = g.second;
    if (!(std::isfinite(rate) && rate != 0.0)) return false;
    kt[s] = 1.0 / rate;
    w.kq[s] = w.v * kt[s];
    w.kp[s] = w.f * kt[s];
    return w.kq[s].allFinite() && w.kp[s].allFinite();
  };
  auto step = [&](double du) {
    if (!stage(0, t, q, p)) return false;
    w.q = q + (0.5 * du) * w.kq[0];
    w.p = p + (0.5 * du) * w.kp[0];
    if (!stage(1, t + 0.5 * du * kt[0], w.q, w.p)) return false;
    w.q = q + (0.5 * du) * w.kq[1];
    w.p = p + (0.5 * du) * w.kp[1];
    if (!stage(2, t + 0.5 * du * kt[1], w.q, w.p)) return false;
    w.q = q + du * w.kq[2];
    w.p = p + du * w.kp[2];
    if (!stage(3, t + du * kt[2], w.q, w.p)) return false;
    const double sixth = du / 6.0;
    t += sixth * (kt[0] + 2.0 * kt[1] + 2.0 * kt[2] + kt[3]);
    q += sixth * (w.kq[0] + 2.0 * w.kq[1] + 2.0 * w.kq[2] + w.kq[3]);
    p += sixth * (w.kp[0] + 2.0 * w.kp[1] + 2.0 * w.kp[2] + w.kp[3]);
    return std::isfinite(t);
  };
  double g = rates(t, q, p, w.v, w.f).first;
  if (!std::isfinite(g)) return false;
  for (int k = 0; k < substeps && g != 0.0; ++k)
    if (!step(-g / (substeps - k))) return false;
    else if (k + 1 < substeps) g = rates(t, q, p, w.v, w.f).first;
  // Polish: each step of -g from a point near the section shrinks g by the Runge-Kutta error's factor;
  // stop when it no longer does.
  g = rates(t, q, p, w.v, w.f).first;
  for (int k = 0; k < 4 && g != 0.0 && std::isfinite(g); ++k) {
    const double t_was = t;
    w.q_was = q, w.p_was = p;
    if (!step(-g)) return false;
    const double next = rates(t, q, p, w.v, w.f).first;
    if (!(std::abs(next) < std::abs(g))) {  // no better: the last point stays
      t = t_was, q = w.q_was, p = w.p_was;
      break;
    }
    g = next;
  }
  return std::isfinite(g);
}

}  // namespace raydamp::henon
