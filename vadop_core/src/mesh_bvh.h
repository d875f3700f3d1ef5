// Building a mesh's sphere tree (PreparedShapeData's tris, nodes and root): median splits of
// the triangles' centroids along the widest axis, each node's bounding sphere and lever arm
// over its padded triangles; and the one query that needs no motion: whether a box can meet
// the padded triangles (the world's cull of a pair whose one side is a resting mesh or point
// set). It does not check the triangles' indices (PreparedShape's constructor does) nor
// measure distances or steps (mesh_queries.h). Internal to the library (not installed).
#pragma once

#include "shape_core.h"

namespace vadop {
namespace detail {

void buildBvh(PreparedShapeData& d);

// Whether some leaf's bounding sphere, grown by `slack`, meets the axis-aligned box `box`
// (min x, y, z, max x, y, z; fixed frame) with the mesh posed at (R, p). False proves that no
// padded triangle comes within `slack` of the box (each lies inside its leaf's sphere).
bool treeMeetsBox(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p, const double* box,
                  double slack);

}  // namespace detail
}  // namespace vadop
