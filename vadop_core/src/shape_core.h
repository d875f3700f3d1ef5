// What a PreparedShape holds (distance.h's detail::PreparedShapeData): the shape's core (a
// point, segment, box, cylinder, convex point set or triangle mesh) and its rounding radius,
// with the mesh's triangles and sphere tree; and the support mapping of a primitive core in
// its body frame. It does not pose shapes (posed_convex.h), build the tree (mesh_bvh.h) or
// compute distances. Internal to the library (not installed).
#pragma once

#include "vadop/distance.h"
#include "vadop/shapes.h"

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <array>
#include <vector>

namespace vadop {
namespace detail {

enum class CoreKind { kPoint, kSegment, kBox, kCylinder, kPoints, kMesh };

struct Tri {
  Eigen::Vector3d v[3];  // body frame
  double lever = 0.0;    // max |x| over the padded triangle (body origin)
};

struct BvhNode {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // body frame
  double radius = 0.0;  // bounding sphere of the node's padded triangles
  int left = -1;
  int right = -1;
  int tri = -1;  // leaf: its index in tris (leaf order, not the order of shape.triangles)
};

struct PreparedShapeData {
  Shape shape;
  CoreKind kind = CoreKind::kPoint;
  double rounding = 0.0;  // sphere / capsule radius + margin; margin for the other cores
  double lever = 0.0;     // bounding_radius: max |x| over the padded shape
  double half_length = 0.0;
  double cyl_radius = 0.0;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> points;  // convex
  std::vector<Tri> tris;                // mesh
  std::vector<BvhNode> nodes;
  // Per node (same index): the axis-aligned box of its padded triangles in the body frame, as
  // centre and half extents (the world's cull of a resting mesh; a long wall's box is far
  // tighter than its ball).
  std::vector<std::array<double, 6>> node_boxes;
  int root = -1;
};

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// The support mapping of a primitive core in its body frame: its farthest point along d.
inline Eigen::Vector3d coreSupportBody(const PreparedShapeData& s, const Eigen::Vector3d& d) {
  switch (s.kind) {
    case CoreKind::kPoint: return Eigen::Vector3d::Zero();
    case CoreKind::kSegment: return Eigen::Vector3d(0.0, 0.0, d.z() >= 0.0 ? s.half_length : -s.half_length);
    case CoreKind::kBox:
      return Eigen::Vector3d(d.x() >= 0.0 ? s.half_extents.x() : -s.half_extents.x(),
                             d.y() >= 0.0 ? s.half_extents.y() : -s.half_extents.y(),
                             d.z() >= 0.0 ? s.half_extents.z() : -s.half_extents.z());
    case CoreKind::kCylinder: {
      Eigen::Vector3d p(0.0, 0.0, d.z() >= 0.0 ? s.half_length : -s.half_length);
      // sqrt, not hypot (several times slower, ~7% of a fleet's cycle): hypot only where the
      // squares would underflow (a search direction nearly along the axis).
      const double r2 = d.x() * d.x() + d.y() * d.y();
      const double r = r2 > 1e-280 ? std::sqrt(r2) : std::hypot(d.x(), d.y());
      if (r > 0.0) {
        p.x() = s.cyl_radius * (d.x() / r);
        p.y() = s.cyl_radius * (d.y() / r);
      }
      return p;
    }
    case CoreKind::kPoints: {
      const Eigen::Vector3d* best = &s.points[0];
      double bv = best->dot(d);
      for (size_t i = 1; i < s.points.size(); ++i) {
        const double v = s.points[i].dot(d);
        if (v > bv) {
          bv = v;
          best = &s.points[i];
        }
      }
      return *best;
    }
    case CoreKind::kMesh: break;  // meshes are queried triangle by triangle
  }
  return Eigen::Vector3d::Zero();
}

}  // namespace detail
}  // namespace vadop
