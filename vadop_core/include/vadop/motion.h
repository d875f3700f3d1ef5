// Rigid motion with constant linear and angular velocity, the model of the whole library.
// p(t) = position + linear_velocity (t - t_ref);  R(t) = exp([w]x (t - t_ref)) R(t_ref),
// with w the angular velocity in the fixed frame, about the body origin.
// It does not model acceleration: callers re-state the motion when velocities change.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>

namespace vadop {

struct Motion {
  double t_ref = 0.0;                                      // time at which the pose holds
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // body origin in the fixed frame
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // normalised
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // fixed frame, rad/s

  Eigen::Vector3d positionAt(double t) const { return position + linear_velocity * (t - t_ref); }
  Eigen::Quaterniond orientationAt(double t) const;
  Eigen::Isometry3d poseAt(double t) const;
  bool isRotating() const { return angular_velocity.squaredNorm() > 0.0; }
};

// Builds a Motion, normalising the quaternion. Throws vadop::InvalidArgument naming the
// field when any value is NaN/Inf or the quaternion's norm is below 1e-9 (a zero quaternion).
Motion makeMotion(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                  const Eigen::Vector3d& linear_velocity,
                  const Eigen::Vector3d& angular_velocity, double t_ref = 0.0);

// Throws vadop::InvalidArgument, prefixed with `what`, when `motion` holds a NaN/Inf or an
// orientation that is not unit length (to 1e-6).
void validateMotion(const Motion& motion, const std::string& what);
// A quick pre-test for hot paths: true only for a motion validateMotion accepts (false for a few
// valid ones too), so they call validateMotion, and build its message, only when this says no.
bool isValidMotion(const Motion& motion);

}  // namespace vadop
