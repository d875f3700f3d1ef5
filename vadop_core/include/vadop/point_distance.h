// The distance from a point to a posed shape: what a caller asks when it decides whether a
// measured point belongs to a body it already knows (a sensor's points within a robot).
// A PointDistance prepares the shape once (a mesh's or point set's bounding-volume tree, the
// core/rounding split) and answers any number of queries at any pose, on any thread (it is
// immutable; copies share the prepared data). The gap is the narrow phase's own (distance.h,
// GJK on the shape's core, its rounding and margin subtracted exactly): for a solid shape a
// point inside gives a negative gap (an estimate of minus its depth; exact, as every gap, for
// spheres, capsules, boxes and cylinders, answered in closed form), for a mesh or point set,
// surfaces as everywhere in the library, the distance to the nearest triangle or point ball.
// It does not cull: a caller with many shapes tests their bounding spheres first
// (Shape::bounding_radius about the pose's origin).
#pragma once

#include "vadop/shapes.h"

#include <Eigen/Geometry>

#include <memory>

namespace vadop {

class PreparedShape;  // src/vadop/distance.h (internal)

class PointDistance {
 public:
  // Throws vadop::InvalidArgument when the shape is invalid (validateShape).
  explicit PointDistance(const Shape& shape);

  const Shape& shape() const;
  // The gap between the shape placed at `pose` (fixed frame) and the point `p` (fixed frame):
  // > 0 outside, within 1e-9 m of the exact distance; <= 0 on or inside a solid shape.
  // Throws vadop::InvalidArgument for a pose or point that is not finite.
  double gap(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p) const;
  // Whether `p` lies within the shape at `pose` grown by `margin` >= 0 (gap <= margin, to 1e-9
  // m). Decided first at a coarse tolerance (a fraction of the margin: a point on the surface,
  // the common case, needs few iterations), refined only when that leaves it open.
  bool within(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double margin) const;

 private:
  std::shared_ptr<const PreparedShape> shape_;
  std::shared_ptr<const PreparedShape> point_;  // a small ball: its radius is added back exactly
  // The gap's certified bounds at `tolerance`: [lower, upper] (inside a solid shape: upper <= 0).
  void bounds(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double tolerance, double& lower,
              double& upper) const;
};

}  // namespace vadop
