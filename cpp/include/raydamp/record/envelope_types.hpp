// What a run is asked to record as an envelope (EnvelopeSpec, in RunSpec) and what it gives back
// (EnvelopeRecord, in RunResult). The step loop's observer of them is record/envelope.hpp.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace raydamp {

// The peaks an envelope can take, each max |x| over every step's end (the initial state included) and
// the time it happens. Per coordinate: q, v = M^{-1} p, the relative acceleration a = M^{-1} pdot and
// the absolute acceleration a + r a_g (the ground motion's terms, load.hpp's add_ground). Per spring
// (a model with hysteretic springs): its deformation d = r^T q and its force sigma(d).
enum class Peak { displacement, velocity, acceleration, abs_acceleration, drift, force };
inline constexpr int kPeaks = 6;
inline constexpr std::array<const char*, kPeaks> kPeakNames = {"displacement", "velocity", "acceleration",
                                                               "abs_acceleration", "drift", "force"};
inline constexpr bool per_spring(Peak p) { return p == Peak::drift || p == Peak::force; }

struct EnvelopeSpec {
  std::array<bool, kPeaks> peaks{};  // which peaks to take
  // A collapse limit per spring (the springs' order in the core): the first step's end at which some
  // |d_s| passes its limit ends the run (status collapsed). Empty: no limit.
  std::vector<double> collapse;
  std::vector<int> labels;  // each spring's index as the caller numbers them (messages); empty: the core's
  bool any() const {
    for (bool p : peaks)
      if (p) return true;
    return !collapse.empty();
  }
};

struct EnvelopeRecord {
  std::array<std::vector<double>, kPeaks> peak, time;  // empty unless asked
  long collapse_spring = -1;                           // the spring (core order) that passed its limit, or -1
};

}  // namespace raydamp
