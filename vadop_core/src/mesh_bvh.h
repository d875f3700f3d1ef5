// Building a mesh's sphere tree (PreparedShapeData's tris, nodes and root): median splits of
// the triangles' centroids along the widest axis, each node's bounding sphere and lever arm
// over its padded triangles. It does not check the triangles' indices (PreparedShape's
// constructor does) nor query the tree (mesh_queries.h). Internal to the library (not
// installed).
#pragma once

#include "shape_core.h"

namespace vadop {
namespace detail {

void buildBvh(PreparedShapeData& d);

}  // namespace detail
}  // namespace vadop
