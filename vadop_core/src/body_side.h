// One body as a query sees it: a mesh's sphere tree, or a primitive acting as its single
// leaf, posed about its rotation centre with that centre's velocity. It does not compute
// distances or steps (mesh_queries.h, convex_distance.h, separation_step.h). Internal to the
// library (not installed).
#pragma once

#include "posed_convex.h"
#include "separation_step.h"
#include "shape_core.h"

#include "vadop/motion.h"

#include <Eigen/Core>

namespace vadop {
namespace detail {

// One side of a bounding-volume traversal (meshes), a convex primitive acting as a single leaf.
struct Side {
  const PreparedShapeData* d = nullptr;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      // the rotation centre (Motion's pivot)
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // body origin - p
  Kin kin;  // of p
  bool mesh = false;

  int root() const { return mesh ? d->root : 0; }
  bool leaf(int i) const { return !mesh || d->nodes[i].tri >= 0; }
  Eigen::Vector3d centre(int i) const {
    return mesh ? Eigen::Vector3d(R * d->nodes[i].centre + p + shift) : Eigen::Vector3d(p + shift);
  }
  double radius(int i) const { return mesh ? d->nodes[i].radius : d->lever; }
  Convex convex(int i) const {
    return mesh ? makeTriangle(*d, d->nodes[i].tri, R, p, shift) : makeConvex(*d, R, p, shift);
  }
};

Side makeSide(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
              const Eigen::Vector3d& shift = Eigen::Vector3d::Zero());

// The side of a body moving with m, at time t: posed, seen from its rotation centre (the pivot;
// the certified steps below bound every point's motion about it), with the pivot's velocity.
Side sideAt(const PreparedShapeData& d, const Motion& m, double t);

}  // namespace detail
}  // namespace vadop
