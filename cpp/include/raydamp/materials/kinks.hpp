// Kink location for a structure's springs (issue 42): each step is split where a spring's force has a
// kink, so that every piece of it sees one smooth force and each method keeps its order.
//
// A spring's force is smooth within a phase (materials/phases.hpp) and kinks where its deformation d
// leaves the phase's range (yield) or, yielding, reverses (unloading). A step of a located run:
//   1. steps the method over what is left of the step, every kick reading each spring's phase law;
//   2. reads d and d' = r^T M^{-1} p of each spring at both ends, and on their cubic Hermite interpolant
//      (fourth order where the ends are) finds the first time a phase ends: d reaching an end of the
//      range from inside, or d' changing sign against a yielding phase's direction (also at once, where a
//      phase starts against the motion: a virgin Bouc-Wen spring's first motion downward);
//   3. if none, the piece is done: each state moves along its law to the end (phase_state) and commits;
//      else the piece is stepped again from its start, to that time, committed there, and that spring
//      changes phase; the rest of the step is a new piece.
// A load's kinks (a harmonic term's t_end, a series' sample times) end pieces too, unless they lie on a step
// end to within 1e-9 h. A step has at most kMaxPieces pieces; past that, its rest runs as one.
//
// The extra cost of a step without a kink is reading d, d' at its end and a scan of a cubic per spring;
// a kink costs the step's rest again. The step loop runs whole steps (no first-same-as-last merging). A
// piece's rerun redraws no noise, so a temperature is refused.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "raydamp/load.hpp"
#include "raydamp/materials/commit.hpp"
#include "raydamp/materials/phases.hpp"
#include "raydamp/run_types.hpp"

namespace raydamp {

template <class Model>
bool locates_kinks(const Model& model) {
  if constexpr (has_materials_v<Model>) return model.springs.phased();
  else return (static_cast<void>(model), false);
}

namespace kinks {

inline constexpr int kMaxPieces = 64;
inline constexpr double kNone = 2.0;  // "no event in the piece", as a fraction of it

// c0 + c1 s + c2 s^2 + c3 s^3.
struct Cubic {
  double c0, c1, c2, c3;
  double operator()(double s) const { return c0 + s * (c1 + s * (c2 + s * c3)); }
};

// The root of g in [x0, x1] where g(x0) < 0 <= g(x1) and g is monotone: Newton's method kept inside the
// bracket (bisection where a Newton step would leave it), to a few roundings of s; the end where g >= 0.
inline double bracketed_rise(const Cubic& g, double x0, double x1) {
  double x = 0.5 * (x0 + x1);
  for (int it = 0; it < 60; ++it) {
    const double gx = g(x);
    (gx < 0.0 ? x0 : x1) = x;
    if (x1 - x0 <= 4e-16) break;
    const double slope = g.c1 + x * (2.0 * g.c2 + 3.0 * x * g.c3);
    double next = slope != 0.0 ? x - gx / slope : 0.5 * (x0 + x1);
    if (!(next > x0 && next < x1)) next = 0.5 * (x0 + x1);
    if (next == x) break;  // converged to rounding
    x = next;
  }
  return g(x) >= 0.0 ? x : x1;
}

// The first s in (0, 1] where g passes from < 0 to >= 0 (kNone if it does not): g is split at the zeros
// of g' into monotone pieces, and the first piece that brackets a rise is bisected to rounding. Most steps
// are far from a kink: a bound of g on [0, 1] (s^k in [0, 1]) below 0 answers them in a few flops.
inline double first_rise(const Cubic& g) {
  if (g.c0 + std::max(g.c1, 0.0) + std::max(g.c2, 0.0) + std::max(g.c3, 0.0) < 0.0) return kNone;
  std::array<double, 4> at{0.0, 1.0, 1.0, 1.0};
  int n = 1;
  // zeros of g' = c1 + 2 c2 s + 3 c3 s^2 inside (0, 1)
  const double a = 3.0 * g.c3, b = 2.0 * g.c2, c = g.c1;
  auto keep = [&](double s) {
    if (s > 0.0 && s < 1.0) at[n++] = s;
  };
  if (a != 0.0) {
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0) {
      const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
      if (q != 0.0) {
        keep(q / a);
        keep(c / q);
      } else {
        keep(0.0);
      }
    }
  } else if (b != 0.0) {
    keep(-c / b);
  }
  std::sort(at.begin() + 1, at.begin() + n);
  at[n++] = 1.0;
  double lo = at[0], g_lo = g(lo);
  for (int k = 1; k < n; ++k) {
    const double hi = at[k], g_hi = g(hi);
    if (g_lo < 0.0 && g_hi >= 0.0) return bracketed_rise(g, lo, hi);
    lo = hi;
    g_lo = g_hi;
  }
  return kNone;
}

// The deformation's cubic Hermite interpolant over a piece of length T, in s = (t - t0) / T.
inline Cubic hermite_cubic(double d0, double v0, double d1, double v1, double T) {
  return {d0, T * v0, 3.0 * (d1 - d0) - T * (2.0 * v0 + v1), 2.0 * (d0 - d1) + T * (v0 + v1)};
}

// The time of every kink of a load in (a, b), the first one or kNoBreak.
inline constexpr double kNoBreak = 1e300;
inline double next_load_kink(const Load& load, double a, double b) {
  double out = kNoBreak;
  for (const LoadTerm& term : load.terms()) {
    if (term.shape == LoadTerm::Shape::harmonic) {
      if (term.t_end > a && term.t_end < b) out = std::min(out, term.t_end);
    } else if (term.shape == LoadTerm::Shape::series) {
      const LoadSeries& s = *term.series;
      const double u = term.time_scale * a;  // the series' own time
      double next;
      if (s.step > 0.0) {
        const double k = std::floor((u - s.times.front()) / s.step) + 1.0;
        next = k <= 0.0 ? s.times.front() : k >= static_cast<double>(s.times.size()) ? kNoBreak
                                                                                      : s.times[static_cast<std::size_t>(k)];
        if (next != kNoBreak && next <= u && k + 1.0 < static_cast<double>(s.times.size()))  // rounding of the division
          next = s.times[static_cast<std::size_t>(k) + 1];
      } else {
        const auto it = std::upper_bound(s.times.begin(), s.times.end(), u);
        next = it == s.times.end() ? kNoBreak : *it;
      }
      if (next != kNoBreak) {
        const double t = next / term.time_scale;
        if (t > a && t < b) out = std::min(out, t);
      }
    }
  }
  return out;
}

}  // namespace kinks

// The step loop's kink locator (see the top of this file); off, and compiled away, for a model without
// springs.
template <class Model, int Dim>
class KinkLocator {
  using Vec = typename Model::Vec;

 public:
  KinkLocator(const Model& model, const RunSpec& spec) : model_(model), load_(spec.load), on_(locates_kinks(model)) {
    if (!on_) return;
    if (spec.temperature > 0.0)
      throw std::invalid_argument("temperature: a Structure with locate_kinks reruns the piece of a step before "
                                  "a kink, which would draw its noise twice; run it without locate_kinks");
    if constexpr (has_materials_v<Model>) {
      const std::size_t m = model.springs.size();
      d0_.assign(m, 0.0);
      v0_ = d1_ = v1_ = d0_;
      vel_.setZero(model.size());
      start_.q.setZero(model.size());  // sized now: the loop's copies into it allocate nothing
      start_.p.setZero(model.size());
    }
  }

  bool on() const { return on_; }

  // Steps x over [t, t + h], in pieces that end at kinks: step(y, tau, whole) steps y by tau (whole: the
  // loop's own step, of length h). rec observes each piece (its work's trapezoid), and takes back what
  // a rerun piece added.
  template <class WS, class Rec, class Step>
  void step(State<Dim>& x, double t, double h, WS& ws, Rec& rec, const Step& step_by) {
    if constexpr (has_materials_v<Model>) {
      if (std::abs(t - read_at_) > 1e-9 * h) read(x, d0_, v0_);  // else the last step's end, read already
      read_at_ = t + h;
      double done = 0.0;
      for (int piece = 0;; ++piece) {
        const double a = t + done, end = t + h;
        const double tol = 1e-9 * h;
        double T = h - done;
        const double kink = load_ ? kinks::next_load_kink(*load_, a + tol, end - tol) : kinks::kNoBreak;
        if (kink != kinks::kNoBreak) T = kink - a;
        start_ = x;
        const auto marks = rec.marks();
        ws.time = a;
        step_by(x, T, done == 0.0 && T == h);
        read(x, d1_, v1_);
        int spring = -1;
        bool upper = false;
        const double s = piece + 1 < kinks::kMaxPieces ? first_kink(T, spring, upper) : kinks::kNone;
        if (s >= 1.0 - 1e-12) {  // none in the piece (or at its end): it stands
          commit_all(x);
          rec.on_step(x, T, a + T);
          if (s != kinks::kNone) {
            switch_phase(spring, upper);
            rec.restart_power(x);
          }
          done += T;
          std::swap(d0_, d1_);
          std::swap(v0_, v1_);
          if (kink == kinks::kNoBreak || done >= h) return;
          continue;
        }
        x = start_;
        rec.restore(marks);
        const double tau = s * T;
        if (tau > 1e-13 * h) {
          ws.time = a;
          step_by(x, tau, false);
          commit_all(x);
          rec.on_step(x, tau, a + tau);
          done += tau;
          read(x, d0_, v0_);
        }
        switch_phase(spring, upper);
        rec.restart_power(x);
      }
    } else {
      static_cast<void>(x), static_cast<void>(t), static_cast<void>(h), static_cast<void>(ws), static_cast<void>(rec),
          static_cast<void>(step_by);
    }
  }

 private:
  // d and d' of every spring at x, in Springs' order.
  void read(const State<Dim>& x, std::vector<double>& d, std::vector<double>& v) {
    model_.mass.velocity(x.p, vel_);
    std::size_t base = 0;
    model_.springs.for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        d[base + s] = set.deformation(x.q, s);
        v[base + s] = set.deformation(vel_, s);
      }
      base += set.size();
    });
  }

  // The first kink in the piece of length T just stepped, as a fraction of it (kNone: none); spring and
  // upper say whose and how (a range's upper end, or a reversal where upper is false and the range finite
  // ends are not crossed).
  double first_kink(double T, int& spring, bool& upper) {
    double first = kinks::kNone;
    std::size_t base = 0;
    model_.springs.for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        const std::size_t k = base + s;
        const int phase = set.phase[s];
        const kinks::Cubic d = kinks::hermite_cubic(d0_[k], v0_[k], d1_[k], v1_[k], T);
        const materials::Range r = phase_range(set.material[s], set.committed[s], phase);
        auto consider = [&](double at, bool up, bool reversal) {
          if (at < first) {
            first = at;
            spring = static_cast<int>(k);
            upper = up;
            reversal_ = reversal;
          }
        };
        if (std::isfinite(r.upper)) consider(kinks::first_rise({d.c0 - r.upper, d.c1, d.c2, d.c3}), true, false);
        if (std::isfinite(r.lower)) consider(kinks::first_rise({r.lower - d.c0, -d.c1, -d.c2, -d.c3}), false, false);
        if (phase != 0) {  // yielding: g = -s d' (times T) rising through 0 ends it
          const double sign = -materials::direction_of(phase);
          const kinks::Cubic g{sign * d.c1, sign * 2.0 * d.c2, sign * 3.0 * d.c3, 0.0};
          if (g.c0 >= 0.0 && g.c1 > 0.0) consider(0.0, false, true);  // it starts against the motion
          else consider(kinks::first_rise(g), false, true);
        }
      }
      base += set.size();
    });
    return first;
  }

  // Each spring's state moves along its phase law to its deformation at x, and commits.
  void commit_all(const State<Dim>& x) {
    model_.springs.for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        set.committed[s] = phase_state(set.material[s], set.committed[s], set.phase[s], set.deformation(x.q, s));
        set.trial[s] = set.committed[s];
      }
    });
  }

  void switch_phase(int spring, bool upper) {
    std::size_t base = 0;
    model_.springs.for_each([&](const auto& set) {
      if (spring >= static_cast<int>(base) && spring < static_cast<int>(base + set.size())) {
        const std::size_t s = static_cast<std::size_t>(spring) - base;
        const int phase = set.phase[s];
        const int next = reversal_ ? phase_after_reversal(set.material[s], set.committed[s], phase)
                                   : phase_after_exit(set.material[s], set.committed[s], phase, upper);
        set.phase[s] = static_cast<signed char>(next);
      }
      base += set.size();
    });
  }

  const Model& model_;
  const Load* load_;
  bool on_;
  bool reversal_ = false;
  double read_at_ = -std::numeric_limits<double>::infinity();  // the time whose d, d' are in d0_, v0_
  std::vector<double> d0_, v0_, d1_, v1_;
  Vec vel_;
  State<Dim> start_;
};

}  // namespace raydamp
