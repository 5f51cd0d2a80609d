// The damping's factors (its factors(t): exponentials, phi1 and noise factors of one sub-flow length) for
// the last few lengths a run asked for.
//
// A merged 3s run asks for two lengths (h between its steps, h/2 at the ends of a block of steps). A
// composed run, or one that runs whole steps (events, envelopes, collapse limits), cycles through a few
// more in every step: 3s + suzuki4's whole step damps for three lengths, 2s + suzuki4 kicks and damps for
// two. Keeping six per run matters beyond the arithmetic: a structure's factors(t) looks its length up under
// a lock that every run of the model shares, so a miss per step is contention between an ensemble's threads
// (benchmarks/bench_ida_threads.py).
#pragma once

#include <array>
#include <type_traits>
#include <utility>

#include "raydamp/attributes.hpp"
#include "raydamp/damping/decay_factors.hpp"

namespace raydamp {

template <class F, int N = 4>
class FactorsCache {
 public:
  // The factors for length t: the last two lengths tested inline. A scalar damping's few numbers (DecayFactors)
  // are computed again past those, inline, as before this cache kept more: the damped pendulum's 3s loop is
  // sensitive to this code's shape (an index into the lengths cost it 2%, a call to refresh() 20%).
  template <class Damping>
  const F& get(double t, const Damping& damping) {
    if (current_.t != t) {
      std::swap(current_, previous_);
      if (current_.t != t) {
        if constexpr (std::is_same_v<F, DecayFactors>) current_ = damping.factors(t);
        else refresh(t, damping);
      }
    }
    return current_;
  }

 private:
  // t's factors in current_ (previous_ keeps the other of the last two): swapped in from the earlier lengths, else
  // computed, the current ones taking the oldest's place.
  template <class Damping>
  RAYDAMP_OUT_OF_LINE void refresh(double t, const Damping& damping) {
    for (F& kept : earlier_)
      if (kept.t == t) {
        std::swap(kept, current_);
        return;
      }
    std::swap(earlier_[next_], current_);
    next_ = (next_ + 1) % N;
    current_ = damping.factors(t);
  }

  F current_{}, previous_{};  // t = NaN until computed: matches no length
  // The lengths before those two (none kept for DecayFactors).
  std::array<F, std::is_same_v<F, DecayFactors> ? 0 : N> earlier_{};
  int next_ = 0;
};

}  // namespace raydamp
