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

  // A sphere's, capsule's, box's or cylinder's parameters, as the closed-form gap reads them.
  struct Primitive {
    enum Kind { kNone, kPoint, kSegment, kBox, kCylinder } kind = kNone;  // kNone: GJK's kinds
    double rounding = 0.0, half_length = 0.0, radius = 0.0;
    Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  };
  // The shape placed at one pose for many points (a sensor's points against one body): the
  // pose checked and inverted once, the closed-form kinds' parameters copied beside it, so that
  // within() reads nothing else. It refers to this PointDistance, which must outlive it.
  // Throws vadop::InvalidArgument for a pose that is not finite.
  class Placed {
   public:
    // PointDistance::within at the pose.
    bool within(const Eigen::Vector3d& p, double margin) const;

   private:
    friend class PointDistance;
    const PointDistance* shape_ = nullptr;
    Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
    Eigen::Matrix3d to_body_ = Eigen::Matrix3d::Identity();  // the pose's rotation, transposed
    Primitive primitive_;
  };
  Placed place(const Eigen::Isometry3d& pose) const;

 private:
  std::shared_ptr<const PreparedShape> shape_;
  std::shared_ptr<const PreparedShape> point_;  // a small ball: its radius is added back exactly
  // The gap's certified bounds at `tolerance`: [lower, upper] (inside a solid shape: upper <= 0).
  void bounds(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double tolerance, double& lower,
              double& upper) const;
};

}  // namespace vadop
