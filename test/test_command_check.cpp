// MonitorCore::checkCommand, the velocity gate's question: the largest scale of a body-frame
// twist for which none of the body's elements touches anything within the window. Analytic
// scenes, each pinning one rule: the command is in the body frame (a body facing +y driving
// "forward" moves along +y), a body already being run into gets the scale of the latest first
// contact (driving away passes at full speed), a long body turning in place sweeps its ends
// (navigation2#3171), the arc keeps its curvature, and a state it cannot check is refused.
// The scale search itself is tested against brute force in vadop_core (test_gate).
#include "vadop_ros/monitor_core.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using vadop_ros::CommandCheck;
using vadop_ros::MonitorCore;
using vadop_test::FakeTf;

namespace {

nav_msgs::Odometry odom(double stamp, double x, double y, double yaw, double vx, double wz = 0.0) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = "odom";
  m.pose.pose.position.x = x;
  m.pose.pose.position.y = y;
  m.pose.pose.orientation.z = std::sin(yaw / 2);
  m.pose.pose.orientation.w = std::cos(yaw / 2);
  m.twist.twist.linear.x = vx;  // child frame = body frame
  m.twist.twist.angular.z = wz;
  return m;
}

MonitorCore makeCore(const std::string& yaml_text) {
  return MonitorCore(vadop_ros::parseParams(vadop_test::yaml(yaml_text)),
                     [](const std::string&, std::string&) { return false; });
}

const char* kTwo = R"(
horizon: 5.0
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
)";

const Eigen::Vector3d kZero = Eigen::Vector3d::Zero();

// a: a body twist source (frame a_base, posed by tf at x = -2); b: odometry at x = 2; both still,
// their states received at 100 s; a's pose stamped `tf_stamp`.
const char* kTwistAndOdometry = R"(
horizon: 5.0
bodies:
  - {name: a, twist_topic: /a, frame: a_base, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
)";
void poseA(FakeTf& tf, const ros::Time& tf_stamp) {
  Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
  at.translation() = Eigen::Vector3d(-2, 0, 0);
  tf.set("odom", "a_base", at, tf_stamp);
}
void stateTwistAndOdometry(MonitorCore& core, FakeTf& tf, const ros::Time& tf_stamp) {
  poseA(tf, tf_stamp);
  geometry_msgs::TwistStamped tw;
  tw.header.stamp = ros::Time(100.0);
  ASSERT_EQ(core.registry().onTwist(0, tw, ros::Time(100.0)), vadop_ros::InputResult::kAccepted);
  ASSERT_EQ(core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0)),
            vadop_ros::InputResult::kAccepted);
}

}  // namespace

// a at x = -2 and b at x = 2, both still: a gap of 3 m ahead of a.
TEST(CommandCheck, ForwardIntoAStillBodyIsScaledToStopShortOfIt) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  // 1 m/s for 1 s covers 1 m of the 3: clear at full speed.
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 1.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_TRUE(c.scale.clear);
  EXPECT_EQ(c.scale.scale, 1.0);
  EXPECT_FALSE(c.limited);
  // Over 5 s, s m/s covers 5 s m: clear below s = 0.6, so the grid's 0.58 (0.6 itself touches
  // within the tolerance at the window's end).
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_TRUE(c.scale.clear);
  EXPECT_GE(c.scale.scale, 0.58 - 1e-9);
  EXPECT_LE(c.scale.scale, 0.6 + 1e-9);
  ASSERT_TRUE(c.limited);
  EXPECT_EQ(core.registry().elements()[c.other].id, "b");
  // The contact just above: 3 m at (scale + 0.02) m/s.
  EXPECT_NEAR(c.time_to_contact, 3.0 / (c.scale.scale + 0.02), 1e-3);
  // Backwards: away from b, nothing behind a.
  c = core.checkCommand(0, {-1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  EXPECT_TRUE(c.scale.clear);
  EXPECT_EQ(c.scale.scale, 1.0);
}

// The same gap, but a faces +y (yaw 90 deg) and b is 3 m ahead of it along +y: "forward" in the
// body frame is +y in the fixed frame.
TEST(CommandCheck, TheCommandIsInTheBodyFrame) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, 0, -2, M_PI / 2, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 0, 2, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_LE(c.scale.scale, 0.6 + 1e-9);
  EXPECT_GE(c.scale.scale, 0.58 - 1e-9);
  // Sideways in the body frame (its y = fixed -x): clear.
  c = core.checkCommand(0, {0, 1, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  EXPECT_EQ(c.scale.scale, 1.0);
}

// b drives into a standing a at 1 m/s: contact at 3 s whatever a does not do. Stopping does not
// help, so a may drive away at full speed; driving towards b only brings the contact closer.
TEST(CommandCheck, ABodyBeingRunIntoMayAlwaysDriveAway) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, M_PI, 1.0), ros::Time(100.0));  // facing -x
  core.cycle(ros::Time(100.0), tf);
  CommandCheck c = core.checkCommand(0, {-1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_TRUE(c.scale.clear);
  EXPECT_EQ(c.scale.scale, 1.0);
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_FALSE(c.scale.clear);
  EXPECT_EQ(c.scale.scale, 0.0);  // the latest first contact: standing still
  ASSERT_TRUE(c.limited);
  EXPECT_NEAR(c.time_to_contact, 3.0, 1e-3);
}

// A 4 m long box (half-width 0.2 m) turning in place about its centre, a pillar of radius
// 0.2 m 1.5 m to its side (navigation2#3171: pure rotations slip through footprint checks).
// Turned by theta, the pillar's centre lies at (1.5 sin theta, 1.5 cos theta) in the box frame,
// within the box's length, 1.5 cos theta - 0.2 from its long side: contact at
// cos theta = 0.4 / 1.5, theta = 1.3010 rad.
TEST(CommandCheck, ALongBodyTurningInPlaceIsStoppedBeforeThePillar) {
  MonitorCore core = makeCore(R"(
horizon: 5.0
bodies:
  - {name: cart, odom_topic: /cart, shape: {type: box, size: [4.0, 0.4, 0.4]}}
static_obstacles:
  - {name: pillar, shape: {type: sphere, radius: 0.2}, pose: {position: [0.0, 1.5, 0.0]}}
)");
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, 0, 0, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  // Straight ahead along its long axis: the pillar stays 1.3 m to the side.
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 2.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_EQ(c.scale.scale, 1.0);
  // 1 rad/s for 2 s would turn 2 rad: clear while 2 s < 1.3010, the grid's 0.64.
  const double theta = std::acos(0.4 / 1.5);
  c = core.checkCommand(0, kZero, {0, 0, 1}, ros::Time(100.0), tf, 2.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_TRUE(c.scale.clear);
  EXPECT_NEAR(c.scale.scale, 0.64, 1e-9);
  ASSERT_TRUE(c.limited);
  EXPECT_EQ(core.registry().elements()[c.other].id, "pillar");
  EXPECT_NEAR(c.time_to_contact, theta / 0.66, 1e-3);
  // Turning the other way sweeps the other end into it just the same.
  c = core.checkCommand(0, kZero, {0, 0, -1}, ros::Time(100.0), tf, 2.0, 0.5);
  EXPECT_NEAR(c.scale.scale, 0.64, 1e-9);
}

// The arc keeps its curvature: a body at the origin facing +x driving at 1 m/s while turning
// at 0.5 rad/s follows the circle of radius 2 about (0, 2). An obstacle on that circle, a
// quarter turn on (at (2, 2)), is hit; one on the tangent (at (3.14, 0)) is not.
TEST(CommandCheck, TheCommandedArcIsFollowed) {
  const char* scene = R"(
horizon: 5.0
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.2}}
static_obstacles:
  - {name: o, shape: {type: sphere, radius: 0.2}, pose: {position: [%f, %f, 0.0]}}
)";
  char text[512];
  std::snprintf(text, sizeof text, scene, 2.0, 2.0);
  MonitorCore on_arc = makeCore(text);
  std::snprintf(text, sizeof text, scene, 3.14, 0.0);
  MonitorCore on_tangent = makeCore(text);
  FakeTf tf;
  for (MonitorCore* core : {&on_arc, &on_tangent}) {
    core->registry().onOdometry(0, odom(100.0, 0, 0, 0, 0), ros::Time(100.0));
    core->cycle(ros::Time(100.0), tf);
  }
  // The quarter circle is pi m long: 3.14 s at full speed, less the 0.4 m of the radii.
  CommandCheck c = on_arc.checkCommand(0, {1, 0, 0}, {0, 0, 0.5}, ros::Time(100.0), tf, 4.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_LT(c.scale.scale, 1.0);
  EXPECT_TRUE(c.limited);
  c = on_tangent.checkCommand(0, {1, 0, 0}, {0, 0, 0.5}, ros::Time(100.0), tf, 4.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_EQ(c.scale.scale, 1.0);
}

TEST(CommandCheck, WhatCannotBeCheckedIsSaidNotGuessed) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  // No state yet.
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 1.0, 0.5);
  EXPECT_EQ(c.status, CommandCheck::Status::kNoState);
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0));
  // A state, but no cycle yet: its elements are not in the world.
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 1.0, 0.5);
  EXPECT_EQ(c.status, CommandCheck::Status::kNotInWorld) << c.why;
  core.cycle(ros::Time(100.0), tf);
  // Stale for this gate (0.5 s without odometry) although the node's own cycle still predicts.
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.6), tf, 1.0, 0.5);
  EXPECT_EQ(c.status, CommandCheck::Status::kStale) << c.why;
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.6), tf, 1.0, 1.0);
  EXPECT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  // Not a moving body; out of range.
  EXPECT_EQ(core.checkCommand(7, {1, 0, 0}, kZero, ros::Time(100.0), tf, 1.0, 0.5).status,
            CommandCheck::Status::kNoState);
  // A command far beyond the library's speed range is refused, not forwarded.
  c = core.checkCommand(0, {1e9, 0, 0}, kZero, ros::Time(100.0), tf, 1.0, 0.5);
  EXPECT_NE(c.status, CommandCheck::Status::kChecked);
  // Skipping b: nothing left to touch.
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5,
                        [&](size_t e) { return core.registry().elements()[e].id == "b"; });
  EXPECT_EQ(c.scale.scale, 1.0);
}

// A body twist source whose frame has no transform: the gate cannot place the body.
TEST(CommandCheck, AMissingTransformIsReported) {
  MonitorCore core = makeCore(kTwistAndOdometry);
  FakeTf tf;
  stateTwistAndOdometry(core, tf, ros::Time(1.0));
  core.cycle(ros::Time(100.0), tf);
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_LE(c.scale.scale, 0.6 + 1e-9);
  tf.erase("a_base");
  c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  EXPECT_EQ(c.status, CommandCheck::Status::kTfMissing) << c.why;
}

// States the library cannot carry to now: a gate refuses them instead of throwing (the node's
// callback would die) or forwarding. A body twist source whose frame's pose comes from tf
// stamped far from the clock (its motion's reference time beyond the library's range), and an
// odometry received after the clock (the clock went back past it: its age is unknown).
TEST(CommandCheck, StatesFarFromTheClockAreRefusedNotThrown) {
  MonitorCore core = makeCore(kTwistAndOdometry);
  FakeTf tf;
  stateTwistAndOdometry(core, tf, ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  // a's pose is now stamped 2e7 s: the gate places the body anew and cannot.
  poseA(tf, ros::Time(2e7));
  ASSERT_NO_THROW(c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5));
  EXPECT_EQ(c.status, CommandCheck::Status::kTfMissing) << c.why;
  EXPECT_NE(c.why.find("out of range"), std::string::npos) << c.why;
  // b's odometry was received at 100 s; the clock is now at 99 s.
  ASSERT_NO_THROW(c = core.checkCommand(1, {1, 0, 0}, kZero, ros::Time(99.0), tf, 5.0, 0.5));
  EXPECT_EQ(c.status, CommandCheck::Status::kStale) << c.why;
  EXPECT_NE(c.why.find("went back"), std::string::npos) << c.why;
  // Within the clock's lag (a simulated /clock behind its messages): checked.
  c = core.checkCommand(1, {1, 0, 0}, kZero, ros::Time(99.9), tf, 5.0, 0.5);
  EXPECT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
}

// The markers of a checked command: the body's sweep under the gated command, in the gate's
// namespace, ending where the scaled command takes it; nothing for a command not checked.
// The node runs the cycle in phases and predicts outside its lock: between the phases a gate
// answers from the world of the last cycle's end (not the one predicting); the new states
// count once the cycle is finished.
TEST(CommandCheck, BetweenTheCyclesPhasesTheGateSeesTheLastCyclesWorld) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 2.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  core.registry().onOdometry(1, odom(100.1, 0, 0, 0, 0), ros::Time(100.1));  // b now 1 m from a
  const ros::Time now(100.1);
  core.startCycle(now, tf);
  core.predictCycle();
  // 1 m/s for 2 s covers 2 m of the 3 to where b was at the last cycle's end: clear.
  c = core.checkCommand(0, {1, 0, 0}, kZero, now, tf, 2.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_TRUE(c.scale.clear);
  EXPECT_EQ(c.scale.scale, 1.0);
  EXPECT_FALSE(core.retryCycle(now));
  EXPECT_TRUE(core.finishCycle(now).impacts.empty());
  // Now b is 1 m away: s m/s for 2 s reaches it at s = 0.5.
  c = core.checkCommand(0, {1, 0, 0}, kZero, now, tf, 2.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  EXPECT_GE(c.scale.scale, 0.48 - 1e-9);
  EXPECT_LE(c.scale.scale, 0.5 + 1e-9);
  ASSERT_TRUE(c.limited);
  EXPECT_EQ(core.registry().elements()[c.other].id, "b");
}

TEST(CommandCheck, MarkersDrawTheGatedSweep) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  const CommandCheck c = core.checkCommand(0, {1, 0, 0}, kZero, ros::Time(100.0), tf, 5.0, 0.5);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked) << c.why;
  visualization_msgs::MarkerArray out;
  core.appendCommandMarkers(c, "gate/a", out);
  ASSERT_FALSE(out.markers.empty());
  double farthest = -1e9;
  for (const auto& m : out.markers) {
    EXPECT_EQ(m.ns, "gate/a");
    EXPECT_NE(m.action, visualization_msgs::Marker::DELETEALL);
    if (m.type == visualization_msgs::Marker::SPHERE) farthest = std::max(farthest, m.pose.position.x);
  }
  // The end pose: -2 + scale * 5 s.
  EXPECT_NEAR(farthest, -2.0 + 5.0 * c.scale.scale, 1e-6);
  CommandCheck unchecked;
  visualization_msgs::MarkerArray none;
  core.appendCommandMarkers(unchecked, "gate/a", none);
  EXPECT_TRUE(none.markers.empty());
}

// A gate's decision: one text above its body (top of its 0.5 m ball + kGateDecisionRaise) in the
// gate's namespace; nothing while the body is not in the world.
TEST(CommandCheck, GateDecisionDrawnAboveItsBody) {
  MonitorCore core = makeCore(kTwo);
  FakeTf tf;
  vadop::GateState s;
  s.reason = vadop::GateState::REASON_STOP;
  s.limiting_body = "b";
  s.time_to_contact = 0.8;
  visualization_msgs::MarkerArray none;
  core.appendGateDecision(s, 0, "gate/a", none);
  EXPECT_TRUE(none.markers.empty());
  core.registry().onOdometry(0, odom(100.0, -2, 1, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2, 0, 0, 0), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  visualization_msgs::MarkerArray out;
  core.appendGateDecision(s, 0, "gate/a", out);
  ASSERT_EQ(out.markers.size(), 1u);
  const visualization_msgs::Marker& m = out.markers[0];
  EXPECT_EQ(m.ns, "gate/a");
  EXPECT_EQ(m.id, vadop_ros::kGateDecisionId);
  EXPECT_EQ(m.type, visualization_msgs::Marker::TEXT_VIEW_FACING);
  EXPECT_EQ(m.text, "stop: b in 0.80 s");
  EXPECT_NEAR(m.pose.position.x, -2.0, 1e-9);
  EXPECT_NEAR(m.pose.position.y, 1.0, 1e-9);
  EXPECT_NEAR(m.pose.position.z, 0.5 + vadop_ros::kGateDecisionRaise, 1e-9);
}

// The braking rule (issue 48), analytic: a at x = -2 facing b, a gap `gap` ahead; a brakes at
// 1 m/s^2 and 2 rad/s^2, holds a command for 0.5 s (cmd_timeout) after a reaction time.
namespace {

vadop_ros::CommandQuestion brakingQuestion(double reaction_time, double last_v) {
  vadop_ros::CommandQuestion q;
  q.v = Eigen::Vector3d(1, 0, 0);
  q.last_v = Eigen::Vector3d(last_v, 0, 0);
  q.reaction_time = reaction_time;
  q.hold = 0.5;
  q.linear_decel = 1.0;
  q.angular_decel = 2.0;
  q.others_may_stop = false;
  q.state_timeout = 0.5;
  return q;
}

// b at -2 + 1 + gap (its surface `gap` ahead of a's), moving along +x at b_speed.
void twoInLine(MonitorCore& core, FakeTf& tf, double gap, double b_speed) {
  core.registry().onOdometry(0, odom(100.0, -2, 0, 0, 0), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, -1 + gap, 0, 0, b_speed), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
}

}  // namespace

TEST(CommandCheck, BrakingRuleStopsWithinTheGapAfterHoldingTheCommand) {
  FakeTf tf;
  MonitorCore core = makeCore(kTwo);
  twoInLine(core, tf, 0.5, 0.0);
  // No reaction time: 0.5 s + s^2 / 2 <= 0.5 m, s <= 0.618: the grid's 0.60.
  CommandCheck c = core.checkCommand(0, brakingQuestion(0.0, 0.0), ros::Time(100.0), tf);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked);
  EXPECT_TRUE(c.scale.clear);
  EXPECT_NEAR(c.scale.scale, 0.60, 1e-9);
  EXPECT_TRUE(c.braking);
  EXPECT_TRUE(c.limited);
  EXPECT_EQ(c.other, 1u);
  EXPECT_NEAR(c.stop_duration, 0.60, 1e-9);
  // The manoeuvre ends when a stands: 0.5 s held, 0.6 s braking.
  EXPECT_NEAR(c.window, 1.1, 1e-9);
  ASSERT_EQ(c.paths.size(), 1u);
  EXPECT_NEAR(c.paths[0].poseAt(c.t0 + c.window).translation().x(), -2 + 0.3 + 0.18, 1e-6);
  // The last forwarded command (1 m/s) goes on for 0.1 s: 0.1 + 0.5 s + s^2 / 2 <= 0.5,
  // s <= 0.5247: 0.52.
  c = core.checkCommand(0, brakingQuestion(0.1, 1.0), ros::Time(100.0), tf);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked);
  EXPECT_NEAR(c.scale.scale, 0.52, 1e-9);
  // Without braking (0.4 s held, nothing after): s = 1 passes.
  vadop_ros::CommandQuestion held = brakingQuestion(0.0, 0.0);
  held.linear_decel = held.angular_decel = 0.0;
  held.hold = 0.4;
  c = core.checkCommand(0, held, ros::Time(100.0), tf);
  EXPECT_NEAR(c.scale.scale, 1.0, 1e-9);
  EXPECT_FALSE(c.braking);
}

TEST(CommandCheck, OthersThatMayStopAreCheckedStoppingToo) {
  FakeTf tf;
  // b 0.5 m ahead, driving away at 1 m/s: as predicted it makes room (a at full speed brakes
  // 1 m behind where b is then); stopped at once (no decelerations) it does not.
  MonitorCore core = makeCore(kTwo);
  twoInLine(core, tf, 0.5, 1.0);
  vadop_ros::CommandQuestion q = brakingQuestion(0.0, 0.0);
  CommandCheck c = core.checkCommand(0, q, ros::Time(100.0), tf);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked);
  EXPECT_NEAR(c.scale.scale, 1.0, 1e-9);
  q.others_may_stop = true;
  c = core.checkCommand(0, q, ros::Time(100.0), tf);
  EXPECT_NEAR(c.scale.scale, 0.60, 1e-9);
  EXPECT_TRUE(c.limited);
  EXPECT_TRUE(c.others_stopping);
}

TEST(CommandCheck, BackingAwayFromContactIsNeverBlockedDrivingIntoItIs) {
  FakeTf tf;
  // a touches b (gap 0) and stands; the last command was zero.
  MonitorCore core = makeCore(kTwo);
  twoInLine(core, tf, 0.0, 0.0);
  vadop_ros::CommandQuestion q = brakingQuestion(0.1, 0.0);
  q.v = Eigen::Vector3d(-1, 0, 0);
  CommandCheck c = core.checkCommand(0, q, ros::Time(100.0), tf);
  ASSERT_EQ(c.status, CommandCheck::Status::kChecked);
  EXPECT_NEAR(c.scale.scale, 1.0, 1e-9);
  q.v = Eigen::Vector3d(1, 0, 0);
  c = core.checkCommand(0, q, ros::Time(100.0), tf);
  EXPECT_EQ(c.scale.scale, 0.0);
}
