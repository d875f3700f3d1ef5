// What the sources that bring a body frame's pose and twist together share (odometry: one
// nav_msgs/Odometry per body; body states: one entry of a fleet's vadop/BodyStateArray): the
// checks of the pose and twist against the library's range, the stamp policy, the velocity
// state they keep, and the body frame's motion at a cycle from it (the pose transformed into
// the fixed frame with tf at the state's stamp, else the latest transform; the twist, given in
// the child frame, rotated with it; a body `frame` other than the child frame is a frame rigid
// with it, found with tf).
// It does not subscribe, or know where the pose and twist came from: each kind reads its own
// message and hands the fields over (internal to vadop_ros, not installed).
//
// Threads: a message is posted (post, postInvalid) into the body's StateSlot from any one
// thread at a time, without the node's lock (the odometry callbacks run on the transport's
// thread or the ingest spinner's); the cycle, under the node's lock, collects the slot into the
// state it reads (collect, before contribute) and applies the counts and warnings. Everything
// else here runs under the node's lock. state_slot.h says who owns what.
#pragma once

#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "state_slot.h"

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Twist.h>

#include <string>
#include <string_view>

namespace vadop_ros {

// The field names a kind's warnings give for the pose and twist (views of literals).
struct PoseTwistFields {
  std::string_view position, orientation, linear, angular;
};

class PoseTwistSource : public Source {
 public:
  const VelocityState* velocityState() const override { return &state_; }
  bool contribute(Body& b, BodyRegistry& registry, const ros::Time& now, TransformSource& tf,
                  BodyInputs& in) override;
  // The slot's latest state, counts and drops into the body (the node's lock held).
  void collect(Body& b, BodyRegistry& registry) override;
  void reset() override;
  std::string describe(const Body&, const ros::Time&) const override { return ""; }

 protected:
  // True when the pose and twist are finite, in range and the quaternion not zero, else false
  // with why not in `why` (naming the field with `fields`).
  static bool checkPoseTwist(const geometry_msgs::Pose& p, const geometry_msgs::Twist& t, const PoseTwistFields& fields,
                             std::string& why);
  // A message (or entry) that failed its checks: dropped; counted and warned about (throttled
  // per body, through the registry) when the cycle collects it. Any thread.
  InputResult postInvalid(std::string why, const ros::Time& receipt);
  // A checked pose (in `pose_frame`, empty: the fixed frame) and twist (in `child_frame`) at
  // `stamp` for body `body` (its name, for the log): the body's latest state when the stamp
  // policy accepts it (BodyRegistry::stampDecision, against the slot's last stamp), else
  // dropped or ignored. Any thread; reads only what `registry` never changes after
  // construction (fixed frame, max_stamp_skew).
  InputResult post(const BodyRegistry& registry, const std::string& body, const ros::Time& stamp,
                   std::string_view pose_frame, std::string_view child_frame, const geometry_msgs::Pose& p,
                   const geometry_msgs::Twist& t, const ros::Time& receipt);

  VelocityState state_;  // the cycle's: the node's lock
  StateSlot slot_;        // the callback's and the cycle's: its own mutex
};

}  // namespace vadop_ros
