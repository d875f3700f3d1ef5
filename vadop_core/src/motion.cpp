#include "vadop/motion.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace {

void requireFinite(const Eigen::Vector3d& v, const std::string& what, const char* field) {
  if (!v.allFinite()) throw InvalidArgument(what + ": " + field + " is not finite");
}

void requireInRange(const std::string& error, const std::string& what) {
  if (!error.empty()) throw InvalidArgument(what + ": " + error);
}

// Every coordinate within limit (error.h: kMaxCoordinate).
void requireCoordinates(const Eigen::Vector3d& v, double limit, const std::string& what, const char* field) {
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v[k]) <= limit) continue;  // the field's name is spelled out for an error only
    requireInRange(rangeError(v[k], limit, std::string(field) + "[" + std::to_string(k) + "]", "m"), what);
  }
}

// The norm of a velocity within limit: sqrt(squaredNorm()), the value isValidMotion bounds (the
// overflow-free norm when the square overflows, for the message).
void requireSpeed(const Eigen::Vector3d& v, double limit, const std::string& what, const char* field,
                  const char* unit) {
  const double sq = v.squaredNorm();
  const double norm = std::isfinite(sq) ? std::sqrt(sq) : v.stableNorm();
  if (norm <= limit) return;  // the field's name is spelled out for an error only (a NaN goes on)
  requireInRange(rangeError(norm, limit, std::string("|") + field + "|", unit), what);
}

// The range of error.h for the fields of a motion (all finite already).
void requireMotionRange(const Eigen::Vector3d& position, const Eigen::Vector3d& pivot_offset,
                        const Eigen::Vector3d& linear_velocity, const Eigen::Vector3d& angular_velocity,
                        double t_ref, const std::string& what) {
  requireCoordinates(position, kMaxCoordinate, what, "position");
  requireCoordinates(pivot_offset, kMaxCoordinate, what, "pivot_offset");
  requireSpeed(linear_velocity, kMaxLinearSpeed, what, "linear_velocity", "m/s");
  requireSpeed(angular_velocity, kMaxAngularSpeed, what, "angular_velocity", "rad/s");
  if (!(std::abs(t_ref) <= kMaxTime)) requireInRange(rangeError(t_ref, kMaxTime, "t_ref", "s"), what);
}

}  // namespace

Eigen::Quaterniond Motion::orientationAt(double t) const {
  const Eigen::Vector3d rotation = angular_velocity * (t - t_ref);
  const double angle = rotation.norm();
  if (angle == 0.0) return orientation;
  // Fixed-frame angular velocity: the increment multiplies from the left.
  Eigen::Quaterniond q(Eigen::AngleAxisd(angle, rotation / angle) * orientation);
  q.normalize();
  return q;
}

Eigen::Matrix3d Motion::spin(double t) const {
  const Eigen::Vector3d rotation = angular_velocity * (t - t_ref);
  const double angle = rotation.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix();
}

// With s = t - t0, E = exp([w] s), c the point the body turns about (the origin when it has no
// pivot) and u = origin(t0) - c(t0), a material point p (body coordinates) is at
//   x(t0 + s) = origin(t0 + s) + E R(t0) p,   origin(t0 + s) = c(t0) + v s + E u.
// For two motions M, N (D = M minus N), x_M - x_N = D origin(s) + (E_M R_M(t0) - E_N R_N(t0)) p.
// A rotation by theta moves a vector by at most min(2, theta) times its length; E_M and E_N
// differ by a rotation of at most |D w| s (the differential of exp between two skew matrices has
// norm <= 1: integrate along the segment from w_N s to w_M s), so E_M R_M(t0) and E_N R_N(t0)
// by at most theta0 + |D w| s (bi-invariant metric), theta0 the angle between the orientations
// at t0: the second term is at most min(2, theta0 + |D w| T) r. Two bounds of |D origin(s)|, the
// smaller taken:
//  - about the pivots: D origin(s) = (D origin(t0) + D v s) + (E_M - I) D u + (E_M - E_N) u_N;
//    tight when both turn about nearly the same point (a link about its joint);
//  - along the origins' paths: origin'' = [w]^2 E u = E k with k = w x (w x u), so
//    |D origin'' | <= |D k| + min(2, |D w| s) |k_N| and D origin(s) is within s^2/2 of that of
//    D origin(t0) + D origin'(t0) s; tight for vehicles, whose far turning centres move a lot
//    with small changes of w while k (|w| |v|) does not.
// The terms linear in s are convex in s (largest at s = 0 or T); the others grow with s.
double maxDisplacement(const Motion& m, const Motion& n, double radius, double t0, double t1) {
  const double T = t1 - t0;
  const Eigen::Vector3d om = m.positionAt(t0), on = n.positionAt(t0);
  const Eigen::Vector3d cm = m.centreAt(t0), cn = n.centreAt(t0);
  const Eigen::Vector3d um = om - cm, un = on - cn;
  const Eigen::Vector3d d_origin = om - on;
  const double dw = (m.angular_velocity - n.angular_velocity).norm();
  const double theta0 = m.orientationAt(t0).angularDistance(n.orientationAt(t0));
  auto linear = [&](const Eigen::Vector3d& d_rate) { return std::max(d_origin.norm(), (d_origin + d_rate * T).norm()); };
  const double about_pivots = linear(m.linear_velocity - n.linear_velocity) +
                              std::min(2.0, m.angular_velocity.norm() * T) * (um - un).norm() +
                              std::min(2.0, dw * T) * un.norm();
  const Eigen::Vector3d vm = m.linear_velocity + m.angular_velocity.cross(um);  // the origins' velocities
  const Eigen::Vector3d vn = n.linear_velocity + n.angular_velocity.cross(un);
  const Eigen::Vector3d km = m.angular_velocity.cross(m.angular_velocity.cross(um));
  const Eigen::Vector3d kn = n.angular_velocity.cross(n.angular_velocity.cross(un));
  const double along_paths = linear(vm - vn) + 0.5 * T * T * ((km - kn).norm() + std::min(2.0, dw * T) * kn.norm());
  const double turn = std::min(2.0, theta0 + dw * T) * radius;
  // Rounding of the positions above (a few ulps of the largest coordinate involved).
  const double scale = 1.0 + std::max({om.norm(), on.norm(), cm.norm(), cn.norm()}) + radius +
                       (m.linear_velocity.norm() + n.linear_velocity.norm()) * std::abs(T);
  return std::min(about_pivots, along_paths) + turn + 1e-13 * scale;
}

Eigen::Vector3d screwPivotOffset(const Eigen::Vector3d& origin_velocity, const Eigen::Vector3d& w) {
  const double w2 = w.squaredNorm();
  if (!(w2 > 0.0)) return Eigen::Vector3d::Zero();
  return w.cross(origin_velocity) / w2;
}

Eigen::Vector3d screwPivotVelocity(const Eigen::Vector3d& origin_velocity, const Eigen::Vector3d& w) {
  const double w2 = w.squaredNorm();
  if (!(w2 > 0.0)) return origin_velocity;
  return w * (w.dot(origin_velocity) / w2);
}

Eigen::Isometry3d Motion::poseAt(double t) const {
  // One rotation exp([w] (t - t_ref)) for both the orientation and the origin's turn about the
  // pivot (positionAt and orientationAt would each compute it).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d p = position + linear_velocity * (t - t_ref);
  if (!isRotating()) {
    pose.linear() = orientation.toRotationMatrix();
    pose.translation() = p;
    return pose;
  }
  const Eigen::Matrix3d e = spin(t);
  pose.linear() = e * orientation.toRotationMatrix();
  pose.translation() = hasPivot() ? Eigen::Vector3d(p + pivot_offset - e * pivot_offset) : p;
  return pose;
}

Motion makeMotion(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                  const Eigen::Vector3d& linear_velocity,
                  const Eigen::Vector3d& angular_velocity, double t_ref) {
  const std::string what = "motion";
  requireFinite(position, what, "position");
  if (!orientation.coeffs().allFinite()) throw InvalidArgument("motion: orientation is not finite");
  if (orientation.norm() < 1e-9) {
    throw InvalidArgument("motion: orientation is a zero quaternion (norm < 1e-9)");
  }
  requireFinite(linear_velocity, what, "linear_velocity");
  requireFinite(angular_velocity, what, "angular_velocity");
  if (!std::isfinite(t_ref)) throw InvalidArgument("motion: t_ref is not finite");
  requireMotionRange(position, Eigen::Vector3d::Zero(), linear_velocity, angular_velocity, t_ref, what);
  Motion m;
  m.t_ref = t_ref;
  m.position = position;
  m.orientation = orientation.normalized();
  m.linear_velocity = linear_velocity;
  m.angular_velocity = angular_velocity;
  return m;
}

bool isValidMotion(const Motion& m) {
  // The range of error.h, as validateMotion checks it; every comparison is false for a NaN, and
  // an Inf is beyond every limit, so a non-finite value fails too.
  // (Not maxCoeff(), which may skip a NaN.)
  return (m.position.array().abs() <= kMaxCoordinate).all() && (m.pivot_offset.array().abs() <= kMaxCoordinate).all() &&
         m.linear_velocity.squaredNorm() <= kMaxLinearSpeed * kMaxLinearSpeed &&
         m.angular_velocity.squaredNorm() <= kMaxAngularSpeed * kMaxAngularSpeed && std::abs(m.t_ref) <= kMaxTime &&
         std::abs(m.orientation.squaredNorm() - 1.0) <= 1e-6;
}

void validateMotion(const Motion& m, const std::string& what) {
  requireFinite(m.position, what, "position");
  requireFinite(m.linear_velocity, what, "linear_velocity");
  requireFinite(m.angular_velocity, what, "angular_velocity");
  requireFinite(m.pivot_offset, what, "pivot_offset");
  if (!m.orientation.coeffs().allFinite()) throw InvalidArgument(what + ": orientation is not finite");
  if (std::abs(m.orientation.norm() - 1.0) > 1e-6) {
    throw InvalidArgument(what + ": orientation is not a unit quaternion (norm " +
                          std::to_string(m.orientation.norm()) + ")");
  }
  if (!std::isfinite(m.t_ref)) throw InvalidArgument(what + ": t_ref is not finite");
  requireMotionRange(m.position, m.pivot_offset, m.linear_velocity, m.angular_velocity, m.t_ref, what);
}

}  // namespace vadop
