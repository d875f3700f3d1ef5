// Queries that traverse a mesh's sphere tree (a primitive acts as a single leaf): the static
// distance (the closest leaf pair, with a lower bound over all pairs) and the certified
// advancement step (best-first over pairs of bounding balls ordered by the step they could
// limit). Each leaf pair is a convex query (convex_distance.h, separation_step.h). It does not
// build the tree (mesh_bvh.h). Internal to the library (not installed).
#pragma once

#include "advance_step.h"
#include "body_side.h"
#include "gjk.h"

#include "vadop/distance.h"

namespace vadop {
namespace detail {

// Closest pair over all leaf pairs (static distance for meshes).
DistanceResult meshDistance(const Side& A, const Side& B, const Tolerances& tol);

// Best-first traversal of the pairs of bounding balls, ordered by the step each pair could
// at most limit: the search stops as soon as no remaining pair can shorten the best step.
AdvanceStep meshStep(const Side& A, const Side& B, double horizon, double touch, double adv,
                     const Tolerances& tol);

}  // namespace detail
}  // namespace vadop
