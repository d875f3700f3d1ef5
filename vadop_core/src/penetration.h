// The direction of least penetration of two overlapping convex cores (GJK reported overlap):
// separating axes for polytopes, the expanding polytope (EPA) and a hill climb otherwise. It
// does not compute the depth itself (the caller evaluates separation() along the direction)
// and does not handle meshes (their triangles are handled one by one). Internal to the
// library (not installed).
#pragma once

#include "gjk.h"
#include "posed_convex.h"

#include <Eigen/Core>

namespace vadop {
namespace detail {

// Overlapping cores: the direction of least penetration, maximising the separation over
// unit directions. When both cores are polytopes the maximum is exact: the separation of
// the padded shapes is the core separation minus the roundings, so it is largest along a
// facet normal of the cores' Minkowski difference (the origin lies inside it), and every
// such normal is a facet normal of one core or the cross product of an edge of each
// (separating axes). A cylinder or a point cloud: the expanding polytope, to 1e-6 of the
// sum of the shapes' bounding radii; where it cannot run (no tetrahedron of supports around
// the origin: the cores touch within rounding) or does not converge, hill climbing from the
// centre lines, the bodies' axes and the polytope's best direction.
Eigen::Vector3d penetrationDirection(const Convex& A, const Convex& B, const Gjk& g);

}  // namespace detail
}  // namespace vadop
