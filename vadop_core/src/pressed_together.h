// The one rule for a pair that already touches when a window [s, e] of a query opens
// (TimeOfImpact::initially_touching): whether that touch blocks the motions. It is a contact
// only where the motions press the pair together at the touching point (the closing speed along
// the normal > 0), or where, not pressed there, they still dig in over the window: the witness of
// a face contact is one point of the face and another corner may press (a box turning in place
// against a wall). The guard samples the gap at four times of the window against the gap at s
// less the tolerance: it can only add contacts to the exemption's answer, never remove one.
// Driving away from a touching body, or sliding along it, is thereby never blocked.
//
// MotionA / MotionB: Motion, TimedPath or LinkChain (each offers poseAt and velocityOfPoint).
// Internal to vadop_core (World's mover queries).
#pragma once

#include "vadop/distance.h"
#include "vadop/time_of_impact.h"

#include <algorithm>

namespace vadop {
namespace detail {

// Whether `closing` (a's velocity less b's at the contact point) presses the bodies together
// along the contact's normal, beyond 1e-9 of its speed: a touching pair's normal comes from
// closest points a rounding error apart, so a body turning in place against a wall (sliding,
// exactly) would show a closing speed of that error's size at the patch's centre.
inline bool pressesIn(const Eigen::Vector3d& closing, const Eigen::Vector3d& normal) {
  return closing.dot(normal) > 1e-9 * closing.norm();
}

}  // namespace detail

template <class MotionA, class MotionB>
bool pressedTogether(const TimeOfImpact& hit, const PreparedShape& a, const MotionA& ma, const PreparedShape& b,
                     const MotionB& mb, double s, double e, double tolerance) {
  const Eigen::Vector3d closing = ma.velocityOfPoint(hit.point, s) - mb.velocityOfPoint(hit.point, s);
  if (detail::pressesIn(closing, hit.normal)) return true;
  const double deeper = std::min(hit.distance, 0.0) - tolerance;
  for (int k = 1; k <= 4; ++k) {
    const double t = s + (e - s) * k / 4.0;
    if (distance(a, ma.poseAt(t), b, mb.poseAt(t)).distance < deeper) return true;
  }
  return false;
}

}  // namespace vadop
