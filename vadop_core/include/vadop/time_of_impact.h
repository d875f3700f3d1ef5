// Continuous narrow phase: the first time two moving shapes touch.
//
// Contract (g(t) is the gap between the padded shapes, tol = ToiOptions::tolerance):
//  - hit == false, undecided == false  =>  g(t) > tol/2 for every t in [t0, t1]   (certified)
//  - hit == true   =>  g(t) > tol/2 for every t in [t0, time)    (certified)
//                      and g(time) <= tol                        (up to rounding)
//  - undecided == true (hit == false): the budget (ToiOptions::max_iterations) ran out before a
//    verdict: g(t) > tol/2 is certified on [t0, time) only; nothing is known after `time`.
//    Never reported as a contact (no contact was found), never as clear.
// So a contact (g <= 0) is never missed and `time` is never later than the first contact.
// "Touching" means "within tol": when the shapes approach a contact directly, the contact
// follows `time` by about tol / (closing speed); a pass within tol/2 of touching (a graze)
// is itself reported as the impact, even when a real contact follows later in the window;
// a pass between tol/2 and tol may be reported either way.
//
// Method: closed form for sphere-sphere; otherwise conservative advancement on our own GJK
// (distance.h) whose certified lower bound along a separating direction is advanced with a
// bound on the motion that includes rotation (see detail::advanceStep). Linear-only motion
// uses the exact linear law of the separation along the normal. Where rotation keeps those
// steps short (fast spinners), whole stretches of the window are certified clear at once by
// swept volumes (detail::sweptLowerBound: each body's revolution hull plus its pivot's path)
// and by the swept bounding spheres about the pivots. Meshes are triangle soups
// (surfaces): a body wholly inside a closed mesh does not touch it.
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"

#include <Eigen/Core>

namespace vadop {

// A shape prepared for the narrow phase (its support mapping, mesh hierarchy): internal to
// vadop_core (src/vadop/distance.h); the overloads taking it are the library's own.
class PreparedShape;

struct ToiOptions {
  double tolerance = 1e-6;      // m, target gap: hit once the gap is <= tolerance; > 0
  // Budget of distance evaluations (conservative-advancement steps and swept-volume tests).
  // When it runs out before a verdict the result is `undecided` at the last certified time:
  // neither a contact nor a miss.
  int max_iterations = 10000;
};

struct TimeOfImpact {
  bool hit = false;
  // hit: the time of impact (see the contract above); no hit: t1.
  double time = 0.0;
  // hit: the contact point in the fixed frame, midway between the closest points of the
  // two padded surfaces (on or between the surfaces). No hit: the same for the last
  // evaluated time (diagnostic only).
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  // Unit, from a to b: the separating direction at `time`; when the shapes already overlap
  // at t0, the estimated penetration direction (centre to centre for spheres).
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  bool initially_touching = false;  // g(t0) <= tol: then time == t0
  int iterations = 0;               // distance evaluations (1 for closed forms)
  // The gap at `time` (upper bound; <= tolerance on a hit; for overlapping cores an estimate
  // of minus the penetration depth).
  double distance = 0.0;
  // No verdict within the budget (max_iterations ran out, or no numerical progress was
  // possible): hit is false and `time` is only the end of the certified-clear interval.
  bool undecided = false;
};

// The first t in [t0, t1] at which a (moving with ma) and b (moving with mb) touch.
// Throws vadop::InvalidArgument when a shape or motion is invalid (validateShape /
// validateMotion), t0 or t1 is not finite, t1 < t0, or the options are not positive.
TimeOfImpact timeOfImpact(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb,
                    double t0, double t1, const ToiOptions& options = {});

// The same for prepared shapes (reuse a mesh's bounding-volume tree across queries).
TimeOfImpact timeOfImpact(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                    const Motion& mb, double t0, double t1, const ToiOptions& options = {});

}  // namespace vadop
