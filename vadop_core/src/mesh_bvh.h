// Building a mesh's sphere tree (PreparedShapeData's tris, nodes, node_boxes and root): median
// splits of the triangles' centroids along the widest axis, or for large sets (a sensor's
// points, rebuilt for every message) splits of the centroids' Morton order; tris in the
// leaves' order (a leaf's neighbours in the tree are its neighbours in memory); a leaf's box and
// bounding sphere those of its padded triangle, a node's box the union of its
// children's and its sphere one that holds theirs (linear time after the splits); and the one
// query that needs no motion: whether a box can meet the padded triangles (the world's cull of
// a pair whose one side is a resting mesh or point set). It does not check the triangles'
// indices (PreparedShape's constructor does) nor measure distances or steps (mesh_queries.h).
// Internal to the library (not installed).
#pragma once

#include "shape_core.h"

#include <cstdint>

namespace vadop {
namespace detail {

// On up to `threads` threads (0: one per hardware thread) for sets large enough to gain; the
// same tree whatever the count (the nodes' order aside).
void buildBvh(PreparedShapeData& d, int threads = 1);

// A node's box (node_boxes: centre and half extents, body frame) turned into the fixed frame
// with the body posed at (R, p), absR = |R| elementwise: the box about the turned centre with
// half extents absR h (it bounds the turned box), grown by `grow`; min x, y, z, max x, y, z.
inline void turnedNodeBox(const std::array<double, 6>& nb, const Eigen::Matrix3d& R, const Eigen::Matrix3d& absR,
                          const Eigen::Vector3d& p, double grow, double out[6]) {
  const Eigen::Vector3d c = R * Eigen::Vector3d(nb[0], nb[1], nb[2]) + p;
  const Eigen::Vector3d h = absR * Eigen::Vector3d(nb[3], nb[4], nb[5]) + Eigen::Vector3d::Constant(grow);
  for (int a = 0; a < 3; ++a) {
    out[a] = c[a] - h[a];
    out[3 + a] = c[a] + h[a];
  }
}

// Of the parts set in `parts` (bit k: the axis-aligned box part_boxes[6k .. 6k + 5], min x, y,
// z, max x, y, z, fixed frame), those whose box meets the box of some leaf (its padded
// triangle's, turned into the fixed frame and grown by `slack`) with the mesh posed at (R, p).
// A part left out is proved to hold no padded triangle within `slack` of its box.
uint64_t partsMeetingTree(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
                          const double* part_boxes, uint64_t parts, double slack);

}  // namespace detail
}  // namespace vadop
