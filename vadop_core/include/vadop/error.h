// Errors raised by vadop_core on bad input, and the numerical range every input is checked
// against. Every public operation validates its arguments before it changes any state, so a
// thrown InvalidArgument always leaves the object exactly as it was (strong guarantee).
//
// The numerical range in which vadop's answers hold, one set of numbers for the library, the
// scene reader, vadop_predict and the monitor node. Inside it the narrow phase resolves gaps of
// its 1e-6 m tolerance (coordinates stay below 2e7 m, where a double is exact to 4e-9 m);
// outside it an input is rejected with a message naming the value, never silently rounded.
// It does not bound how many bodies there are or how long a computation takes.
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

// --- The numerical range ---

// |coordinate| of a body's position, a pivot offset or a static pose (m). Covers UTM northings.
constexpr double kMaxCoordinate = 1e7;
// |position| any body may reach within a prediction window (m): the check at predict time.
constexpr double kMaxReach = 2e7;
// Any shape dimension: radius, edge, length, |mesh or convex point|, padding (m).
constexpr double kMaxSize = 1e5;
// |linear velocity| (m/s) and |angular velocity| (rad/s).
constexpr double kMaxLinearSpeed = 1e4;
constexpr double kMaxAngularSpeed = 1e4;
// |t| of any library time: a motion's t_ref, a prediction's t0 and t0 + horizon (s). Times are
// seconds since a recent base (the node rebases; epoch seconds would cost the tolerance).
constexpr double kMaxTime = 1e7;

// "" when |value| <= limit (and finite), else a message "<field> = <value> is beyond <limit> <unit>"
// (or "... is not finite").
std::string rangeError(double value, double limit, const std::string& field, const char* unit);

}  // namespace vadop
