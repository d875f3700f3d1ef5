// One velocity gate (~bodies[i].gate): what vadop_monitor publishes on a body's cmd_vel_out for
// each command on its cmd_vel_in, and when the commands stop. Every finite command is checked
// by MonitorCore::checkCommand and forwarded scaled to what is clear; a command it cannot check
// (NaN/Inf, stale state, missing transform, body not monitored yet, a stale sensor, another
// moving body not ignored that has sent no state yet) becomes a zero Twist; when
// commands stop for cmd_timeout, one zero Twist. The check assumes the base executes a command
// reaction_time after it is published (the last one forwarded goes on meanwhile) and, with the
// body's max_linear_decel / max_angular_decel, that it can brake to standstill along the
// command's arc: a scale is clear when that manoeuvre touches nothing, against the others as
// predicted and, with others_may_stop, braking too (GateState's rule and future). It does not
// hold, repeat or smooth commands, limit accelerations, or act between commands. No ROS
// transport: the node subscribes and publishes, tests drive it directly.
#pragma once

#include "vadop_ros/monitor_core.h"
#include "vadop_ros/params.h"

#include <vadop/GateState.h>

#include <geometry_msgs/Twist.h>
#include <ros/time.h>

#include <cstdint>
#include <string>
#include <vector>

namespace vadop_ros {

class VelocityGate {
 public:
  // `body`: index of a moving body of `registry` whose params have a gate.
  VelocityGate(size_t body, const BodyRegistry& registry);

  size_t body() const { return body_; }
  const GateParams& params() const { return params_; }

  // A command received at `now`: the Twist to publish on cmd_vel_out (always one).
  geometry_msgs::Twist onCommand(MonitorCore& core, const geometry_msgs::Twist& command, const ros::Time& now,
                                 TransformSource& tf);
  // Called every cycle: true, once, with `out` a zero Twist, when no command arrived for
  // cmd_timeout since the last one (none before the first command).
  bool onCycle(const ros::Time& now, geometry_msgs::Twist& out);

  const vadop::GateState& state() const { return state_; }
  const CommandCheck& lastCheck() const { return check_; }
  struct Counts {
    uint64_t commands = 0, clear = 0, slowed = 0, stopped = 0, unchecked = 0, bad = 0, timeouts = 0;
  };
  const Counts& counts() const { return counts_; }

 private:
  void publishZero(const std::string& reason, const std::string& detail, const geometry_msgs::Twist& in);
  // Some moving body other than the gate's, not left out by its ignore globs, has sent no state
  // yet; `why` names it.
  bool unheardBody(const MonitorCore& core, std::string& why);

  size_t body_;
  // unheardBody's cursor: the bodies before it have been heard since the registry's reset
  // number heard_resets_ (has_state turns false only on a reset), so a command looks at each
  // body about once, not a fleet's 10,000 each time.
  size_t heard_upto_ = 0;
  uint64_t heard_resets_ = ~uint64_t{0};
  GateParams params_;
  std::vector<char> ignored_;  // by registry element: matched by params_.ignore
  vadop::GateState state_;
  CommandCheck check_;
  Counts counts_;
  bool has_command_ = false, timed_out_ = false;
  // The body's braking model (BodyParams) and the last command published: it goes on during the
  // reaction time of the next check.
  bool braking_ = false;
  double linear_decel_ = 0.0, angular_decel_ = 0.0;
  geometry_msgs::Twist forwarded_;
  ros::Time last_command_;
  double last_warn_ = -1e300;  // wall seconds
};

}  // namespace vadop_ros
