// The step loop's envelope recorder: peaks of |x| taken at the end of every step, not only at the saved
// rows, so that an incremental dynamic analysis keeps per-spring and per-coordinate peaks without saving a
// trajectory (record/envelope_types.hpp lists them). It reads the state the loop stepped and never changes
// it, so a run steps the same with and without it (whole steps: integrate.hpp's merges_steps).
//
// A spring's drift past its collapse limit stops it (stopped()); the loop then ends the run at that step's
// end with the status collapsed. Its cost when off is one branch per step; the work is kept out of line
// (observe) so the flattened step loops carry no copy of it.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/record/envelope_types.hpp"
#include "raydamp/record/model_view.hpp"
#include "raydamp/run_types.hpp"
#include "raydamp/record/save_grid.hpp"

#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_ENVELOPE_FLAT __attribute__((noinline, flatten))
#else
#define RAYDAMP_ENVELOPE_FLAT
#endif

namespace raydamp {

// One class for every model: the model is seen through a ModelView (record/model_view.hpp).
class EnvelopeRecorder {
  using Vec = Eigen::VectorXd;

 public:
  EnvelopeRecorder(const ModelView& model, const RunSpec& spec, RunResult& result, StateView z)
      : model_(model), spec_(spec.envelope && spec.envelope->any() ? spec.envelope : nullptr), load_(spec.load),
        out_(result.envelope), on_(spec_ != nullptr), h_(spec.h), h_last_(spec.h_last), n_steps_(spec.n_steps) {
    if (!on_) return;
    const int n = model.n;
    const std::size_t springs = model.springs;
    for (int k = 0; k < kPeaks; ++k) {
      if (!spec_->peaks[k]) continue;
      if (per_spring(static_cast<Peak>(k)) && springs == 0)
        throw std::invalid_argument(std::string("envelope: '") + kPeakNames[k] + "' is a spring's, and this model "
                                    "has no springs");
      const std::size_t size = per_spring(static_cast<Peak>(k)) ? springs : static_cast<std::size_t>(n);
      out_.peak[k].assign(size, -1.0);  // below every |x|: the first state observed sets each
      out_.time[k].assign(size, 0.0);
    }
    if (!spec_->collapse.empty() && springs == 0)
      throw std::invalid_argument("envelope: collapse limits are a spring's, and this model has no springs");
    if (!spec_->collapse.empty() && spec_->collapse.size() != springs)
      throw std::invalid_argument("envelope: " + std::to_string(spec_->collapse.size()) + " collapse limits for " +
                                  std::to_string(springs) + " springs");
    for (Vec* v : {&q_, &p_, &v_, &grad_, &rate_, &f_, &a_}) v->setZero(n);
    d_.assign(springs, 0.0);
    s_.assign(springs, 0.0);
    if (finite(z)) read(z, 0.0);
  }

  bool stopped() const { return out_.collapse_spring >= 0; }

  // After step i (a block replayed after a blow-up runs steps already observed: skipped; a state that is
  // not finite ends the run, and adds no peak). The test is the model's, at its fixed size.
  template <int Dim>
  void after_step(const State<Dim>& x, long i) {
    if (on_ && i > step_ && x.all_finite()) observe(view_of(x), i, step_time(i + 1, h_, n_steps_, h_last_));
  }

  // Ends a collapsed run: its status and message; returns the steps taken (up to the collapse step's end).
  long stop(RunResult& result) const {
    const long s = out_.collapse_spring;
    const long label = spec_->labels.empty() ? s : spec_->labels[s];
    result.status = Status::collapsed;
    result.failed_step = step_ + 1;
    result.message = "collapsed: springs[" + std::to_string(label) + "]'s drift " + std::to_string(d_[s]) +
                     " passed its limit " + std::to_string(spec_->collapse[s]) + " at t = " + std::to_string(t_) +
                     " (step " + std::to_string(step_ + 1) + ")";
    return step_ + 1;
  }

 private:
  bool finite(StateView x) const {
    return Eigen::Map<const Vec>(x.q, model_.n).allFinite() && Eigen::Map<const Vec>(x.p, model_.n).allFinite();
  }

  // Out of line (one copy for every model and method), with read() and take() inlined into it: a
  // call fewer per step, and no call through the module's PLT.
  RAYDAMP_ENVELOPE_FLAT void observe(StateView x, long i, double t) {
    step_ = i;
    read(x, t);
  }

  void take(Peak which, const double* x, std::size_t size, double t) {
    std::vector<double>& peak = out_.peak[static_cast<int>(which)];
    std::vector<double>& time = out_.time[static_cast<int>(which)];
    for (std::size_t j = 0; j < size; ++j) {
      const double a = std::abs(x[j]);
      if (a > peak[j]) {
        peak[j] = a;
        time[j] = t;
      }
    }
  }
  bool wants(Peak which) const { return spec_->peaks[static_cast<int>(which)]; }

  void read(StateView x, double t) {
    t_ = t;
    const void* m = model_.model;
    const std::size_t n = static_cast<std::size_t>(model_.n);
    if (wants(Peak::displacement)) take(Peak::displacement, x.q, n, t);
    // The view's functions take vectors: q and p copied into ours, only where a peak reads them.
    const bool accelerations = wants(Peak::acceleration) || wants(Peak::abs_acceleration);
    if (accelerations || !d_.empty()) q_ = Eigen::Map<const Vec>(x.q, model_.n);
    if (accelerations || wants(Peak::velocity)) p_ = Eigen::Map<const Vec>(x.p, model_.n);
    if (wants(Peak::velocity)) {
      model_.velocity(m, p_, v_);
      take(Peak::velocity, v_.data(), n, t);
    }
    if (accelerations) {
      // a = M^{-1} pdot, pdot = -grad V - eps D M^{-1} p + f(t). A spring's gradient writes its trial state from
      // the committed one; the next step's kick writes it again before any commit.
      model_.force(m, q_, p_, grad_, rate_, f_);
      if (load_ && !load_->empty()) load_->add(t, 1.0, f_.data());
      model_.velocity(m, f_, a_);
      if (wants(Peak::acceleration)) take(Peak::acceleration, a_.data(), n, t);
      if (wants(Peak::abs_acceleration)) {
        if (load_ && !load_->empty()) load_->add_ground(t, a_.data());
        take(Peak::abs_acceleration, a_.data(), n, t);
      }
    }
    if (d_.empty()) return;
    model_.deformations(m, q_, d_.data());
    if (wants(Peak::drift)) take(Peak::drift, d_.data(), d_.size(), t);
    if (wants(Peak::force)) {
      model_.spring_forces(m, q_, s_.data());
      take(Peak::force, s_.data(), s_.size(), t);
    }
    const std::vector<double>& limit = spec_->collapse;
    for (std::size_t s = 0; s < limit.size() && out_.collapse_spring < 0; ++s)
      if (std::abs(d_[s]) > limit[s]) out_.collapse_spring = static_cast<long>(s);
  }

  const ModelView model_;
  const EnvelopeSpec* spec_;
  const Load* load_;
  EnvelopeRecord& out_;
  const bool on_;
  const double h_, h_last_;
  const long n_steps_;
  long step_ = -1;
  double t_ = 0.0;
  Vec q_, p_, v_, grad_, rate_, f_, a_;
  std::vector<double> d_, s_;  // the springs' deformations and forces at the last step's end
};

}  // namespace raydamp
