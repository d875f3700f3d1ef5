// MonitorCore: the cycle from registry to published impacts, without ROS transport.
#include "vadop_ros/monitor_core.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>

using vadop_ros::MonitorCore;
using vadop_test::FakeTf;

namespace {

nav_msgs::Odometry odom(double stamp, double x, double y, double vx, double vy = 0.0) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = "odom";
  m.pose.pose.position.x = x;
  m.pose.pose.position.y = y;
  m.pose.pose.orientation.w = 1.0;
  m.twist.twist.linear.x = vx;
  m.twist.twist.linear.y = vy;
  return m;
}

vadop_ros::ParamReader noParams() {
  return [](const std::string&, std::string&) { return false; };
}

MonitorCore makeCore(const std::string& yaml_text, const vadop_ros::ParamReader& reader = noParams()) {
  return MonitorCore(vadop_ros::parseParams(vadop_test::yaml(yaml_text)), reader);
}

const char* kFour = R"(
horizon: 3.0
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
  - {name: c, odom_topic: /c, shape: {type: sphere, radius: 0.5}}
  - {name: d, odom_topic: /d, shape: {type: sphere, radius: 0.5}}
)";

}  // namespace

TEST(MonitorCore, HeadOnImpactAndNearMiss) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  auto& reg = core.registry();
  // a and b head-on along x: gap 4 - 1 = 3 m, closing at 2 m/s -> 1.5 s after their stamp.
  reg.onOdometry(0, odom(100.0, -2.0, 0.0, 1.0), ros::Time(100.0));
  reg.onOdometry(1, odom(100.0, 2.0, 0.0, -1.0), ros::Time(100.0));
  // c and d pass each other 1.02 m apart (2 cm clearance): never an impact.
  reg.onOdometry(2, odom(100.0, -2.0, 10.0, 1.0), ros::Time(100.0));
  reg.onOdometry(3, odom(100.0, 2.0, 11.02, -1.0), ros::Time(100.0));
  const ros::Time now(100.25);
  const vadop::ImpactArray& out = core.cycle(now, tf);
  EXPECT_EQ(out.header.stamp, now);
  EXPECT_EQ(out.header.frame_id, "odom");
  ASSERT_EQ(out.impacts.size(), 1u);
  const vadop::Impact& i = out.impacts[0];
  EXPECT_EQ(i.body_a, "a");
  EXPECT_EQ(i.body_b, "b");
  EXPECT_EQ(i.link_a, "");
  EXPECT_NEAR(i.time_to_impact, 1.25, 1e-4);
  EXPECT_NEAR((i.time_of_impact - now).toSec(), i.time_to_impact, 1e-6);
  EXPECT_NEAR(i.point.x, 0.0, 1e-3);
  EXPECT_NEAR(i.normal.x, 1.0, 1e-6);  // from a to b
  EXPECT_NEAR(i.closing_speed, 2.0, 1e-6);
  EXPECT_FALSE(i.in_contact);
  EXPECT_NEAR(core.soonest()[0], 1.25, 1e-4);
  EXPECT_TRUE(std::isinf(core.soonest()[2]));
  EXPECT_EQ(core.lastStats().impacts, 1u);
  EXPECT_EQ(core.lastStats().elements_in_world, 4u);
}

TEST(MonitorCore, ImpactsSortedAndInContactFlagged) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  auto& reg = core.registry();
  reg.onOdometry(0, odom(1.0, 0.0, 0.0, 0.0), ros::Time(1.0));
  reg.onOdometry(1, odom(1.0, 0.9, 0.0, 0.0), ros::Time(1.0));  // overlapping now
  reg.onOdometry(2, odom(1.0, 10.0, 0.0, 1.0), ros::Time(1.0));
  reg.onOdometry(3, odom(1.0, 13.0, 0.0, -1.0), ros::Time(1.0));  // impact in 1 s
  const auto& out = core.cycle(ros::Time(1.0), tf);
  ASSERT_EQ(out.impacts.size(), 2u);
  EXPECT_TRUE(out.impacts[0].in_contact);
  EXPECT_DOUBLE_EQ(out.impacts[0].time_to_impact, 0.0);
  EXPECT_EQ(out.impacts[1].body_a, "c");
  EXPECT_NEAR(out.impacts[1].time_to_impact, 1.0, 1e-4);
}

TEST(MonitorCore, IgnorePairsAndStaticPairs) {
  MonitorCore core = makeCore(R"(
ignore_pairs: [["a", "b*"]]
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
static_obstacles:
  - {name: w1, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0, 5, 0]}}
  - {name: w2, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0.5, 5, 0]}}
)");
  FakeTf tf;
  core.registry().onOdometry(0, odom(1.0, 0.0, 0.0, 0.0), ros::Time(1.0));
  core.registry().onOdometry(1, odom(1.0, 0.5, 0.0, 0.0, 2.0), ros::Time(1.0));  // touching a; heads to w1/w2
  const auto& out = core.cycle(ros::Time(1.0), tf);
  ASSERT_GE(out.impacts.size(), 1u);
  for (const auto& i : out.impacts) {
    EXPECT_FALSE(i.body_a == "a" && i.body_b == "b");
    EXPECT_FALSE(i.body_a.front() == 'w' && i.body_b.front() == 'w');  // static-static
    EXPECT_EQ(i.body_a, "b");
  }
  EXPECT_GE(core.lastStats().raw_impacts, out.impacts.size() + 2);  // a-b and w1-w2 filtered
}

TEST(MonitorCore, BadMessageDoesNotHideOtherBodies) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  auto& reg = core.registry();
  reg.onOdometry(0, odom(1.0, -2.0, 0.0, 1.0), ros::Time(1.0));
  reg.onOdometry(1, odom(1.0, 2.0, 0.0, -1.0), ros::Time(1.0));
  auto bad = odom(1.05, std::numeric_limits<double>::quiet_NaN(), 0.0, 1.0);
  EXPECT_EQ(reg.onOdometry(2, bad, ros::Time(1.05)), vadop_ros::InputResult::kInvalid);
  const auto& out = core.cycle(ros::Time(1.1), tf);
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_NEAR(out.impacts[0].time_to_impact, 1.4, 1e-4);
}

TEST(MonitorCore, PaddingAndHorizonChanges) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  auto& reg = core.registry();
  reg.onOdometry(0, odom(1.0, -2.0, 0.0, 1.0), ros::Time(1.0));
  reg.onOdometry(1, odom(1.0, 2.0, 0.0, -1.0), ros::Time(1.0));
  ASSERT_EQ(core.cycle(ros::Time(1.0), tf).impacts.size(), 1u);
  EXPECT_NEAR(core.lastImpacts().impacts[0].time_to_impact, 1.5, 1e-4);
  core.setPadding(0.1);  // both grow by 0.1: gap 2.8 -> 1.4 s
  ASSERT_EQ(core.cycle(ros::Time(1.0) + ros::Duration(0.001), tf).impacts.size(), 1u);
  EXPECT_NEAR(core.lastImpacts().impacts[0].time_to_impact, 1.399, 1e-4);
  core.setHorizon(1.0);
  EXPECT_TRUE(core.cycle(ros::Time(1.002), tf).impacts.empty());
}

TEST(MonitorCore, TimeJumpBackResets) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  core.registry().onOdometry(0, odom(10.0, -2.0, 0.0, 1.0), ros::Time(10.0));
  core.registry().onOdometry(1, odom(10.0, 2.0, 0.0, -1.0), ros::Time(10.0));
  ASSERT_EQ(core.cycle(ros::Time(10.0), tf).impacts.size(), 1u);
  core.reset();
  EXPECT_TRUE(core.cycle(ros::Time(1.0), tf).impacts.empty());
  EXPECT_EQ(core.lastStats().elements_in_world, 0u);
  // After the jump, states with small stamps are accepted again.
  EXPECT_EQ(core.registry().onOdometry(0, odom(1.0, -2.0, 0.0, 1.0), ros::Time(1.0)), vadop_ros::InputResult::kAccepted);
}

TEST(MonitorCore, MarkersStartWithDeleteAllAndUseOneNamespacePerBody) {
  MonitorCore core = makeCore(R"(
horizon: 3.0
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: capsule, radius: 0.2, length: 1.0}}
  - {name: c, odom_topic: /c, shape: {type: box, size: [1, 1, 1]}}
static_obstacles:
  - {name: w, shape: {type: cylinder, radius: 1, length: 1}, pose: {position: [0, 50, 0]}}
)");
  FakeTf tf;
  core.registry().onOdometry(0, odom(1.0, -1.0, 0.0, 1.0), ros::Time(1.0));
  core.registry().onOdometry(1, odom(1.0, 1.0, 0.0, -1.0), ros::Time(1.0));
  core.registry().onOdometry(2, odom(1.0, 20.0, 0.0, 0.0), ros::Time(1.0));
  core.cycle(ros::Time(1.0), tf);
  const auto markers = core.markers();
  ASSERT_FALSE(markers.markers.empty());
  EXPECT_EQ(markers.markers[0].action, visualization_msgs::Marker::DELETEALL);
  std::map<std::string, int> per_ns;
  std::set<std::pair<std::string, int>> ids;
  for (size_t k = 1; k < markers.markers.size(); ++k) {
    const auto& m = markers.markers[k];
    ++per_ns[m.ns];
    EXPECT_TRUE(ids.insert({m.ns, m.id}).second) << "duplicate id " << m.ns << " " << m.id;
    EXPECT_EQ(m.header.frame_id, "odom");
  }
  EXPECT_TRUE(per_ns.count("a") && per_ns.count("b") && per_ns.count("c") && per_ns.count("w"));
  EXPECT_EQ(per_ns["impacts"], 3);  // one impact: point, arrow, text
  EXPECT_EQ(per_ns["c"], 1);        // standing still: the shape only
  // a is about to hit b (0.6 s): amber; c is clear: grey.
  for (size_t k = 1; k < markers.markers.size(); ++k) {
    const auto& m = markers.markers[k];
    if (m.ns == "a") EXPECT_FLOAT_EQ(m.color.g, 0.65f);
    if (m.ns == "c") EXPECT_FLOAT_EQ(m.color.r, 0.6f);
    if (m.ns == "impacts" && m.type == visualization_msgs::Marker::TEXT_VIEW_FACING) {
      EXPECT_NE(m.text.find("a <-> b"), std::string::npos);
    }
  }
  EXPECT_EQ(vadop_ros::impactColour(0.3, 2.0)[0], 0.9f);
}

TEST(MonitorCore, RejectsABadVadopConfiguration) {
  EXPECT_THROW(makeCore("axes: 3\nphi_deg: 1.0\n"), vadop_ros::ParamError);
}

TEST(MonitorCore, RobotDrivingACurveIsPredictedOnItsArc) {
  // 1 m/s along x while turning at 1 rad/s about z: a circle of radius 1 about (0, 1). A post
  // (radius 0.1) at the top of that circle, (0, 2); the robot is a ball of radius 0.1. Contact
  // when the chord to the post is 0.2: at the angle pi - 2 asin(0.1), i.e. after 2.9413 s,
  // moving at 1 m/s at asin(0.1) from the contact normal. A straight-line extrapolation (with
  // spin) never reaches the post.
  MonitorCore core = makeCore(R"(
horizon: 5.0
bodies:
  - {name: robot, odom_topic: /r, shape: {type: sphere, radius: 0.1}}
static_obstacles:
  - {name: post, shape: {type: sphere, radius: 0.1}, pose: {position: [0.0, 2.0, 0.0]}}
)");
  FakeTf tf;
  nav_msgs::Odometry m = odom(10.0, 0.0, 0.0, 1.0);
  m.child_frame_id = "base_link";
  m.twist.twist.angular.z = 1.0;
  ASSERT_EQ(core.registry().onOdometry(0, m, ros::Time(10.0)), vadop_ros::InputResult::kAccepted);
  const vadop::ImpactArray& out = core.cycle(ros::Time(10.0), tf);
  ASSERT_EQ(out.impacts.size(), 1u);
  const vadop::Impact& i = out.impacts[0];
  EXPECT_NEAR(i.time_to_impact, M_PI - 2.0 * std::asin(0.1), 1e-3);
  EXPECT_NEAR(i.closing_speed, std::cos(std::asin(0.1)), 1e-3);
  // Halfway between the two centres: the robot's at (sin a, 1 + cos a), a = 2 asin(0.1).
  const double a = 2.0 * std::asin(0.1);
  EXPECT_NEAR(i.point.x, 0.5 * std::sin(a), 1e-3);
  EXPECT_NEAR(i.point.y, 0.5 * (1.0 + std::cos(a) + 2.0), 1e-3);
}
