// The point reported for two bodies in contact (touching within the narrow phase's tolerance,
// or overlapping), given the contact's normal and depth: the centroid of the contact patch. Each
// core's support feature along the normal (a face, edge or vertex of a polytope: box, convex
// point set, mesh triangle; a cylinder's cap, side line or rim point; a capsule's segment or
// end; a sphere's centre) is projected onto the contact plane, the two convex outlines are
// clipped against each other (Sutherland-Hodgman), and the centroid of what remains is placed on
// the plane midway through the penetration. For a round core this is the deepest point of the
// penetration between the two witness points. It does not change the normal or the depth, and
// does not search for the contact (convex_distance.h, mesh_queries.h do). Internal to the
// library (not installed).
#pragma once

#include "body_side.h"

#include "vadop/distance.h"

#include <Eigen/Core>

namespace vadop {
namespace detail {

// The contact point of `contact` (a DistanceResult between A and B posed as given: its normal,
// from a to b, unit; its distance, minus the depth when overlapping; its witness points).
// A mesh contributes every triangle whose separation from the other body along the normal is
// the contact's (within the features' tolerance) and whose outline meets the other's: the
// area-weighted centroid of those patches, or, when all are points or segments (point sets,
// edges), the one nearest the witness points. Falls back to the midpoint of the witness points
// when no outline meets (a normal only approximate: a cylinder's or a point cloud's).
// Features are taken within 1e-7 of each core's size along the normal, so the point lies within
// that plus half the depth of each shape.
Eigen::Vector3d contactPatchPoint(const Side& A, const Side& B, const DistanceResult& contact);

// Whether `closing` (a's velocity less b's at the contact point) presses the bodies together
// along the contact's normal, beyond 1e-9 of its speed: a touching pair's normal comes from
// closest points a rounding error apart, so a body turning in place against a wall (sliding,
// exactly) would show a closing speed of that error's size at the patch's centre.
inline bool pressesIn(const Eigen::Vector3d& closing, const Eigen::Vector3d& normal) {
  return closing.dot(normal) > 1e-9 * closing.norm();
}

}  // namespace detail
}  // namespace vadop
