// Why a run stopped: the one list of run statuses. Python names and documents each
// (raydamp.results.statuses); files store a status as its index here, so a new status
// is added at the end.
#pragma once

#include <array>

namespace raydamp {

enum class Status {
  completed, non_finite, cancelled, out_of_memory, diverged, event, not_converged, collapsed, constraint_failed };

inline constexpr std::array<const char*, 9> kStatusNames = {
    "completed", "non_finite", "cancelled", "out_of_memory", "diverged", "event", "not_converged", "collapsed",
    "constraint_failed"};

inline const char* status_name(Status s) { return kStatusNames[static_cast<std::size_t>(s)]; }

}  // namespace raydamp
