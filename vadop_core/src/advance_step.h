// The certified steps of conservative advancement under screw motion, shared by the distance
// code that computes them (advance_step.cpp, swept_volume.cpp) and timeOfImpact that drives
// them (time_of_impact.cpp).
// Internal to the library (not installed): the public entry point is timeOfImpact.
#pragma once

#include "vadop/distance.h"
#include "vadop/motion.h"

#include <Eigen/Core>

namespace vadop {

namespace detail {

// One step of conservative advancement, used by timeOfImpact. At time t:
//  - touching: the gap at t is <= touch_gap (closest holds the contact);
//  - otherwise `step` in [0, horizon] is certified: gap(t') > advance_gap for every
//    t' in [t, t + step); clear = true when that holds up to t + horizon (inclusive).
// The certificate: for a separating direction n at t (per triangle pair for meshes, after a
// bounding-ball screen), the separation along n -- n fixed in the world, or turning with a,
// or with b -- is bounded below for all later times by concave functions of the elapsed
// time (exact for translation; first order exact and a Taylor remainder bound for rotation)
// and by a linear one (|w x n| times the lever arm); step is where the best bound reaches
// advance_gap. See separationStep in separation_step.h for the formulas.
struct AdvanceStep {
  bool touching = false;
  bool clear = false;
  double step = 0.0;
  DistanceResult closest;  // at t
};

// What one step of a convex pair leaves to the next step of the same advancement: the last
// separating direction, and the simplex GJK ended on, its points in each core's body frame.
// Points of the cores stay points of the cores wherever the bodies move, so the next GJK
// starts from that simplex re-posed (near the answer when the closest features stay the same:
// a box's corner, a cylinder's rim point) and its answer and certificate are as exact as from
// scratch. Empty (n = 0) at first; meshes do not use it.
struct WarmStart {
  Eigen::Vector3d dir = Eigen::Vector3d::Zero();
  Eigen::Vector3d a[3], b[3];
  int n = 0;
};

// Requires 0 <= advance_gap < touch_gap. `warm` (may be null) carries the warm start from one
// call to the next for convex pairs.
AdvanceStep advanceStep(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                        const Motion& mb, double t, double horizon, double touch_gap,
                        double advance_gap, WarmStart* warm);

// The same step for bodies that only stay near a constant twist: each posed at t, with the
// velocity of its pose's origin and its angular velocity at t, and every point of it within
// deviation_x D^2 / 2 of where that twist takes it D later (`deviation` the sum over both, a
// bound over [t, t + horizon]): links of joint chains (joint_chain.cpp). Convex shapes only;
// throws vadop::InvalidArgument for a mesh.
AdvanceStep advanceStepNearTwist(const PreparedShape& a, const PosedTwist& ta, const PreparedShape& b,
                                 const PosedTwist& tb, double deviation, double horizon, double touch_gap,
                                 double advance_gap, WarmStart* warm);

// The swept-volume certificate, used by timeOfImpact where rotation limits the steps above.
// Over [ta, tb] (ta <= tb) each body lies in a convex set: a turning body in its revolution
// hull -- the cylinder about the axis of its angular velocity through its pivot at ta, whose
// radius is the largest distance of its core from that axis and whose axial extent is the
// core's support along +-axis (both unchanged by the turning), rounded by the shape's rounding
// radius -- Minkowski-summed with the pivot's displacement over [ta, tb]; a body that does not
// turn in its posed shape (a mesh: the convex hull of its vertices) summed with its
// displacement; a body that turns by at most 0.5 rad over [ta, tb], in its shape posed at ta
// and grown by that angle times its largest distance from the pivot, plus the displacement.
// lower_bound is a certified lower bound of the gap between the two sets (the
// separation along a GJK direction, computed with exact support functions, less a rounding
// allowance), hence of the gap between the bodies at every t in [ta, tb]; -inf when the sets
// overlap. The GJK may stop as soon as the bound exceeds stop_above (+inf: run to accuracy).
struct SweptBound {
  double lower_bound = 0.0;
  int iterations = 0;  // GJK iterations
};
SweptBound sweptLowerBound(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                           const Motion& mb, double ta, double tb, double stop_above);

}  // namespace detail

}  // namespace vadop
