// The divergence test: a run whose energy gained far more than anything could give it has blown
// up, although its state is still finite (3s at h omega_max = 6.9 on a 10-storey frame reaches
// |q| = 1e287 in 3 s without overflowing).
//
// The rule. With damping that only dissipates (D >= 0), the exact flow's energy H = T + V obeys
//   H(t) - H(0) = W_f(t) - W(t) + (thermal input) <= W_f(t) + (thermal input),
// and the load's work is bounded by W_f = int f . M^{-1} p <= int |f|_{M^-1} |p|_{M^-1}, which lets
// sqrt(H - min V) grow by at most t F / sqrt(2) with F = max_t |f(t)|_{M^-1}. So the energy a run can
// gain is of the order of the scale
//   S(t) = T(0) + |V(0)| + (t F)^2 + n kT.
// A run is diverged at a check when
//   H(t) - H(0) > G S(t)   and   H(t) - H(0) > (T(t) + |V(t)|) / 2,
// or when H is +inf while the state is finite. G = RunSpec::divergence (default 1e6, 0: no test) is
// generous: a stable method's energy error is a fraction of S, while a blow-up multiplies H by its
// amplification factor every step. The second condition keeps out the rounding of a large T and V
// that cancel (an orbit escaping to infinity, a fall in a potential unbounded below: H stays H(0)).
// The checks are every kCheckEvery steps and at the run's end; a blow-up that overflows between two
// checks is found by the finiteness check first and ends non_finite.
//
// F is exact for harmonic terms and series of one value per time (scale x largest value x
// |direction|_{M^-1}), and for series of a row per time the largest |row|_{M^-1}. An expression's
// history is sampled: at kExpressionSamples times over the run before its first step, and at every
// check. (A pulse narrower than t_end / kExpressionSamples, from rest, can go unseen: set G = 0.)
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/load.hpp"
#include "raydamp/record/model_view.hpp"
#include "raydamp/run_types.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

inline constexpr long kCheckEvery = 256;          // steps between divergence checks
inline constexpr long kExpressionSamples = 4096;  // samples of an expression load before the first step

// One class for every model: the model is seen through a ModelView (record/model_view.hpp).
class DivergenceGuard {
  using Vec = Eigen::VectorXd;

 public:
  DivergenceGuard(const ModelView& model, const RunSpec& spec, StateView z0, double t_end)
      : model_(model), factor_(spec.divergence) {
    if (!(factor_ >= 0.0) || !std::isfinite(factor_))
      throw std::invalid_argument("divergence must be a finite number >= 0 (0: no divergence test)");
    if (factor_ == 0.0) return;
    q_ = Eigen::Map<const Vec>(z0.q, model.n);
    p_ = Eigen::Map<const Vec>(z0.p, model.n);
    const double T0 = kinetic(p_), V0 = model.potential(model.model, q_);
    h0_ = T0 + V0;
    base_ = T0 + std::abs(V0) + model.n * spec.temperature;
    if (spec.load && !spec.load->empty()) bound_load(*spec.load, t_end);
  }

  // Whether z, after step k of N at time t, has diverged: checked every kCheckEvery steps and at the
  // run's end (false between checks); the figures then go into message().
  template <int Dim>
  bool check(const State<Dim>& z, long k, long N, double t) {
    if (factor_ == 0.0 || (k < next_check_ && k != N)) return false;
    return check_at(view_of(z), k, t);
  }

  std::string message(long step, double t) const {
    return "diverged at step " + std::to_string(step) + " (t = " + figure(t) + "): the energy went from H(0) = " +
           figure(h0_) + " to " + figure(T_ + V_) + ", a gain of more than " + figure(factor_) + " times " +
           figure(scale_) + ", the most its start, its load and its temperature can give; the rows so far are " +
           "kept (a smaller h, or divergence = 0 to turn the test off)";
  }

 private:
  double kinetic(const Vec& p) const { return model_.kinetic(model_.model, p); }

  bool check_at(StateView z, long k, double t) {
    next_check_ = k + kCheckEvery;
    if (sampled_) F_ = std::max(F_, F_fixed_ + norm_of(*sampled_, t));
    q_ = Eigen::Map<const Vec>(z.q, model_.n);
    p_ = Eigen::Map<const Vec>(z.p, model_.n);
    T_ = kinetic(p_);
    V_ = model_.potential(model_.model, q_);
    const double H = T_ + V_;
    scale_ = base_ + (t * F_) * (t * F_);  // before the return below: message() reports it either way
    // +inf: T or V overflowed while the state did not. NaN: a user's function failed (that run stops
    // non_finite at its next step, with the function's message); -inf: a fall into a singular potential.
    if (!std::isfinite(H)) return H == std::numeric_limits<double>::infinity();
    const double excess = H - h0_;
    return excess > factor_ * scale_ && excess > 0.5 * (T_ + std::abs(V_));
  }

  static std::string figure(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return buf;
  }

  // |f|_{M^-1} for f = what `load` gives at t.
  double norm_of(const Load& load, double t) {
    buf_.setZero();
    load.add(t, 1.0, buf_.data());
    return std::sqrt(2.0 * std::max(0.0, kinetic(buf_)));
  }

  void bound_load(const Load& load, double t_end) {
    buf_ = Vec::Zero(model_.n);
    std::vector<LoadTerm> expressions;
    for (const LoadTerm& term : load.terms()) {
      if (term.shape == LoadTerm::Shape::expression) {
        expressions.push_back(term);
        continue;
      }
      const LoadSeries* s = term.shape == LoadTerm::Shape::series ? term.series.get() : nullptr;
      if (s && s->width > 1) {  // the largest row
        double most = 0.0;
        for (std::size_t k = 0; k < s->times.size(); ++k) {
          for (int i = 0; i < s->width; ++i) buf_[i] = s->values[k * s->width + i];
          most = std::max(most, kinetic(buf_));
        }
        F_fixed_ += std::abs(term.scale) * std::sqrt(2.0 * most);
        continue;
      }
      double peak = 1.0;  // |sin|
      if (s) {
        peak = 0.0;
        for (double v : s->values) peak = std::max(peak, std::abs(v));
      }
      buf_.setZero();
      const LoadDirection& d = *term.direction;
      for (std::size_t j = 0; j < d.index.size(); ++j) buf_[d.index[j]] += d.value[j];
      F_fixed_ += std::abs(term.scale) * peak * std::sqrt(2.0 * std::max(0.0, kinetic(buf_)));
    }
    F_ = F_fixed_;
    if (expressions.empty()) return;
    sampled_ = std::make_unique<Load>(std::move(expressions), model_.n);
    for (long k = 0; k <= kExpressionSamples; ++k)
      F_ = std::max(F_, F_fixed_ + norm_of(*sampled_, t_end * static_cast<double>(k) / kExpressionSamples));
  }

  const ModelView model_;
  double factor_;
  long next_check_ = kCheckEvery;
  double h0_ = 0.0, base_ = 0.0, F_fixed_ = 0.0, F_ = 0.0;
  double T_ = 0.0, V_ = 0.0, scale_ = 0.0;  // at the last check
  std::unique_ptr<Load> sampled_;  // the load's expression terms
  Vec buf_, q_, p_;  // scratch: a load's value; the state at a check
};

}  // namespace raydamp
