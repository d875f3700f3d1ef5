// The distance between two posed convex cores with their roundings (a DistanceResult: gap,
// witness points, normal and a certified lower bound; on overlap the penetration along the
// least-penetration direction), and the refinement of a contact to rounding accuracy. It does
// not traverse meshes (mesh_queries.h) nor step in time (separation_step.h, advance_step.h).
// Internal to the library (not installed).
#pragma once

#include "advance_step.h"
#include "posed_convex.h"

#include "vadop/distance.h"

#include <Eigen/Core>

namespace vadop {
namespace detail {

// Distance between two posed convexes. `cert` receives the unit direction (a to b) along
// which lower_bound was certified; it can differ from the witness normal by the GJK's
// angular accuracy (near contact the witness direction is the better contact normal, the
// certified one the better separating plane).
// `warm` (primitives only, may be null): started from its simplex, re-posed, when it has one;
// the final simplex stored back in the cores' body frames (none after an overlap).
// `penetration` false: when the cores overlap, return at once with cores_overlap, distance
// minus the roundings (an upper bound of the signed gap: the cores share a point) and
// lower_bound -inf, without witness points or the penetration direction (EPA), for a caller that only asks
// whether the gap is below a threshold.
DistanceResult convexDistance(const Convex& A, const Convex& B, const Eigen::Vector3d& guess,
                              double abs_tol, double rel_tol, int max_iter, Eigen::Vector3d* cert,
                              WarmStart* warm = nullptr, bool penetration = true);

// The reported contact: near touching, the witness direction of a GJK run stopped at a
// gap accuracy delta can be off by about sqrt(2 delta / gap) radians (the closest point
// slides along a flat or ruled patch of the Minkowski difference at second order), so the
// contact that ends the advancement is recomputed to rounding accuracy.
DistanceResult refineContact(const Convex& A, const Convex& B, const DistanceResult& coarse,
                             const WarmStart* coarse_simplex = nullptr);

}  // namespace detail
}  // namespace vadop
