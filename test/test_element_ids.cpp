// Collision element ids (the vadop::World ids of BodyRegistry): unique by construction, so that no
// element is left out of the world by a name clash (issue 13, item 7).
#include "vadop_ros/monitor_core.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>

using vadop_ros::MonitorCore;
using vadop_test::FakeTf;

namespace {

nav_msgs::Odometry odom(double stamp, double x, double vx) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = "odom";
  m.child_frame_id = "bot/x";
  m.pose.pose.position.x = x;
  m.pose.pose.orientation.w = 1.0;
  m.twist.twist.linear.x = vx;
  return m;
}

// Link "x" with two collision elements (its second one was "bot/x#1") and a link named "x#1"
// (whose first element was "bot/x#1" too): before the fix the latter was left out of the world.
const char* kClashUrdf = R"(<robot name="clash">
  <link name="x">
    <collision><origin xyz="0 0 0"/><geometry><sphere radius="0.1"/></geometry></collision>
    <collision><origin xyz="0 5 0"/><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <link name="x#1">
    <collision><origin xyz="0 0 0"/><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <joint name="j" type="fixed"><parent link="x"/><child link="x#1"/><origin xyz="0 10 0"/></joint>
</robot>)";

// The body drives along +x at 1 m/s; one static sphere ahead of each element, at a gap of 1.0,
// 1.5 and 2.0 m, so that each element has its own impact at its own time.
const char* kClashParams = R"(
horizon: 3.0
bodies:
  - {name: bot, odom_topic: /bot/odom, robot_description: clash_description}
static_obstacles:
  - {name: w0, shape: {type: sphere, radius: 0.1}, pose: {position: [1.2, 0, 0]}}
  - {name: w1, shape: {type: sphere, radius: 0.1}, pose: {position: [1.7, 5, 0]}}
  - {name: w2, shape: {type: sphere, radius: 0.1}, pose: {position: [2.2, 10, 0]}}
)";

vadop_ros::ParamReader clashReader() {
  return [](const std::string& name, std::string& value) {
    if (name != "clash_description") return false;
    value = kClashUrdf;
    return true;
  };
}

}  // namespace

TEST(ElementIds, LinkNamedLikeAnotherLinksSecondElementIsMonitored) {
  MonitorCore core(vadop_ros::parseParams(vadop_test::yaml(kClashParams)), clashReader());
  ASSERT_TRUE(core.registry().geometryErrors().empty());

  // Every element has its own id; the link "x#1" keeps its name in the impacts.
  std::set<std::string> ids;
  for (const auto& e : core.registry().elements()) EXPECT_TRUE(ids.insert(e.id).second) << e.id;
  EXPECT_EQ(ids, (std::set<std::string>{"bot/x", "bot/x#1", "bot/x%231", "w0", "w1", "w2"}));

  FakeTf tf;
  core.registry().onOdometry(0, odom(10.0, 0.0, 1.0), ros::Time(10.0));
  const auto& out = core.cycle(ros::Time(10.0), tf);
  EXPECT_EQ(core.lastStats().elements_in_world, 6u);  // the old ids left one out: 5

  ASSERT_EQ(out.impacts.size(), 3u);
  const char* expected_link[] = {"x", "x", "x#1"};
  const char* expected_obstacle[] = {"w0", "w1", "w2"};
  const double expected_time[] = {1.0, 1.5, 2.0};
  for (size_t k = 0; k < 3; ++k) {
    const vadop::Impact& i = out.impacts[k];
    // One side is the body's link, the other the obstacle (the order is the world's).
    const bool bot_first = i.body_a == "bot";
    EXPECT_EQ(bot_first ? i.link_a : i.link_b, expected_link[k]) << k;
    EXPECT_EQ(bot_first ? i.body_b : i.body_a, expected_obstacle[k]) << k;
    EXPECT_NEAR(i.time_to_impact, expected_time[k], 1e-3) << k;
  }
}

TEST(ElementIds, EscapingIsOneToOne) {
  // Links whose names differ only in '%' / '#' escapes keep distinct ids.
  const char* urdf = R"(<robot name="esc">
  <link name="a"><collision><geometry><sphere radius="0.1"/></geometry></collision>
                 <collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="a#1"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="a%231"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="a%23"><collision><geometry><sphere radius="0.1"/></geometry></collision>
                    <collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <joint name="j1" type="fixed"><parent link="a"/><child link="a#1"/></joint>
  <joint name="j2" type="fixed"><parent link="a"/><child link="a%231"/></joint>
  <joint name="j3" type="fixed"><parent link="a"/><child link="a%23"/></joint>
</robot>)";
  vadop_ros::BodyRegistry r(vadop_ros::parseParams(vadop_test::yaml(
                                "bodies: [{name: b, odom_topic: /b, robot_description: d}]")),
                            [&](const std::string&, std::string& value) {
                              value = urdf;
                              return true;
                            },
                            vadop_ros::makeDefaultMeshLoader());
  std::set<std::string> ids;
  for (const auto& e : r.elements()) EXPECT_TRUE(ids.insert(e.id).second) << e.id;
  EXPECT_EQ(ids.size(), 6u);
  EXPECT_EQ(ids.count("b/a#1"), 1u);
  EXPECT_EQ(ids.count("b/a%231"), 1u);
  EXPECT_EQ(ids.count("b/a%25231"), 1u);
  EXPECT_EQ(ids.count("b/a%2523#1"), 1u);
}

TEST(ElementIds, ADuplicateIdIsAnInternalErrorAtStartUp) {
  // parseParams refuses '/' in body names; built directly, a body "a/b" and body "a"'s link "b"
  // would share the id "a/b": the registry refuses to start rather than drop one.
  vadop_ros::MonitorParams p;
  vadop_ros::BodyParams b1;
  b1.name = "a/b";
  b1.topic = "/x";
  b1.has_shape = true;
  b1.shape = vadop::makeSphere(0.1);
  vadop_ros::BodyParams b2;
  b2.name = "a";
  b2.topic = "/y";
  b2.robot_description = "d";
  p.bodies = {b1, b2};
  const auto reader = [](const std::string&, std::string& value) {
    value = "<robot name='r'><link name='b'><collision><geometry><sphere radius='0.1'/></geometry></collision></link></robot>";
    return true;
  };
  try {
    vadop_ros::BodyRegistry r(p, reader, vadop_ros::makeDefaultMeshLoader());
    FAIL() << "no error for a duplicate element id";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("internal error: collision element id \"a/b\""), std::string::npos) << e.what();
  }
}
