// Swept volumes and the swept-volume lower bound (sweptLowerBound). See swept_volume.h.
#include "swept_volume.h"

#include "advance_step.h"
#include "gjk.h"
#include "posed_convex.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace detail {

Swept sweptVolume(const PreparedShapeData& d, const Motion& m, double ta, double tb) {
  Swept s;
  s.rounding = d.rounding;
  s.seg = m.linear_velocity * (tb - ta);
  if (!m.isRotating()) {
    s.p = m.positionAt(ta);
    s.d = &d;
    s.R = m.orientation.toRotationMatrix();
    s.lever = d.lever + s.seg.norm();
    return s;
  }
  const Eigen::Matrix3d R = m.orientationAt(ta).toRotationMatrix();
  s.p = m.centreAt(ta);
  const Eigen::Vector3d shift = m.hasPivot() ? Eigen::Vector3d(m.positionAt(ta) - s.p) : Eigen::Vector3d::Zero();
  const double turn = m.angular_velocity.norm() * (tb - ta);
  if (turn <= kSmallTurn) {
    const double arm = d.lever + shift.norm();  // max |x - p| over the padded shape
    s.d = &d;
    s.R = R;
    s.shift = shift;
    s.rounding += turn * arm * (1.0 + 4.0 * kEps);
    s.lever = arm + turn * arm + s.seg.norm();
    return s;
  }
  s.rotating = true;
  s.axis = m.angular_velocity.normalized();
  // The core's points that bound it (a cylinder's end centres, with its radius added).
  double hi = -kInf, lo = kInf, rho = 0.0, extra = 0.0;
  auto visit = [&](const Eigen::Vector3d& body) {
    const Eigen::Vector3d y = R * body + shift;
    const double a = y.dot(s.axis);
    hi = std::max(hi, a);
    lo = std::min(lo, a);
    rho = std::max(rho, (y - a * s.axis).norm());
  };
  switch (d.kind) {
    case CoreKind::kPoint: visit(Eigen::Vector3d::Zero()); break;
    case CoreKind::kSegment:
    case CoreKind::kCylinder:
      visit(Eigen::Vector3d(0, 0, d.half_length));
      visit(Eigen::Vector3d(0, 0, -d.half_length));
      if (d.kind == CoreKind::kCylinder) {
        // The rim circles: radius bounded by the end centre's plus the cylinder's radius (a
        // vector of the disk moves a point by at most its length); the axial extent exactly.
        extra = d.cyl_radius;
        const Eigen::Vector3d ab = R.transpose() * s.axis;
        const double ax = R.col(2).dot(s.axis);
        const double rim = d.cyl_radius * std::sqrt(std::max(0.0, ab.squaredNorm() - ax * ax));
        hi += rim;
        lo -= rim;
      }
      break;
    case CoreKind::kBox:
      for (int k = 0; k < 8; ++k) {
        visit(Eigen::Vector3d((k & 1) ? d.half_extents.x() : -d.half_extents.x(),
                              (k & 2) ? d.half_extents.y() : -d.half_extents.y(),
                              (k & 4) ? d.half_extents.z() : -d.half_extents.z()));
      }
      break;
    case CoreKind::kPoints:
      for (const Eigen::Vector3d& q : d.points) visit(q);
      break;
    case CoreKind::kMesh:
      for (const Eigen::Vector3d& q : d.shape.points) visit(q);
      break;
  }
  s.rho = rho + extra;
  s.ax_hi = hi;
  s.ax_lo = lo;
  s.lever = s.rho + std::max(std::abs(hi), std::abs(lo)) + s.seg.norm() + s.rounding;
  return s;
}

SweptBound sweptLowerBound(const PreparedShape& a, const Motion& ma, const PreparedShape& b, const Motion& mb,
                           double ta, double tb, double stop_above) {
  const Swept A = sweptVolume(a.data(), ma, ta, tb);
  const Swept B = sweptVolume(b.data(), mb, ta, tb);
  // Rounding allowance: the separation below is computed with exact support functions but in
  // floating point, from coordinates of size `scale` (a few ulps of it each).
  const double scale = A.p.norm() + B.p.norm() + A.lever + B.lever;
  const double slack = 1e-15 * scale;
  const double rounding = A.rounding + B.rounding;
  Eigen::Vector3d guess = A.p - B.p;
  const Gjk g = runGjk(A, B, guess, 1e-9, 1e-9, 64, stop_above + rounding + slack);
  SweptBound out;
  out.iterations = g.iterations;
  if (g.overlap) {
    out.lower_bound = -kInf;
    return out;
  }
  double lower = separation(A, B, Eigen::Vector3d(-g.v / g.dist));
  if (g.best_dir.squaredNorm() > 0.0) lower = std::max(lower, separation(A, B, Eigen::Vector3d(-g.best_dir)));
  out.lower_bound = lower - slack;
  return out;
}

}  // namespace detail
}  // namespace vadop
