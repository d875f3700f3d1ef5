// Posing a body for a query: makeSide, sideAt. See body_side.h.
#include "body_side.h"

namespace vadop {
namespace detail {

Side makeSide(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
              const Eigen::Vector3d& shift) {
  Side s;
  s.d = &d;
  s.R = R;
  s.p = p;
  s.shift = shift;
  s.mesh = d.kind == CoreKind::kMesh;
  return s;
}

// The side of a body moving with m, at time t: posed, seen from its rotation centre (the pivot;
// the certified steps below bound every point's motion about it), with the pivot's velocity.
Side sideAt(const PreparedShapeData& d, const Motion& m, double t) {
  // One rotation E = exp([w] (t - t_ref)) gives both the orientation (E R(t_ref), as
  // orientationAt) and the origin's offset from the pivot (-E pivot_offset, as positionAt):
  // every advancement step poses both bodies, and each exp costs a sincos.
  const bool turning = m.isRotating();
  const Eigen::Matrix3d E = turning ? m.spin(t) : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d R = turning ? Eigen::Matrix3d(E * m.orientation.normalized().toRotationMatrix())
                                    : m.orientation.toRotationMatrix();
  Side s = m.hasPivot() ? makeSide(d, R, m.pivotAt(t), -(E * m.pivot_offset)) : makeSide(d, R, m.positionAt(t));
  s.kin.v = m.linear_velocity;
  s.kin.w = m.angular_velocity;
  return s;
}

}  // namespace detail
}  // namespace vadop
