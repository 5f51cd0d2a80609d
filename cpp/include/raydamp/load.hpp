// A time-dependent load f(t): the external force in p' = -grad V(q) - eps D M^{-1} p + f(t).
// Data, not code: a sum of terms s_k(t) d_k, each a scalar history times a fixed
// direction over the coordinates (or, for a series given as a vector per time, the
// interpolated vector itself). The step loop treats t as one more coordinate that the
// drifts advance, and the kicks apply f at the time the drifts left (flows/exact.hpp),
// so every splitting keeps its order and every composition its own.
//
// Term data (times, values, directions) is held through shared pointers: the loads of
// an ensemble's members differ in a scale or a frequency and share the rest.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/attributes.hpp"
#include "raydamp/system/compiled_function.hpp"

namespace raydamp {

// A sparse direction: f gets s(t) * value at each index.
struct LoadDirection {
  std::vector<int> index;
  std::vector<double> value;
};

// A piecewise-linear history over `times`: width 1 (one value per time, times a
// direction) or width n (a row of n values per time, added to coordinates 0..n-1).
struct LoadSeries {
  std::vector<double> times;
  std::vector<double> values;  // times.size() * width, row by row
  int width = 1;
  bool hold = false;   // outside [times.front(), times.back()]: the end value (true) or zero
  double step = 0.0;   // times[k] = times[0] + k * step to rounding (0: not uniform)

  // Where t lies: the row k with times[k] <= t < times[k + 1] and the weight of row k + 1;
  // false outside the range.
  bool locate(double t, std::size_t& k, double& w) const {
    const std::size_t last = times.size() - 1;
    if (!(t >= times.front() && t <= times.back())) return false;
    if (last == 0) {
      k = 0;
      w = 0.0;
      return true;
    }
    if (step > 0.0) {  // a record sampled at dt: the row by one division, checked against its neighbours
      double x = (t - times.front()) / step;
      k = std::min(static_cast<std::size_t>(x), last - 1);
      if (t < times[k] && k > 0) --k;
      else if (k + 1 < last && t >= times[k + 1]) ++k;
    } else {
      k = static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
      k = k == 0 ? 0 : std::min(k - 1, last - 1);
    }
    w = (t - times[k]) / (times[k + 1] - times[k]);
    return true;
  }

  // The row k and weight w of row k + 1 that the load takes at t: locate()'s inside the range, the end
  // row (w = 0) outside it when held; false when the load is zero there.
  bool row(double t, std::size_t& k, double& w) const {
    if (locate(t, k, w)) return true;
    if (!hold) return false;
    k = t < times.front() ? 0 : times.size() - 1;
    w = 0.0;
    return true;
  }

  // Component i of the interpolated row (width values a row).
  double at(std::size_t k, double w, int i) const {
    const double a = values[k * width + i];
    return w == 0.0 ? a : (1.0 - w) * a + w * values[(k + 1) * width + i];
  }
};

struct LoadTerm {
  enum class Shape { harmonic, series, expression };
  Shape shape = Shape::harmonic;
  double scale = 1.0;                // a factor on the term (an ensemble member's amplitude)
  double omega = 0.0, phase = 0.0;   // harmonic: s(t) = sin(omega t + phase) for t <= t_end, 0 after
  double t_end = std::numeric_limits<double>::infinity();
  double time_scale = 1.0;           // series and expression: s(t) = history(time_scale * t)
  std::shared_ptr<const LoadSeries> series;
  CompiledFunction expression;       // (t) -> s(t), the user's expression with its parameters bound
  std::shared_ptr<const LoadDirection> direction;  // unset for a series of width n
  // A ground motion's term (force -M r a_g(t)): its influence vector r, so that r a_g(t), the ground's own
  // acceleration, can be added back to a relative one (add_ground). Unset for every other term.
  std::shared_ptr<const LoadDirection> ground;
};

class Load {
 public:
  Load() = default;
  explicit Load(std::vector<LoadTerm> terms, int n) : terms_(std::move(terms)), n_(n) {
    for (std::size_t k = 0; k < terms_.size(); ++k) check(terms_[k], "load.terms[" + std::to_string(k) + "]");
  }

  bool empty() const { return terms_.empty(); }
  int size() const { return n_; }
  const std::vector<LoadTerm>& terms() const { return terms_; }

  // out[i] += c * f_i(t).
  RAYDAMP_OUT_OF_LINE void add(double t, double c, double* out) const {
    for (const LoadTerm& term : terms_) {
      if (term.shape == LoadTerm::Shape::series && term.series->width > 1) {
        add_rows(*term.series, term.time_scale * t, c * term.scale, out);
        continue;
      }
      const double s = c * term.scale * scalar(term, t);
      if (s == 0.0) continue;
      const LoadDirection& d = *term.direction;
      for (std::size_t j = 0; j < d.index.size(); ++j) out[d.index[j]] += s * d.value[j];
    }
  }

  // out[i] += r_i a_g(t) summed over the ground motion's terms: the ground's acceleration, which turns a
  // relative acceleration into an absolute one (record/envelope.hpp).
  void add_ground(double t, double* out) const {
    for (const LoadTerm& term : terms_) {
      if (!term.ground) continue;
      const double s = term.scale * scalar(term, t);
      if (s == 0.0) continue;
      const LoadDirection& r = *term.ground;
      for (std::size_t j = 0; j < r.index.size(); ++j) out[r.index[j]] += s * r.value[j];
    }
  }

  // f(t) . v.
  RAYDAMP_OUT_OF_LINE double dot(double t, const double* v) const {
    double sum = 0.0;
    for (const LoadTerm& term : terms_) {
      if (term.shape == LoadTerm::Shape::series && term.series->width > 1) {
        const LoadSeries& s = *term.series;
        std::size_t k;
        double w;
        if (!s.row(term.time_scale * t, k, w)) continue;
        double part = 0.0;
        for (int i = 0; i < s.width; ++i) part += s.at(k, w, i) * v[i];
        sum += term.scale * part;
        continue;
      }
      const double s = term.scale * scalar(term, t);
      if (s == 0.0) continue;
      const LoadDirection& d = *term.direction;
      double part = 0.0;
      for (std::size_t j = 0; j < d.index.size(); ++j) part += d.value[j] * v[d.index[j]];
      sum += s * part;
    }
    return sum;
  }

 private:
  static double scalar(const LoadTerm& term, double t) {
    switch (term.shape) {
      case LoadTerm::Shape::harmonic: return t <= term.t_end ? std::sin(term.omega * t + term.phase) : 0.0;
      case LoadTerm::Shape::expression: {
        const double in = term.time_scale * t;
        double out = 0.0;
        term.expression(&out, &in);
        return out;
      }
      default: {
        const LoadSeries& s = *term.series;
        std::size_t k;
        double w;
        return s.row(term.time_scale * t, k, w) ? s.at(k, w, 0) : 0.0;
      }
    }
  }

  static void add_rows(const LoadSeries& s, double t, double c, double* out) {
    std::size_t k;
    double w;
    if (!s.row(t, k, w)) return;
    for (int i = 0; i < s.width; ++i) out[i] += c * s.at(k, w, i);
  }

  void check(const LoadTerm& term, const std::string& where) const {
    auto fail = [&](const std::string& why) { throw std::invalid_argument(where + ": " + why); };
    if (!std::isfinite(term.scale)) fail("scale is not finite");
    if (term.shape == LoadTerm::Shape::harmonic && !(std::isfinite(term.omega) && std::isfinite(term.phase)))
      fail("omega and phase must be finite");
    if (term.shape == LoadTerm::Shape::harmonic && std::isnan(term.t_end)) fail("t_end is not a number");
    if (term.shape == LoadTerm::Shape::expression && !term.expression) fail("the expression is not compiled");
    if (term.shape == LoadTerm::Shape::series) {
      if (!term.series || term.series->times.empty()) fail("a series needs at least one time");
      const LoadSeries& s = *term.series;
      if (s.width != 1 && s.width != n_) fail("a series row has " + std::to_string(s.width) + " values, not 1 or n");
      if (s.values.size() != s.times.size() * static_cast<std::size_t>(s.width)) fail("values do not match times");
      for (std::size_t k = 1; k < s.times.size(); ++k)
        if (!(s.times[k] > s.times[k - 1])) fail("times must increase (at index " + std::to_string(k) + ")");
      if (s.step > 0.0)
        for (std::size_t k = 0; k < s.times.size(); ++k)
          if (std::abs(s.times[k] - (s.times[0] + k * s.step)) > 1e-9 * s.step)
            fail("times are not uniform at step " + std::to_string(s.step));
      if (s.width > 1) return;
    }
    if (!term.direction) fail("a direction is needed");
    const LoadDirection& d = *term.direction;
    if (d.index.size() != d.value.size()) fail("direction indices and values differ in length");
    for (int i : d.index)
      if (i < 0 || i >= n_) fail("direction index " + std::to_string(i) + " is not a coordinate");
    if (!term.ground) return;
    if (term.ground->index.size() != term.ground->value.size()) fail("ground indices and values differ in length");
    for (int i : term.ground->index)
      if (i < 0 || i >= n_) fail("ground index " + std::to_string(i) + " is not a coordinate");
  }

  std::vector<LoadTerm> terms_;
  int n_ = 0;
};

}  // namespace raydamp
