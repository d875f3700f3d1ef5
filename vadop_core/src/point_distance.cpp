#include "vadop/point_distance.h"

#include "body_side.h"
#include "convex_distance.h"
#include "mesh_queries.h"

#include "vadop/distance.h"
#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace vadop {
namespace {

// The point is a sphere's core (a point) rounded by this radius; distance() subtracts the
// rounding analytically, so adding it back is exact up to one rounding of a double.
constexpr double kPointRadius = 1e-3;
constexpr double kFineTolerance = 1e-10;  // m: gap()'s

// Spheres, capsules, boxes and cylinders: the exact gap between the shape and the point `q`
// in the shape's frame, in closed form.
double primitiveGap(const PointDistance::Primitive& s, const Eigen::Vector3d& q) {
  switch (s.kind) {
    case PointDistance::Primitive::kPoint: return q.norm() - s.rounding;
    case PointDistance::Primitive::kSegment: {
      const double z = std::clamp(q.z(), -s.half_length, s.half_length);
      return (q - Eigen::Vector3d(0.0, 0.0, z)).norm() - s.rounding;
    }
    case PointDistance::Primitive::kBox: {
      const Eigen::Vector3d out = (q.cwiseAbs() - s.half_extents);
      // Outside: the distance to the box; inside: minus the distance to the nearest face.
      return (out.cwiseMax(0.0).norm() + std::min(out.maxCoeff(), 0.0)) - s.rounding;
    }
    case PointDistance::Primitive::kCylinder: {
      // The box's rule in the plane of the axis and the point: radial and axial excess.
      const double dr = std::sqrt(q.x() * q.x() + q.y() * q.y()) - s.radius, dz = std::abs(q.z()) - s.half_length;
      return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0) - s.rounding;
    }
    case PointDistance::Primitive::kNone: break;
  }
  return std::numeric_limits<double>::quiet_NaN();  // not reached: callers check kind first
}

// The prepared shape's closed-form kind and parameters (kind kNone: convex sets, meshes and
// point sets, answered by the narrow phase's GJK).
PointDistance::Primitive primitiveOf(const detail::PreparedShapeData& d) {
  PointDistance::Primitive s;
  s.rounding = d.rounding;
  s.half_length = d.half_length;
  s.radius = d.cyl_radius;
  s.half_extents = d.half_extents;
  switch (d.kind) {
    case detail::CoreKind::kPoint: s.kind = PointDistance::Primitive::kPoint; break;
    case detail::CoreKind::kSegment: s.kind = PointDistance::Primitive::kSegment; break;
    case detail::CoreKind::kBox: s.kind = PointDistance::Primitive::kBox; break;
    case detail::CoreKind::kCylinder: s.kind = PointDistance::Primitive::kCylinder; break;
    default: s.kind = PointDistance::Primitive::kNone; break;
  }
  return s;
}

// The exact gap in closed form (true) for the primitive kinds; false for the others.
bool closedFormGap(const detail::PreparedShapeData& d, const Eigen::Isometry3d& pose, const Eigen::Vector3d& p,
                   double& gap) {
  const PointDistance::Primitive s = primitiveOf(d);
  if (s.kind == PointDistance::Primitive::kNone) return false;
  // The point in the shape's frame (the pose is a rigid transform: its linear part a rotation).
  gap = primitiveGap(s, pose.linear().transpose() * (p - pose.translation()));
  return true;
}

}  // namespace

PointDistance::PointDistance(const Shape& shape)
    : shape_(std::make_shared<const PreparedShape>(shape)),
      point_(std::make_shared<const PreparedShape>(makeSphere(kPointRadius))) {}

const Shape& PointDistance::shape() const { return shape_->shape(); }

void PointDistance::bounds(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double tolerance, double& lower,
                           double& upper) const {
  if (!p.allFinite()) throw InvalidArgument("point is not finite");
  if (!pose.matrix().allFinite()) throw InvalidArgument("pose is not finite");
  if (closedFormGap(shape_->data(), pose, p, upper)) {
    lower = upper;
    return;
  }
  const detail::Tolerances tol{tolerance, 0.0, DistanceOptions().max_iterations};
  const detail::Side a = detail::makeSide(shape_->data(), pose.linear(), pose.translation());
  const detail::Side b = detail::makeSide(point_->data(), Eigen::Matrix3d::Identity(), p);
  // A solid shape's core holding the point decides "inside": no penetration depth (EPA) is
  // computed for it, the gap's upper bound is then minus the roundings.
  const DistanceResult r =
      a.mesh ? detail::meshDistance(a, b, tol)
             : detail::convexDistance(a.convex(0), b.convex(0), a.p - b.p, tol.abs_tol, tol.rel_tol, tol.max_iter,
                                      nullptr, nullptr, false);
  upper = r.distance + kPointRadius;
  lower = r.cores_overlap ? -std::numeric_limits<double>::infinity() : r.lower_bound + kPointRadius;
  if (r.cores_overlap) upper = std::min(upper, 0.0);
}

double PointDistance::gap(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p) const {
  double lower = 0.0, upper = 0.0;
  bounds(pose, p, kFineTolerance, lower, upper);
  return upper;
}

PointDistance::Placed PointDistance::place(const Eigen::Isometry3d& pose) const {
  if (!pose.matrix().allFinite()) throw InvalidArgument("pose is not finite");
  Placed placed;
  placed.shape_ = this;
  placed.pose_ = pose;
  placed.to_body_ = pose.linear().transpose();
  placed.primitive_ = primitiveOf(shape_->data());
  return placed;
}

bool PointDistance::Placed::within(const Eigen::Vector3d& p, double margin) const {
  if (primitive_.kind == Primitive::kNone) return shape_->within(pose_, p, margin);
  if (!p.allFinite()) throw InvalidArgument("point is not finite");
  return primitiveGap(primitive_, to_body_ * (p - pose_.translation())) <= margin;
}

bool PointDistance::within(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double margin) const {
  double lower = 0.0, upper = 0.0;
  if (margin > 4.0 * kFineTolerance) {
    bounds(pose, p, 0.25 * margin, lower, upper);
    if (upper <= margin) return true;
    if (lower > margin) return false;
  }
  return gap(pose, p) <= margin;
}

}  // namespace vadop
