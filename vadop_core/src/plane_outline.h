// Convex outlines in a plane (the contact patch's, contact_patch.h): the convex hull of points,
// and where two convex outlines meet (Sutherland-Hodgman clipping, with the degenerate outlines
// of points and segments handled on their own). It knows nothing of shapes or of 3-D. Internal
// to the library (not installed).
#pragma once

#include <Eigen/Core>

#include <vector>

namespace vadop {
namespace detail {

using Vec2 = Eigen::Vector2d;
using Outline = std::vector<Vec2>;  // convex, counter-clockwise; 1 or 2 points when degenerate

// The convex hull (monotone chain), counter-clockwise; the two extremes of collinear points.
Outline convexHull(Outline p);

// Where two outlines meet, within tol (each outline's edges moved out by it where the exact
// intersection is empty: a point or an edge on the other's boundary): the intersection
// (`region`), its centroid `c` and its area (0 unless both outlines have area; for a segment
// or point, the middle of the common stretch). False when they do not meet.
bool meet(const Outline& P, const Outline& Q, double tol, Vec2& c, double& area, Outline& region);

}  // namespace detail
}  // namespace vadop
