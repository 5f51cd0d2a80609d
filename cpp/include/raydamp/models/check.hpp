// Parameter checks shared by the models: errors name the offending argument.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace raydamp::detail {

inline void require(bool ok, const std::string& argument, const std::string& rule, double value) {
  if (ok) return;
  std::ostringstream msg;
  msg.precision(17);
  msg << argument << " must be " << rule << ", got " << value;
  throw std::invalid_argument(msg.str());
}

inline void require_nonnegative(const std::string& argument, double value) {
  require(std::isfinite(value) && value >= 0.0, argument, "a finite number >= 0", value);
}

}  // namespace raydamp::detail
