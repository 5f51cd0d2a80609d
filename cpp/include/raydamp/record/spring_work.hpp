// The hysteretic work of each spring of a structure (models/structure.hpp), for a run that tracks work: the
// work done on spring s, int sigma_s dd_s, by the trapezoidal rule on the points the recorder observes (the
// step ends, or the stage ends of a composed step), less the energy the spring stores at the end (its
// recoverable part, materials.hpp's stored()):
//   W_h,s(t) = int_0^t sigma_s dd_s - stored_s(t),
// the energy it has dissipated. With the damping work W and the load's work W_f the energy budget
// H(t) - H(0) + W(t) + sum_s W_h,s(t) - W_f(t) then closes to the order of the trapezoid, O(h^2) (H holds
// the springs' stored energy). sigma and stored are read at each point from the committed state, as a
// kick reads them.
//
// A point at a time not past the last one adds nothing: a block replayed after a blow-up, or a step re-run
// shortened, runs points already summed. An increment that is not finite (a blow-up's step) is dropped, so
// the sums stay those of the last finite state.
#pragma once

#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "raydamp/materials/commit.hpp"

namespace raydamp {

template <class Model>
class SpringWork {
 public:
  SpringWork(const Model& model, bool on) : model_(model) {
    static_cast<void>(on);
    if constexpr (has_materials_v<Model>) {
      if (!on) return;
      const std::size_t n = model.springs.size();
      d_.assign(n, 0.0), sigma_.assign(n, 0.0), stored_.assign(n, 0.0), done_.assign(n, 0.0);
    }
  }

  std::size_t size() const { return d_.size(); }

  // The first point (t = 0): nothing done yet.
  template <class S>
  void start(const S& z) {
    if (d_.empty()) return;
    read(z.q);
    t_ = 0.0;
  }

  // A point at time t after the last.
  template <class S>
  void on_point(const S& x, double t) {
    if (d_.empty() || !(t > t_)) return;
    t_ = t;
    add(x.q);
  }

  // Appends W_h,s of the last point for every spring (in the core's order).
  void append(std::vector<double>& out) const {
    for (std::size_t s = 0; s < d_.size(); ++s) out.push_back(done_[s] - stored_[s]);
  }

 private:
  // f(at, d, sigma, stored) for every spring at q, in the core's order, from its committed state.
  template <class Vec, class F>
  void for_each_spring(const Vec& q, F&& f) const {
    if constexpr (has_materials_v<Model>) {
      std::size_t at = 0;
      model_.springs.for_each([&](const auto& set) {
        using St = typename std::decay_t<decltype(set)>::State;
        for (std::size_t s = 0; s < set.size(); ++s, ++at) {
          St trial;
          const double d = set.deformation(q, s);
          const double sigma = set.material[s].force(set.committed[s], d, trial);
          f(at, d, sigma, set.material[s].stored(trial, d));
        }
      });
    } else {
      static_cast<void>(q), static_cast<void>(f);
    }
  }

  template <class Vec>
  void read(const Vec& q) {
    for_each_spring(q, [&](std::size_t at, double d, double sigma, double stored) {
      sigma_[at] = sigma, stored_[at] = stored, d_[at] = d;
    });
  }

  template <class Vec>
  void add(const Vec& q) {
    for_each_spring(q, [&](std::size_t at, double d, double sigma, double stored) {
      const double increment = 0.5 * (sigma_[at] + sigma) * (d - d_[at]);
      if (!std::isfinite(increment) || !std::isfinite(d)) return;
      done_[at] += increment;
      sigma_[at] = sigma, stored_[at] = stored, d_[at] = d;
    });
  }

  const Model& model_;
  double t_ = 0.0;
  std::vector<double> d_, sigma_, stored_, done_;  // at the last point; done: int sigma dd so far
};

}  // namespace raydamp
