#include "vadop_ros/velocity_gate.h"

#include "vadop_ros/pair_filter.h"

#include <ros/console.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace vadop_ros {
namespace {

bool finite(const geometry_msgs::Twist& t) {
  return std::isfinite(t.linear.x) && std::isfinite(t.linear.y) && std::isfinite(t.linear.z) &&
         std::isfinite(t.angular.x) && std::isfinite(t.angular.y) && std::isfinite(t.angular.z);
}

geometry_msgs::Twist scaled(const geometry_msgs::Twist& t, double s) {
  geometry_msgs::Twist out;
  out.linear.x = s * t.linear.x;
  out.linear.y = s * t.linear.y;
  out.linear.z = s * t.linear.z;
  out.angular.x = s * t.angular.x;
  out.angular.y = s * t.angular.y;
  out.angular.z = s * t.angular.z;
  return out;
}

// A sensor the gate may not go without that has no fresh message (source.h's staleInput), unless
// the gate's ignore globs match it ("<sensor>" or "<sensor>/*"); `why` names it.
bool staleSensor(const MonitorCore& core, const GateParams& gate, const ros::Time& now, std::string& why) {
  const auto ignored = [&gate](const std::string& name) {
    return anyMatched(matchingGlobs(gate.ignore, ElementKey{name, ""}));
  };
  for (const auto& source : core.bodiesSources()) {
    if (source->staleInput(now, ignored, why)) return true;
  }
  return false;
}

}  // namespace

VelocityGate::VelocityGate(size_t body, const BodyRegistry& registry)
    : body_(body), params_(registry.bodies().at(body).params.gate) {
  const auto& bodies = registry.bodies();
  const BodyParams& bp = bodies[body].params;
  braking_ = bp.hasBraking();
  linear_decel_ = bp.max_linear_decel;
  angular_decel_ = bp.max_angular_decel;
  for (const Element& e : registry.elements()) {
    ignored_.push_back(anyMatched(matchingGlobs(params_.ignore, {bodies[e.body].name, e.link})) ? 1 : 0);
  }
  state_.body = bodies[body].name;
  state_.reason = vadop::GateState::REASON_STALE;
  state_.detail = "no command yet";
  state_.time_to_contact = std::numeric_limits<double>::infinity();
}

void VelocityGate::publishZero(const std::string& reason, const std::string& detail, const geometry_msgs::Twist& in) {
  state_.scale = 0.0;
  state_.reason = reason;
  state_.detail = detail;
  state_.limiting_body.clear();
  state_.limiting_link.clear();
  state_.time_to_contact = std::numeric_limits<double>::infinity();
  state_.future.clear();
  state_.command_in = in;
  state_.command_out = geometry_msgs::Twist();
  forwarded_ = state_.command_out;
}

bool VelocityGate::unheardBody(const MonitorCore& core, std::string& why) {
  if (heard_resets_ != core.registry().resets()) {
    heard_resets_ = core.registry().resets();
    heard_upto_ = 0;
  }
  const auto& bodies = core.registry().bodies();
  for (; heard_upto_ < bodies.size(); ++heard_upto_) {
    const size_t i = heard_upto_;
    const Body& b = bodies[i];
    // The gate's own body is checked by checkCommand; a body without geometry is never met.
    if (i == body_ || b.is_static || b.has_state || b.elements.empty()) continue;
    const bool all_ignored = std::all_of(b.elements.begin(), b.elements.end(),
                                         [this](size_t e) { return e < ignored_.size() && ignored_[e] != 0; });
    if (all_ignored) continue;
    why = "body \"" + b.name + "\" has sent no state yet (it could be anywhere)";
    return true;
  }
  return false;
}

geometry_msgs::Twist VelocityGate::onCommand(MonitorCore& core, const geometry_msgs::Twist& command,
                                             const ros::Time& now, TransformSource& tf) {
  ++counts_.commands;
  has_command_ = true;
  timed_out_ = false;
  last_command_ = now;
  if (!finite(command)) {
    ++counts_.bad;
    publishZero(vadop::GateState::REASON_BAD_COMMAND, "NaN/Inf in the command", command);
    const double wall = ros::WallTime::now().toSec();
    if (wall - last_warn_ >= 5.0) {
      last_warn_ = wall;
      ROS_WARN("vadop_monitor: gate of \"%s\": a command on %s has NaN/Inf: a zero command is published instead",
               state_.body.c_str(), params_.cmd_vel_in.c_str());
    }
    return state_.command_out;
  }
  // Blind while a sensor is stale (what it would show is not known) or while a body has never
  // sent its state (it could be anywhere, and the check would not see it).
  if (std::string why; staleSensor(core, params_, now, why) || unheardBody(core, why)) {
    ++counts_.unchecked;
    publishZero(vadop::GateState::REASON_STALE, why, command);
    return state_.command_out;
  }
  CommandQuestion q;
  q.v = Eigen::Vector3d(command.linear.x, command.linear.y, command.linear.z);
  q.w = Eigen::Vector3d(command.angular.x, command.angular.y, command.angular.z);
  q.last_v = Eigen::Vector3d(forwarded_.linear.x, forwarded_.linear.y, forwarded_.linear.z);
  q.last_w = Eigen::Vector3d(forwarded_.angular.x, forwarded_.angular.y, forwarded_.angular.z);
  q.reaction_time = params_.reaction_time;
  q.hold = braking_ ? params_.cmd_timeout : params_.time_before_collision;
  q.linear_decel = linear_decel_;
  q.angular_decel = angular_decel_;
  q.others_may_stop = params_.others_may_stop;
  q.state_timeout = params_.state_timeout;
  // The registry's elements matched once (construction); tracked objects come and go: matched
  // by name when met.
  check_ = core.checkCommand(body_, q, now, tf,
                             [this, &core](size_t e) {
                               if (e < ignored_.size()) return ignored_[e] != 0;
                               return !params_.ignore.empty() &&
                                      anyMatched(matchingGlobs(params_.ignore, core.elementKey(e)));
                             });
  if (check_.status != CommandCheck::Status::kChecked) {
    ++counts_.unchecked;
    publishZero(vadop::GateState::REASON_STALE, check_.why, command);
    return state_.command_out;
  }
  const double s = check_.scale.scale;
  state_.scale = s;
  state_.detail.clear();
  if (s >= 1.0) {
    ++counts_.clear;
    state_.reason = vadop::GateState::REASON_CLEAR;
  } else if (s > 0.0) {
    ++counts_.slowed;
    state_.reason = vadop::GateState::REASON_SLOW;
  } else {
    ++counts_.stopped;
    state_.reason = vadop::GateState::REASON_STOP;
  }
  state_.rule = check_.braking ? vadop::GateState::RULE_BRAKING : vadop::GateState::RULE_HELD_COMMAND;
  if (check_.limited) {
    const ElementKey other = core.elementKey(check_.other);
    state_.limiting_body = other.body;
    state_.limiting_link = other.link;
    state_.time_to_contact = check_.time_to_contact;
    state_.future = check_.others_stopping ? vadop::GateState::FUTURE_OTHERS_STOP : vadop::GateState::FUTURE_PREDICTED;
  } else {
    state_.limiting_body.clear();
    state_.limiting_link.clear();
    state_.time_to_contact = std::numeric_limits<double>::infinity();
    state_.future.clear();
  }
  state_.command_in = command;
  state_.command_out = scaled(command, s);
  forwarded_ = state_.command_out;
  core.adoptCommand(check_);
  return state_.command_out;
}

bool VelocityGate::onCycle(const ros::Time& now, geometry_msgs::Twist& out) {
  if (!has_command_ || timed_out_) return false;
  if (secondsBetween(now, last_command_) <= params_.cmd_timeout) return false;
  timed_out_ = true;
  ++counts_.timeouts;
  publishZero(vadop::GateState::REASON_TIMEOUT,
              "no command on " + params_.cmd_vel_in + " for " + std::to_string(params_.cmd_timeout) + " s",
              geometry_msgs::Twist());
  out = state_.command_out;
  return true;
}

}  // namespace vadop_ros
