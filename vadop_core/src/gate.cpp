#include "vadop/world.h"

#include "vadop/error.h"

#include <cmath>
#include <limits>
#include <string>

namespace vadop {

GateScale searchGateScale(const std::function<double(double s)>& first_contact, double step) {
  if (!(std::isfinite(step) && step > 0.0 && step <= 1.0)) {
    throw InvalidArgument("searchGateScale: step must be in (0, 1], got " + formatNumber(step));
  }
  if (!first_contact) throw InvalidArgument("searchGateScale: the contact function is empty");
  // Grid points k * step from the top, and 0 last (step need not divide 1).
  const long count = static_cast<long>(std::ceil(1.0 / step - 1e-9));
  GateScale best;
  best.contact_time = -std::numeric_limits<double>::infinity();
  for (long k = 0; k <= count; ++k) {
    const double s = k == count ? 0.0 : 1.0 - static_cast<double>(k) * step;
    const double t = first_contact(s);
    ++best.evaluations;
    if (std::isnan(t)) throw InvalidArgument("searchGateScale: the contact time at s = " + formatNumber(s) + " is NaN");
    if (t == std::numeric_limits<double>::infinity()) {
      best.scale = s;
      best.clear = true;
      best.contact_time = t;
      return best;
    }
    // Later, or as late: ties go to the smaller s (the search runs downwards), since when every
    // scale meets the same contact (already pressed against something), stopping harms least.
    if (t >= best.contact_time) {
      best.scale = s;
      best.contact_time = t;
    }
  }
  return best;
}

}  // namespace vadop
