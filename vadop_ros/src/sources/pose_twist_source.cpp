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

InputResult PoseTwistSource::postInvalid(std::string why, const ros::Time& receipt) {
  {
    std::lock_guard<std::mutex> guard(slot_.mutex);
    ++slot_.invalid;
    slot_.last_invalid.swap(why);
    slot_.last_invalid_receipt = receipt;
  }
  slot_.pending.store(true, std::memory_order_release);
  return InputResult::kInvalid;
}

InputResult PoseTwistSource::post(const BodyRegistry& registry, const std::string& body, const ros::Time& stamp,
                                  std::string_view pose_frame, std::string_view child_frame,
                                  const geometry_msgs::Pose& p, const geometry_msgs::Twist& t,
                                  const ros::Time& receipt) {
  std::string why;
  ros::Time used = stamp;
  {
    std::lock_guard<std::mutex> guard(slot_.mutex);
    const InputResult decision = BodyRegistry::stampDecision(used, receipt, slot_.has_state, slot_.last_stamp,
                                                             registry.maxStampSkew(), why);
    if (decision == InputResult::kOutOfOrder) {
      ++slot_.out_of_order;
      ROS_DEBUG_NAMED("vadop_monitor", "body \"%s\": message with stamp %u.%09u ignored (not newer than %u.%09u)",
                      body.c_str(), used.sec, used.nsec, slot_.last_stamp.sec, slot_.last_stamp.nsec);
    } else if (decision == InputResult::kAccepted) {
      slot_.has_state = true;
      slot_.last_stamp = used;
      VelocityState& s = slot_.state;
      s.stamp = used;
      // Assigned in place: the slot's strings keep their storage from message to message.
      if (pose_frame.empty()) {
        s.source_frame = registry.fixedFrame();
      } else {
        s.source_frame.assign(pose_frame);
      }
      s.child_frame.assign(child_frame);
      s.pose = Eigen::Isometry3d::Identity();
      s.pose.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
      s.pose.linear() = Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
                            .normalized()
                            .toRotationMatrix();
      s.v = Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z);
      s.w = Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z);
      slot_.last_receipt = receipt;
      ++slot_.accepted;
    }
    if (decision != InputResult::kInvalid) {
      slot_.pending.store(true, std::memory_order_release);
      return decision;
    }
  }
  return postInvalid(std::move(why), receipt);
}

void PoseTwistSource::collect(Body& b, BodyRegistry& registry) {
  if (!slot_.pending.load(std::memory_order_acquire)) return;
  uint64_t accepted, invalid, out_of_order;
  std::string why;
  ros::Time invalid_receipt;
  {
    std::lock_guard<std::mutex> guard(slot_.mutex);
    slot_.pending.store(false, std::memory_order_relaxed);
    accepted = slot_.accepted;
    invalid = slot_.invalid;
    out_of_order = slot_.out_of_order;
    slot_.accepted = slot_.invalid = slot_.out_of_order = 0;
    // Swapped, not copied: the slot's next message overwrites every field of what it gets back.
    if (accepted > 0) {
      std::swap(state_, slot_.state);
      b.status.last_receipt = slot_.last_receipt;
    }
    if (invalid > 0) {
      why.swap(slot_.last_invalid);
      invalid_receipt = slot_.last_invalid_receipt;
    }
  }
  if (accepted > 0) b.has_state = true;
  b.status.accepted += accepted;
  counts_.accepted += accepted;
  b.status.dropped_out_of_order += out_of_order;
  if (invalid > 0) {
    // Every drop counted; the last one's reason kept and warned about (throttled per body).
    b.status.dropped_invalid += invalid - 1;
    registry.dropMessage(b, why, invalid_receipt);
    counts_.dropped += invalid;
  }
}

void PoseTwistSource::reset() {
  std::lock_guard<std::mutex> guard(slot_.mutex);
  slot_.has_state = false;
  slot_.last_stamp = ros::Time();
  slot_.accepted = slot_.invalid = slot_.out_of_order = 0;
  slot_.pending.store(false, std::memory_order_relaxed);
  state_.stamp = ros::Time();
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
