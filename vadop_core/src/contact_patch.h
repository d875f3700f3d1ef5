// The point reported for two bodies in contact (touching within the narrow phase's tolerance,
// or overlapping), given the contact's normal and depth: the centroid of the contact patch. Each
// core's support feature along the normal (a face, edge or vertex of a polytope: box, convex
// point set, mesh triangle; a cylinder's cap, side line or rim point; a capsule's segment or
// end; a sphere's centre) is projected onto the contact plane, the two convex outlines are
// clipped against each other (Sutherland-Hodgman), and the centroid of what remains is placed on
// the plane midway through the penetration. For a round core this is the deepest point of the
// penetration between the two witness points; a cylinder's side line or rim point is taken along
// the contact's own normal, so that the point and the normal agree (a body turning about its axis
// slides at it, exactly). It does not change the normal or the depth, and
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
// The patch is built on the normal of a face of either core within 1e-3 rad of the contact's
// (the exact normal a physics engine's reference face gives), features taken within 1e-7 of
// each core's size along it, so the point lies within that plus half the depth of each shape.
// When no face or line of one meets the other's: touching, the midpoint of the pair's closest
// points to rounding accuracy; overlapping (a normal found by search, a cylinder's or a point
// cloud's), looser features up to a quarter of the depth, else a point of both cores (the GJK's).
// A mesh contributes every triangle about as deep along the normal as the contact whose features
// meet the other's: the deepest patches, the largest with those joined to it edge to edge on its
// plane, area-weighted; when all are points or segments (point sets, edges), the one nearest the
// witness points. The witness points' midpoint when nothing meets.
Eigen::Vector3d contactPatchPoint(const Side& A, const Side& B, const DistanceResult& contact);

}  // namespace detail
}  // namespace vadop
