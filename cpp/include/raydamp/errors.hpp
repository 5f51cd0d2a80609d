// The core's refusals that Python tells apart by type (every refusal is a std::invalid_argument, a ValueError).
#pragma once

#include <stdexcept>
#include <string>

namespace raydamp {

// A flow whose Chebyshev series needs more than kMaxChebyshevDegree terms at this sub-step length (t beta
// lambda_max above about 1e7): raydamp.ChebyshevDegreeError in Python, a ValueError that choose_method and
// advise tell apart from other refusals (the step is too long for 3s, 2s and baoab on this structure, not
// invalid).
struct ChebyshevDegreeError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// Rethrows e with a prefix (a member's number), keeping its type.
[[noreturn]] inline void rethrow_prefixed(const std::string& prefix, const std::invalid_argument& e) {
  if (dynamic_cast<const ChebyshevDegreeError*>(&e)) throw ChebyshevDegreeError(prefix + e.what());
  throw std::invalid_argument(prefix + e.what());
}

}  // namespace raydamp
