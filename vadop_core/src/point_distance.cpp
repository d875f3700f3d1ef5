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

// Spheres, capsules, boxes and cylinders: the exact gap between the shape at `pose` and the
// point, in closed form (true); false for the other kinds.
bool closedFormGap(const detail::PreparedShapeData& d, const Eigen::Isometry3d& pose, const Eigen::Vector3d& p,
                   double& gap) {
  // The point in the shape's frame (the pose is a rigid transform: its linear part a rotation).
  const Eigen::Vector3d q = pose.linear().transpose() * (p - pose.translation());
  switch (d.kind) {
    case detail::CoreKind::kPoint: gap = q.norm() - d.rounding; return true;
    case detail::CoreKind::kSegment: {
      const double z = std::clamp(q.z(), -d.half_length, d.half_length);
      gap = (q - Eigen::Vector3d(0.0, 0.0, z)).norm() - d.rounding;
      return true;
    }
    case detail::CoreKind::kBox: {
      const Eigen::Vector3d out = (q.cwiseAbs() - d.half_extents);
      // Outside: the distance to the box; inside: minus the distance to the nearest face.
      gap = (out.cwiseMax(0.0).norm() + std::min(out.maxCoeff(), 0.0)) - d.rounding;
      return true;
    }
    case detail::CoreKind::kCylinder: {
      // The box's rule in the plane of the axis and the point: radial and axial excess.
      const double dr = std::sqrt(q.x() * q.x() + q.y() * q.y()) - d.cyl_radius, dz = std::abs(q.z()) - d.half_length;
      gap = std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0) - d.rounding;
      return true;
    }
    default: return false;  // convex sets, meshes and point sets: the narrow phase's GJK
  }
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
