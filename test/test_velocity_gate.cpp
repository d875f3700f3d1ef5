// VelocityGate: what a gate publishes for each command and when the commands stop (the node
// only moves messages). The fail-safe rules: NaN/Inf -> zero; state stale or body not
// monitored -> zero for every command; another body never heard from -> zero; commands stop for cmd_timeout -> exactly one zero; the
// reasons and the limiting body in the state; the gate's own ignore list.
#include "vadop_ros/velocity_gate.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using vadop_ros::MonitorCore;
using vadop_ros::VelocityGate;
using vadop_test::FakeTf;

namespace {

nav_msgs::Odometry odom(double stamp, double x, double vx = 0.0) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = "odom";
  m.pose.pose.position.x = x;
  m.pose.pose.orientation.w = 1.0;
  m.twist.twist.linear.x = vx;
  return m;
}

geometry_msgs::Twist twist(double vx, double wz = 0.0) {
  geometry_msgs::Twist t;
  t.linear.x = vx;
  t.angular.z = wz;
  return t;
}

// The gate with the command held from the instant it is checked (reaction_time 0, the others
// as predicted, no decelerations): the scenes below pin that rule; `gate_extra` adds gate keys,
// `body_extra` keys of a.
MonitorCore makeCore(const std::string& gate_extra = "", const std::string& body_extra = "") {
  const std::string text = R"(
horizon: 5.0
stale_timeout: 0.5
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5})" + body_extra + R"(,
     gate: {cmd_vel_in: /a/cmd_in, cmd_vel_out: /a/cmd_out, time_before_collision: 5.0,
            reaction_time: 0.0, others_may_stop: false)" +
                           gate_extra + R"(}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
)";
  return MonitorCore(vadop_ros::parseParams(vadop_test::yaml(text)),
                     [](const std::string&, std::string&) { return false; });
}

}  // namespace

TEST(VelocityGate, ScalesCommandsAndNamesWhatLimitsThem) {
  MonitorCore core = makeCore();
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  EXPECT_EQ(gate.params().cmd_vel_out, "/a/cmd_out");
  // a at -2, b at 2: 3 m of gap.
  core.registry().onOdometry(0, odom(100.0, -2), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  // Backwards: clear.
  geometry_msgs::Twist out = gate.onCommand(core, twist(-1.0, 0.2), ros::Time(100.0), tf);
  EXPECT_EQ(out.linear.x, -1.0);
  EXPECT_EQ(out.angular.z, 0.2);
  EXPECT_EQ(gate.state().reason, "clear");
  EXPECT_TRUE(gate.state().limiting_body.empty());
  // Forwards over 5 s: 0.58 or so, linear and angular alike.
  out = gate.onCommand(core, twist(1.0, 0.1), ros::Time(100.0), tf);
  EXPECT_EQ(gate.state().reason, "slow");
  EXPECT_GT(gate.state().scale, 0.5);
  EXPECT_LE(gate.state().scale, 0.64);  // 0.6 straight; the 10 m arc of 0.1 rad/s bends it a little
  EXPECT_DOUBLE_EQ(out.linear.x, gate.state().scale);
  EXPECT_DOUBLE_EQ(out.angular.z, 0.1 * gate.state().scale);
  EXPECT_EQ(gate.state().limiting_body, "b");
  EXPECT_GT(gate.state().time_to_contact, 0.0);
  EXPECT_LT(gate.state().time_to_contact, 5.0);
  // b closes in at 1 m/s: standing still gives the latest first contact.
  core.registry().onOdometry(1, odom(100.1, 1.9, -1.0), ros::Time(100.1));
  core.cycle(ros::Time(100.1), tf);
  out = gate.onCommand(core, twist(1.0), ros::Time(100.1), tf);
  EXPECT_EQ(gate.state().reason, "stop");
  EXPECT_EQ(out.linear.x, 0.0);
  EXPECT_EQ(gate.counts().commands, 3u);
  EXPECT_EQ(gate.counts().stopped, 1u);
}

TEST(VelocityGate, ItsIgnoreListLeavesBodiesOut) {
  MonitorCore core = makeCore(", ignore: [\"b*\"]");
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  core.registry().onOdometry(0, odom(100.0, -2), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(100.0), tf).linear.x, 1.0);
  EXPECT_EQ(gate.state().reason, "clear");
}

TEST(VelocityGate, NeverForwardsWhatItCannotCheck) {
  MonitorCore core = makeCore();
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  // No state yet: zero.
  geometry_msgs::Twist out = gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
  EXPECT_EQ(out.linear.x, 0.0);
  EXPECT_EQ(gate.state().reason, "stale");
  EXPECT_FALSE(gate.state().detail.empty());
  core.registry().onOdometry(0, odom(100.0, -20), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(100.0), tf).linear.x, 1.0);
  // NaN and Inf anywhere: zero, counted.
  for (int k = 0; k < 6; ++k) {
    geometry_msgs::Twist bad = twist(0.5);
    double* fields[] = {&bad.linear.x, &bad.linear.y, &bad.linear.z, &bad.angular.x, &bad.angular.y, &bad.angular.z};
    *fields[k] = k % 2 ? std::numeric_limits<double>::infinity() : std::nan("");
    out = gate.onCommand(core, bad, ros::Time(100.0), tf);
    EXPECT_EQ(out.linear.x, 0.0);
    EXPECT_EQ(out.angular.z, 0.0);
    EXPECT_EQ(gate.state().reason, "bad_command");
  }
  EXPECT_EQ(gate.counts().bad, 6u);
  // Odometry older than the gate's state_timeout (the node's stale_timeout, 0.5 s): zero for
  // every command until a state arrives.
  for (double t : {100.6, 100.7, 100.8}) {
    out = gate.onCommand(core, twist(1.0), ros::Time(t), tf);
    EXPECT_EQ(out.linear.x, 0.0);
    EXPECT_EQ(gate.state().reason, "stale");
  }
  core.registry().onOdometry(0, odom(100.8, -20), ros::Time(100.8));
  EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(100.8), tf).linear.x, 1.0);
}

// Another moving body that has sent no state yet could be anywhere (the check would not see
// it): zero, naming it, until it has, or when the gate's ignore globs leave it out. A body that
// has gone stale stands at its last pose (documented) and is checked against.
TEST(VelocityGate, AnotherBodyNeverHeardFromStopsTheGate) {
  for (const std::string& extra : {std::string(), std::string(", ignore: [\"b\"]")}) {
    MonitorCore core = makeCore(extra);
    FakeTf tf;
    VelocityGate gate(0, core.registry());
    core.registry().onOdometry(0, odom(100.0, -20), ros::Time(100.0));
    core.cycle(ros::Time(100.0), tf);
    const geometry_msgs::Twist out = gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
    if (!extra.empty()) {
      EXPECT_EQ(out.linear.x, 1.0) << "b ignored";
      continue;
    }
    EXPECT_EQ(out.linear.x, 0.0);
    EXPECT_EQ(gate.state().reason, "stale");
    EXPECT_NE(gate.state().detail.find("\"b\" has sent no state yet"), std::string::npos) << gate.state().detail;
    core.registry().onOdometry(0, odom(100.1, -20), ros::Time(100.1));
    core.registry().onOdometry(1, odom(100.1, 2), ros::Time(100.1));
    core.cycle(ros::Time(100.1), tf);
    EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(100.1), tf).linear.x, 1.0);
    // b stale (0.5 s without a message), a fresh: b stands at its last pose, the gate checks.
    core.registry().onOdometry(0, odom(100.9, -20), ros::Time(100.9));
    core.cycle(ros::Time(100.9), tf);
    EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(100.9), tf).linear.x, 1.0);
    // Time jumps back (a bag restarted): every state forgotten; b unheard again stops the gate.
    core.reset();
    core.registry().onOdometry(0, odom(50.0, -20), ros::Time(50.0));
    core.cycle(ros::Time(50.0), tf);
    EXPECT_EQ(gate.onCommand(core, twist(1.0), ros::Time(50.0), tf).linear.x, 0.0);
    EXPECT_NE(gate.state().detail.find("\"b\" has sent no state yet"), std::string::npos) << gate.state().detail;
  }
}

TEST(VelocityGate, CommandsStoppingGiveExactlyOneZero) {
  MonitorCore core = makeCore(", cmd_timeout: 0.5");
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  geometry_msgs::Twist out;
  // Nothing before the first command.
  EXPECT_FALSE(gate.onCycle(ros::Time(110.0), out));
  core.registry().onOdometry(0, odom(100.0, -20), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 2), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
  EXPECT_FALSE(gate.onCycle(ros::Time(100.4), out));
  int zeros = 0;
  for (double t = 100.51; t < 103.0; t += 0.1) {
    out = twist(7.0);
    if (gate.onCycle(ros::Time(t), out)) {
      ++zeros;
      EXPECT_EQ(out.linear.x, 0.0);
    }
  }
  EXPECT_EQ(zeros, 1);
  EXPECT_EQ(gate.state().reason, "timeout");
  // A new command re-arms it.
  gate.onCommand(core, twist(1.0), ros::Time(103.0), tf);
  EXPECT_TRUE(gate.onCycle(ros::Time(103.6), out));
  EXPECT_EQ(gate.counts().timeouts, 2u);
}

// The braking rule through the gate (issue 48): a brakes at 1 m/s^2 and 2 rad/s^2, b's surface
// 0.5 m ahead; the command is held for cmd_timeout 0.5 s after the reaction time, during which
// the last forwarded command goes on.
TEST(VelocityGate, BrakingRuleUsesTheLastForwardedCommandAndSaysWhichRuleLimits) {
  MonitorCore core = makeCore(", cmd_timeout: 0.5, reaction_time: 0.1",
                              ", max_linear_decel: 1.0, max_angular_decel: 2.0");
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  core.registry().onOdometry(0, odom(100.0, -2), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, -0.5), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  // Nothing forwarded yet (zero goes on for 0.1 s): 0.5 s + s^2 / 2 <= 0.5 m: 0.60.
  geometry_msgs::Twist out = gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
  EXPECT_NEAR(out.linear.x, 0.60, 1e-9);
  EXPECT_EQ(gate.state().rule, "braking");
  EXPECT_EQ(gate.state().future, "predicted");
  EXPECT_EQ(gate.state().limiting_body, "b");
  // Again at the same instant: 0.6 m/s now goes on for 0.1 s (0.06 m): 0.5 s + s^2 / 2 <= 0.44,
  // s <= 0.5630: 0.56.
  out = gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
  EXPECT_NEAR(out.linear.x, 0.56, 1e-9);
  // A zero published (timeout) is what goes on next: back to 0.60.
  gate.onCycle(ros::Time(100.6), out);
  EXPECT_EQ(out.linear.x, 0.0);
  core.registry().onOdometry(0, odom(100.6, -2), ros::Time(100.6));
  core.registry().onOdometry(1, odom(100.6, -0.5), ros::Time(100.6));
  core.cycle(ros::Time(100.6), tf);
  out = gate.onCommand(core, twist(1.0), ros::Time(100.6), tf);
  EXPECT_NEAR(out.linear.x, 0.60, 1e-9);
}

TEST(VelocityGate, HeldRuleWithoutDecelerationsStartsAfterTheReactionTime) {
  // No decelerations: the command held over time_before_collision (1 s) after 0.1 s of the last
  // forwarded (zero): s <= 0.5 / 1.0 with b's surface 0.5 m ahead: 0.48 (0.50 touches at the
  // window's end, within the tolerance).
  MonitorCore core = makeCore(", reaction_time: 0.1, time_before_collision: 1.0");
  FakeTf tf;
  VelocityGate gate(0, core.registry());
  core.registry().onOdometry(0, odom(100.0, -2), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, -0.5), ros::Time(100.0));
  core.cycle(ros::Time(100.0), tf);
  const geometry_msgs::Twist out = gate.onCommand(core, twist(1.0), ros::Time(100.0), tf);
  EXPECT_NEAR(out.linear.x, 0.48, 1e-9);
  EXPECT_EQ(gate.state().rule, "held_command");
}
