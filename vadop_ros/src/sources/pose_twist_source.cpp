// The state update and motion shared by odometry and body states (pose_twist_source.h).
#include "pose_twist_source.h"

#include "../message_checks.h"

namespace vadop_ros {

bool PoseTwistSource::checkPoseTwist(const geometry_msgs::Pose& p, const geometry_msgs::Twist& t,
                                     const PoseTwistFields& fields, std::string& why) {
  return checkPoint(p.position, fields.position, why) && checkQuaternion(p.orientation, fields.orientation, why) &&
         checkVector(t.linear, vadop::kMaxLinearSpeed, "m/s", fields.linear, why) &&
         checkVector(t.angular, vadop::kMaxAngularSpeed, "rad/s", fields.angular, why);
}

InputResult PoseTwistSource::dropInvalid(BodyRegistry& registry, Body& b, const std::string& why,
                                         const ros::Time& receipt) {
  registry.dropMessage(b, why, receipt);
  ++counts_.dropped;
  return InputResult::kInvalid;
}

InputResult PoseTwistSource::accept(BodyRegistry& registry, Body& b, const ros::Time& stamp,
                                    std::string_view pose_frame, std::string_view child_frame,
                                    const geometry_msgs::Pose& p, const geometry_msgs::Twist& t,
                                    const ros::Time& receipt) {
  const InputResult stamp_result = registry.acceptStamp(b, stamp, receipt, state_.stamp);
  if (stamp_result != InputResult::kAccepted) {
    counts_.dropped += stamp_result == InputResult::kInvalid ? 1 : 0;
    return stamp_result;
  }
  b.has_state = true;
  // Assigned in place: the body's strings keep their storage from message to message.
  if (pose_frame.empty()) {
    state_.source_frame = registry.fixedFrame();
  } else {
    state_.source_frame.assign(pose_frame);
  }
  state_.child_frame.assign(child_frame);
  state_.pose = Eigen::Isometry3d::Identity();
  state_.pose.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  state_.pose.linear() = Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
                             .normalized()
                             .toRotationMatrix();
  state_.v = Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z);
  state_.w = Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z);
  b.status.last_receipt = receipt;
  ++b.status.accepted;
  ++counts_.accepted;
  return InputResult::kAccepted;
}

bool PoseTwistSource::contribute(Body& b, BodyRegistry& registry, const ros::Time& now, TransformSource& tf,
                                 BodyInputs& in) {
  const std::string& fixed = registry.fixedFrame();
  std::string error;
  ros::Time stamp;
  Eigen::Isometry3d fixed_src = Eigen::Isometry3d::Identity();
  if (state_.source_frame != fixed) {
    if (!BodyRegistry::lookup(tf, fixed, state_.source_frame, state_.stamp, fixed_src, stamp, error) &&
        !BodyRegistry::lookup(tf, fixed, state_.source_frame, ros::Time(0), fixed_src, stamp, error)) {
      registry.warnTf(b, error, now);
      return false;
    }
  }
  // Most states are in the fixed frame already: no product with the identity (a cycle computes
  // this for every body).
  const Eigen::Isometry3d fixed_child = state_.source_frame == fixed ? state_.pose : fixed_src * state_.pose;
  const Eigen::Matrix3d& r = fixed_child.linear();
  in.v = r * state_.v;
  in.w = r * state_.w;
  in.pose = fixed_child;
  in.frame = &state_.child_frame;
  in.t_ref = state_.stamp;
  const std::string& body_frame = b.params.frame;
  if (!body_frame.empty() && body_frame != state_.child_frame && !state_.child_frame.empty()) {
    // The body frame is another frame rigid with the child frame.
    Eigen::Isometry3d child_body;
    if (!BodyRegistry::lookup(tf, state_.child_frame, body_frame, ros::Time(0), child_body, stamp, error)) {
      registry.warnTf(b, error, now);
      return false;
    }
    in.pose = fixed_child * child_body;
    in.v += in.w.cross(in.pose.translation() - fixed_child.translation());
    in.frame = &body_frame;
  } else if (!body_frame.empty()) {
    in.frame = &body_frame;
  }
  return true;
}

}  // namespace vadop_ros
