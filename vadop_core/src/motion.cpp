#include "vadop/motion.h"

#include "vadop/error.h"
#include "vadop/limits.h"

#include <cmath>

namespace vadop {
namespace {

void requireFinite(const Eigen::Vector3d& v, const std::string& what, const char* field) {
  if (!v.allFinite()) throw InvalidArgument(what + ": " + field + " is not finite");
}

void requireInRange(const std::string& error, const std::string& what) {
  if (!error.empty()) throw InvalidArgument(what + ": " + error);
}

// Every coordinate within limit (limits.h: kMaxCoordinate).
void requireCoordinates(const Eigen::Vector3d& v, double limit, const std::string& what, const char* field) {
  for (int k = 0; k < 3; ++k) {
    requireInRange(rangeError(v[k], limit, std::string(field) + "[" + std::to_string(k) + "]", "m"), what);
  }
}

// The norm of a velocity within limit: sqrt(squaredNorm()), the value isValidMotion bounds (the
// overflow-free norm when the square overflows, for the message).
void requireSpeed(const Eigen::Vector3d& v, double limit, const std::string& what, const char* field,
                  const char* unit) {
  const double sq = v.squaredNorm();
  const double norm = std::isfinite(sq) ? std::sqrt(sq) : v.stableNorm();
  requireInRange(rangeError(norm, limit, std::string("|") + field + "|", unit), what);
}

// The range of limits.h for the fields of a motion (all finite already).
void requireMotionRange(const Eigen::Vector3d& position, const Eigen::Vector3d& pivot_offset,
                        const Eigen::Vector3d& linear_velocity, const Eigen::Vector3d& angular_velocity,
                        double t_ref, const std::string& what) {
  requireCoordinates(position, kMaxCoordinate, what, "position");
  requireCoordinates(pivot_offset, kMaxCoordinate, what, "pivot_offset");
  requireSpeed(linear_velocity, kMaxLinearSpeed, what, "linear_velocity", "m/s");
  requireSpeed(angular_velocity, kMaxAngularSpeed, what, "angular_velocity", "rad/s");
  requireInRange(rangeError(t_ref, kMaxTime, "t_ref", "s"), what);
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
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = orientationAt(t).toRotationMatrix();
  pose.translation() = positionAt(t);
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
  // The range of limits.h, as validateMotion checks it; every comparison is false for a NaN, and
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
