// The range checks of error.h: one message format for every limit.

#include "vadop/error.h"

#include <cmath>

namespace vadop {

std::string rangeError(double value, double limit, const std::string& field, const char* unit) {
  if (!std::isfinite(value)) return field + " = " + formatNumber(value) + " is not finite";
  if (std::abs(value) <= limit) return "";
  return field + " = " + formatNumber(value) + " is beyond " + formatNumber(limit) + " " + unit;
}

}  // namespace vadop
