// Rigid motion with constant linear and angular velocity (a constant twist), the model of the
// whole library. The body turns about a pivot point that moves in a straight line:
//   c(t) = position + pivot_offset + linear_velocity (t - t_ref)      (the pivot)
//   R(t) = exp([w]x (t - t_ref)) R(t_ref)                              (w: fixed frame)
//   origin(t) = c(t) - exp([w]x (t - t_ref)) pivot_offset              (the body origin)
// pivot_offset = 0 (the default) turns the body about its own origin. A vehicle driving a
// curve, or a link turning about a joint, has its pivot on the screw axis (screwPivotOffset):
// its origin then follows the true arc, where a motion about the origin would drift off along
// the tangent. It does not model acceleration: callers re-state the motion when velocities change.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>

namespace vadop {

// A body at an instant: its pose, the velocity of the pose's origin and its angular velocity
// (fixed frame); e.g. a link of a joint chain (LinkChain::stateAt).
struct PosedTwist {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
};

struct Motion {
  double t_ref = 0.0;                                      // time at which the pose holds
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // body origin in the fixed frame
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // normalised
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   // of the pivot (= origin by default)
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // fixed frame, rad/s
  Eigen::Vector3d pivot_offset = Eigen::Vector3d::Zero();  // pivot - origin at t_ref, fixed frame

  Eigen::Vector3d positionAt(double t) const {
    const Eigen::Vector3d p = position + linear_velocity * (t - t_ref);
    return hasPivot() ? Eigen::Vector3d(p + pivot_offset - spin(t) * pivot_offset) : p;
  }
  Eigen::Vector3d pivotAt(double t) const { return position + pivot_offset + linear_velocity * (t - t_ref); }
  // The point the body turns about and that moves in a straight line: the pivot when hasPivot(),
  // else the origin (a motion that does not turn moves its origin, whatever its pivot_offset).
  Eigen::Vector3d centreAt(double t) const { return hasPivot() ? pivotAt(t) : positionAt(t); }
  // How far the origin stays from centreAt: |pivot_offset| when hasPivot(), else 0.
  double pivotArm() const { return hasPivot() ? pivot_offset.norm() : 0.0; }
  Eigen::Quaterniond orientationAt(double t) const;
  Eigen::Isometry3d poseAt(double t) const;
  bool isRotating() const { return angular_velocity.squaredNorm() > 0.0; }
  // Whether the pivot differs from the origin in a way that matters (rotating, non-zero offset).
  bool hasPivot() const { return isRotating() && pivot_offset.squaredNorm() > 0.0; }
  // Velocity of the material point at x (fixed frame) at time t.
  Eigen::Vector3d velocityOfPoint(const Eigen::Vector3d& x, double t) const {
    return linear_velocity + angular_velocity.cross(x - pivotAt(t));
  }
  // exp([w]x (t - t_ref)): the rotation accumulated since t_ref.
  Eigen::Matrix3d spin(double t) const;
};

// The pivot offset that makes a motion with angular velocity w, whose origin moves at
// origin_velocity, a screw about its axis: the axis point nearest the origin,
// w x origin_velocity / |w|^2 (zero when w = 0). The pivot's own velocity is then the part
// of origin_velocity along w: screwPivotVelocity.
Eigen::Vector3d screwPivotOffset(const Eigen::Vector3d& origin_velocity, const Eigen::Vector3d& w);
Eigen::Vector3d screwPivotVelocity(const Eigen::Vector3d& origin_velocity, const Eigen::Vector3d& w);

// A bound on how far apart one body is placed by two motions: the largest distance, over
// every t in [t0, t1] and every material point within `radius` of the body origin, between the
// point moved by `m` and the same point moved by `n` (the Hausdorff distance between the two
// placements of a shape whose bounding_radius is `radius`). The gap between two bodies under
// new motions is at least their gap under old ones minus both bodies' bounds: what lets a
// verdict of the narrow phase outlive small changes of velocity (WorldConfig::coherence).
// Closed form, never below the true value (derivation in motion.cpp); exact for pure
// translations, and 0 for two motions describing the same trajectory up to rounding.
// Requires t0 <= t1 and valid motions (not checked: a hot-path helper).
double maxDisplacement(const Motion& m, const Motion& n, double radius, double t0, double t1);

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
