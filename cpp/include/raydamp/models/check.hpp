// Parameter checks shared by the models: errors name the offending argument.
#pragma once

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

}  // namespace raydamp::detail
