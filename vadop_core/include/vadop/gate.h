// The scale search of a velocity gate: given the first contact time of a body driven by a
// command scaled by s (a function the caller builds, e.g. from World::firstContactIf), the
// largest s in [0, 1] on a grid of step `step` (1, 1 - step, ..., 0) for which nothing is
// touched; when every grid point leads to a contact, the one whose first contact comes latest
// (driving away from a danger is then never blocked). It does not build motions or know the
// world; it only decides which scales to try, largest first, and stops at the first clear one.
#pragma once

#include <cstddef>
#include <functional>

namespace vadop {

struct GateScale {
  double scale = 0.0;
  bool clear = false;           // no contact at `scale` within the window
  double contact_time = 0.0;    // first contact at `scale` (infinity when clear)
  size_t evaluations = 0;       // calls of first_contact
};

// first_contact(s): the first contact time at scale s, +infinity for none. step in (0, 1].
// Guarantees: when clear, `scale` is the largest grid point that is clear and every grid point
// above it leads to a contact (so it is within `step` of the largest clear s unless the clear
// scales above it form an interval shorter than `step`); otherwise `scale` is a grid point of
// the latest first contact, the smallest such point on ties (every scale meeting the same
// contact, e.g. pressed against something whatever the speed: stopping harms least). Throws vadop::InvalidArgument for
// a bad step or a NaN time; what first_contact throws propagates.
GateScale searchGateScale(const std::function<double(double s)>& first_contact, double step = 0.02);

}  // namespace vadop
