// The public distance queries and PreparedShape (distance.h): validation, the core/rounding
// split, then a convex query or a mesh traversal. The pieces live in their own files:
// shape_core.h (cores, support mappings), posed_convex.h, gjk.cpp, penetration.cpp (EPA),
// convex_distance.cpp, mesh_bvh.cpp, mesh_queries.cpp, separation_step.cpp, swept_volume.cpp
// and advance_step.cpp (the certified steps of conservative advancement).
#include "vadop/distance.h"

#include "body_side.h"
#include "convex_distance.h"
#include "gjk.h"
#include "mesh_bvh.h"
#include "mesh_queries.h"
#include "shape_core.h"

#include "vadop/error.h"

#include <cmath>
#include <memory>
#include <string>

namespace vadop {

namespace detail {
namespace {

Tolerances distanceTolerances(const DistanceOptions& o) { return {o.tolerance, o.relative_tolerance, o.max_iterations}; }

void checkPose(const Eigen::Isometry3d& pose, const char* what) {
  if (!pose.matrix().allFinite()) throw InvalidArgument(std::string(what) + " is not finite");
}

}  // namespace
}  // namespace detail

PreparedShape::PreparedShape(const Shape& shape, int threads) {
  validateShape(shape, "shape");
  auto d = std::make_shared<detail::PreparedShapeData>();
  d->shape = shape;
  d->lever = shape.bounding_radius;
  d->rounding = shape.margin;
  switch (shape.type) {
    case ShapeType::kSphere:
      d->kind = detail::CoreKind::kPoint;
      d->rounding += shape.radius;
      break;
    case ShapeType::kCapsule:
      d->kind = detail::CoreKind::kSegment;
      d->half_length = shape.half_length;
      d->rounding += shape.radius;
      break;
    case ShapeType::kBox:
      d->kind = detail::CoreKind::kBox;
      d->half_extents = shape.half_extents;
      break;
    case ShapeType::kCylinder:
      d->kind = detail::CoreKind::kCylinder;
      d->half_length = shape.half_length;
      d->cyl_radius = shape.radius;
      break;
    case ShapeType::kConvex:
      d->kind = detail::CoreKind::kPoints;
      d->points = shape.points;
      break;
    case ShapeType::kMesh: {
      // validateShape checks the vertices; the triangles are checked here, before use.
      if (shape.triangles.empty()) throw InvalidArgument("shape: mesh triangles must not be empty");
      const int nv = static_cast<int>(shape.points.size());
      for (size_t t = 0; t < shape.triangles.size(); ++t) {
        for (int c = 0; c < 3; ++c) {
          const int idx = shape.triangles[t][c];
          if (idx < 0 || idx >= nv) {
            throw InvalidArgument("shape: mesh triangles[" + std::to_string(t) + "][" + std::to_string(c) +
                                  "] = " + std::to_string(idx) + " is out of range [0, " + std::to_string(nv) + ")");
          }
        }
      }
      d->kind = detail::CoreKind::kMesh;
      detail::buildBvh(*d, threads);
      break;
    }
  }
  data_ = std::move(d);
}

const Shape& PreparedShape::shape() const { return data_->shape; }

DistanceResult distance(const PreparedShape& a, const Eigen::Isometry3d& pose_a,
                        const PreparedShape& b, const Eigen::Isometry3d& pose_b,
                        const DistanceOptions& options) {
  detail::checkPose(pose_a, "pose_a");
  detail::checkPose(pose_b, "pose_b");
  if (!(std::isfinite(options.tolerance) && options.tolerance > 0.0) ||
      !(std::isfinite(options.relative_tolerance) && options.relative_tolerance >= 0.0) ||
      options.max_iterations <= 0) {
    throw InvalidArgument("distance options: tolerance must be finite and > 0, relative_tolerance >= 0, max_iterations > 0");
  }
  const detail::Tolerances tol = detail::distanceTolerances(options);
  const detail::Side A = detail::makeSide(a.data(), pose_a.linear(), pose_a.translation());
  const detail::Side B = detail::makeSide(b.data(), pose_b.linear(), pose_b.translation());
  if (A.mesh || B.mesh) return detail::meshDistance(A, B, tol);
  const detail::Convex ca = detail::makeConvex(a.data(), A.R, A.p);
  const detail::Convex cb = detail::makeConvex(b.data(), B.R, B.p);
  return detail::convexDistance(ca, cb, ca.p - cb.p, tol.abs_tol, tol.rel_tol, tol.max_iter, nullptr);
}

DistanceResult distance(const Shape& a, const Eigen::Isometry3d& pose_a, const Shape& b,
                        const Eigen::Isometry3d& pose_b, const DistanceOptions& options) {
  return distance(PreparedShape(a), pose_a, PreparedShape(b), pose_b, options);
}

}  // namespace vadop
