// Errors raised by vadop_core on bad input.
// Every public operation validates its arguments before it changes any state, so a
// thrown InvalidArgument always leaves the object exactly as it was (strong guarantee).
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace vadop {

// Bad input from the caller: NaN/Inf, non-positive sizes, unknown ids, bad parameters.
// The message names what was wrong and the offending value.
class InvalidArgument : public std::invalid_argument {
 public:
  explicit InvalidArgument(const std::string& what) : std::invalid_argument(what) {}
};

// A number as the messages print it: all 17 significant digits, so that the offending value can
// be reproduced exactly from the message.
inline std::string formatNumber(double value) {
  std::ostringstream os;
  os.precision(17);
  os << value;
  return os.str();
}

}  // namespace vadop
