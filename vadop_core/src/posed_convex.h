// A posed convex core with its rounding (a whole primitive or one triangle of a mesh): its
// support point and support value in the world frame, and the separation of two padded convex
// sets along a direction, the certificate every distance and step of the narrow phase rests
// on. It does not search for directions (gjk.h, penetration.h) nor move bodies
// (separation_step.h). Internal to the library (not installed).
#pragma once

#include "shape_core.h"

#include <Eigen/Core>

#include <array>

namespace vadop {
namespace detail {

// A posed convex core with rounding: a whole primitive or one triangle of a mesh.
struct Convex {
  const PreparedShapeData* shape = nullptr;  // null: the triangle `tri` (world frame)
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // the rotation centre (Motion's pivot)
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // body origin - p
  std::array<Eigen::Vector3d, 3> tri;
  double rounding = 0.0;
  double lever = 0.0;  // max |x - p| over the padded convex

  Eigen::Vector3d origin() const { return p + shift; }
  // A point inside the core: the body origin, or a triangle's centroid (its p is the mesh's).
  Eigen::Vector3d centre() const { return shape ? origin() : Eigen::Vector3d((tri[0] + tri[1] + tri[2]) / 3.0); }

  // Farthest core point along d (world frame; d need not be unit).
  Eigen::Vector3d support(const Eigen::Vector3d& d) const {
    if (shape == nullptr) {
      const double a = tri[0].dot(d), b = tri[1].dot(d), c = tri[2].dot(d);
      if (a >= b && a >= c) return tri[0];
      return b >= c ? tri[1] : tri[2];
    }
    return R * coreSupportBody(*shape, R.transpose() * d) + p + shift;
  }
  // Support value of the padded convex about p: max over x of (x - p).u (u need not be unit).
  // For a primitive, in its body frame: (R c + shift).u = c.(R^T u) + shift.u, one rotation
  // fewer than through support(); the certified steps evaluate it dozens of times per step.
  double h(const Eigen::Vector3d& u) const {
    if (shape == nullptr) return (support(u) - p).dot(u) + rounding * u.norm();
    const Eigen::Vector3d ub = R.transpose() * u;
    return coreSupportBody(*shape, ub).dot(ub) + shift.dot(u) + rounding * u.norm();
  }
};

// p: the rotation centre; shift: the body origin relative to it (Motion::pivot_offset turned).
inline Convex makeConvex(const PreparedShapeData& s, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
                         const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  Convex c;
  c.shape = &s;
  c.R = R;
  c.p = p;
  c.shift = shift;
  c.rounding = s.rounding;
  c.lever = s.lever + shift.norm();
  return c;
}

inline Convex makeTriangle(const PreparedShapeData& mesh, int tri, const Eigen::Matrix3d& R,
                           const Eigen::Vector3d& p, const Eigen::Vector3d& shift) {
  Convex c;
  const Tri& t = mesh.tris[tri];
  for (int k = 0; k < 3; ++k) c.tri[k] = R * t.v[k] + p + shift;
  c.p = p;
  c.shift = shift;
  c.rounding = mesh.rounding;
  c.lever = t.lever + shift.norm();
  return c;
}

// Separation of the padded convexes along unit n (from a to b): certified lower bound of
// their signed distance.
template <class CA, class CB>
double separation(const CA& A, const CB& B, const Eigen::Vector3d& n) {
  return n.dot(B.p - A.p) - A.h(n) - B.h(-n);
}

}  // namespace detail
}  // namespace vadop
