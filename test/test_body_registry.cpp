// The body registry: states from odometry / twist + tf, motions of every element, and the
// handling of bad messages (NaN/Inf, zero quaternion, out-of-order and duplicate stamps,
// stale bodies, missing transforms, broken URDFs) without affecting the other bodies.
#include "vadop_ros/body_registry.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <set>
#include <thread>

using vadop_ros::BodyRegistry;
using vadop_ros::BodyState;
using vadop_ros::InputResult;
using vadop_ros::MonitorParams;
using vadop_test::FakeTf;

namespace {

// Where an element's shape is at time t (registry seconds), and how fast that point moves.
Eigen::Vector3d centre(const vadop_ros::Element& e, double t) { return e.motion.positionAt(t); }
Eigen::Vector3d centreVelocity(const vadop_ros::Element& e, double t) {
  return e.motion.velocityOfPoint(centre(e, t), t);
}

const double kNaN = std::numeric_limits<double>::quiet_NaN();

MonitorParams params(const std::string& yaml_text) { return vadop_ros::parseParams(vadop_test::yaml(yaml_text)); }

nav_msgs::Odometry odom(double stamp, double x, double y, double vx, double vy = 0.0, double yaw = 0.0,
                        double wz = 0.0, const std::string& frame = "odom", const std::string& child = "") {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = frame;
  m.child_frame_id = child;
  m.pose.pose.position.x = x;
  m.pose.pose.position.y = y;
  m.pose.pose.orientation.z = std::sin(yaw / 2);
  m.pose.pose.orientation.w = std::cos(yaw / 2);
  m.twist.twist.linear.x = vx;  // body frame (child_frame_id)
  m.twist.twist.linear.y = vy;
  m.twist.twist.angular.z = wz;
  return m;
}

vadop_ros::ParamReader noParams() {
  return [](const std::string&, std::string&) { return false; };
}

const char* kThree = R"(
stale_timeout: 0.5
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
  - {name: c, odom_topic: /c, shape: {type: box, size: [1, 1, 1]}}
)";

std::string testUrdf() {
  std::string text = vadop_test::readFile(VADOP_TEST_DATA_DIR "/two_link.urdf");
  const std::string key = "@DATA_DIR@";
  for (size_t p = text.find(key); p != std::string::npos; p = text.find(key)) text.replace(p, key.size(), VADOP_TEST_DATA_DIR);
  return text;
}

}  // namespace

TEST(BodyRegistry, OdometryExtrapolatedToNowInTheFixedFrame) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  // Heading 90 degrees: the body-frame twist vx = 1 is +y in the fixed frame.
  ASSERT_EQ(r.onOdometry(0, odom(10.0, 1.0, 2.0, 1.0, 0.0, M_PI / 2), ros::Time(10.0)), InputResult::kAccepted);
  r.update(ros::Time(10.2), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  const double now = r.seconds(ros::Time(10.2));
  EXPECT_TRUE(e.motion.positionAt(now).isApprox(Eigen::Vector3d(1.0, 2.2, 0.0), 1e-9));
  EXPECT_TRUE(e.motion.linear_velocity.isApprox(Eigen::Vector3d(0, 1, 0), 1e-9));
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kOk);
  // Bodies without a message are waiting, not monitored.
  EXPECT_FALSE(r.elements()[1].active);
  EXPECT_EQ(r.bodies()[1].status.state, BodyState::kWaiting);
}

TEST(BodyRegistry, OdometryInAnotherFrameGoesThroughTf) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  Eigen::Isometry3d map_in_odom = Eigen::Isometry3d::Identity();
  map_in_odom.translation() = Eigen::Vector3d(10, 0, 0);
  map_in_odom.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("odom", "map", map_in_odom);
  ASSERT_EQ(r.onOdometry(0, odom(5.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, "map"), ros::Time(5.0)), InputResult::kAccepted);
  r.update(ros::Time(5.0), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  EXPECT_TRUE(e.motion.position.isApprox(Eigen::Vector3d(10, 1, 0), 1e-9));
  EXPECT_TRUE(e.motion.linear_velocity.isApprox(Eigen::Vector3d(0, 2, 0), 1e-9));
}

TEST(BodyRegistry, NanAndZeroQuaternionAreDroppedAndMarked) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 1), ros::Time(1.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(1.0, 5, 0, -1), ros::Time(1.0)), InputResult::kAccepted);

  EXPECT_EQ(r.onOdometry(0, odom(1.1, kNaN, 0, 1), ros::Time(1.1)), InputResult::kInvalid);
  auto inf_twist = odom(1.1, 0, 0, 1);
  inf_twist.twist.twist.angular.z = std::numeric_limits<double>::infinity();
  EXPECT_EQ(r.onOdometry(0, inf_twist, ros::Time(1.1)), InputResult::kInvalid);
  auto zero_q = odom(1.1, 0.1, 0, 1);
  zero_q.pose.pose.orientation.w = 0.0;
  EXPECT_EQ(r.onOdometry(0, zero_q, ros::Time(1.1)), InputResult::kInvalid);
  auto huge = odom(1.1, 1e12, 0, 1);
  EXPECT_EQ(r.onOdometry(0, huge, ros::Time(1.1)), InputResult::kInvalid);

  const auto& st = r.bodies()[0].status;
  EXPECT_EQ(st.dropped_invalid, 4u);
  EXPECT_NE(st.last_invalid.find("out of range"), std::string::npos);
  EXPECT_EQ(st.accepted, 1u);

  // The body keeps its last good state, and the other body is unaffected.
  r.update(ros::Time(1.2), tf);
  ASSERT_TRUE(r.elements()[0].active);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(r.seconds(ros::Time(1.2))).isApprox(Eigen::Vector3d(0.2, 0, 0), 1e-9));
  ASSERT_TRUE(r.elements()[1].active);
  EXPECT_EQ(r.bodies()[1].status.dropped_invalid, 0u);
}

TEST(BodyRegistry, NanInTwistStampedIsDropped) {
  BodyRegistry r(params(R"(
bodies:
  - {name: t, twist_topic: /t, frame: t_link, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  geometry_msgs::TwistStamped m;
  m.header.stamp = ros::Time(1.0);
  m.twist.linear.x = kNaN;
  EXPECT_EQ(r.onTwist(0, m, ros::Time(1.0)), InputResult::kInvalid);
  EXPECT_NE(r.bodies()[0].status.last_invalid.find("twist.linear.x"), std::string::npos);
}

TEST(BodyRegistry, OutOfOrderAndDuplicateStampsAreIgnored) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(2.0, 2.0, 0, 1), ros::Time(2.0)), InputResult::kAccepted);
  EXPECT_EQ(r.onOdometry(0, odom(2.0, 9.0, 0, 1), ros::Time(2.01)), InputResult::kOutOfOrder);  // duplicate
  EXPECT_EQ(r.onOdometry(0, odom(1.5, 9.0, 0, 1), ros::Time(2.02)), InputResult::kOutOfOrder);  // older
  EXPECT_EQ(r.bodies()[0].status.dropped_out_of_order, 2u);
  r.update(ros::Time(2.0), tf);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(r.seconds(ros::Time(2.0))).isApprox(Eigen::Vector3d(2, 0, 0), 1e-9));
  EXPECT_EQ(r.onOdometry(0, odom(2.1, 2.1, 0, 1), ros::Time(2.1)), InputResult::kAccepted);
}

TEST(BodyRegistry, ZeroStampUsesTheReceiptTime) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(0.0, 0, 0, 1), ros::Time(7.0)), InputResult::kAccepted);
  r.update(ros::Time(7.5), tf);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(r.seconds(ros::Time(7.5))).isApprox(Eigen::Vector3d(0.5, 0, 0), 1e-9));
}

TEST(BodyRegistry, StaleBodyStandsStillAtItsLastPose) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 3.0, 0, 1.0, 0, 0, 0.5), ros::Time(1.0)), InputResult::kAccepted);
  r.update(ros::Time(1.4), tf);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kOk);
  r.update(ros::Time(1.6), tf);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kStale);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  EXPECT_TRUE(e.motion.linear_velocity.isZero());
  EXPECT_TRUE(e.motion.angular_velocity.isZero());
  EXPECT_TRUE(e.motion.positionAt(r.seconds(ros::Time(1.6))).isApprox(Eigen::Vector3d(3, 0, 0), 1e-9));
  // A new message revives it.
  ASSERT_EQ(r.onOdometry(0, odom(1.7, 3.7, 0, 1.0), ros::Time(1.7)), InputResult::kAccepted);
  r.update(ros::Time(1.7), tf);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kOk);
}

TEST(BodyRegistry, MissingTfSkipsOnlyThatBody) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 1, 0, 0, 0, "nowhere"), ros::Time(1.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(1.0, 5, 0, -1), ros::Time(1.0)), InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  EXPECT_FALSE(r.elements()[0].active);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kTfMissing);
  EXPECT_NE(r.bodies()[0].status.tf_error.find("nowhere"), std::string::npos);
  EXPECT_TRUE(r.elements()[1].active);
  EXPECT_EQ(r.bodies()[1].status.state, BodyState::kOk);
  // The transform appears: monitored again.
  tf.set("odom", "nowhere", Eigen::Isometry3d::Identity());
  r.update(ros::Time(1.1), tf);
  EXPECT_TRUE(r.elements()[0].active);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kOk);
}

TEST(BodyRegistry, TwistWithPoseFromTf) {
  BodyRegistry r(params(R"(
bodies:
  - {name: t, twist_topic: /t, frame: t_link, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1, 1, 0);
  pose.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("odom", "t_link", pose, ros::Time(3.0));
  geometry_msgs::TwistStamped m;
  m.header.stamp = ros::Time(3.0);
  m.twist.linear.x = 2.0;  // body frame (empty frame_id): -x in odom
  ASSERT_EQ(r.onTwist(0, m, ros::Time(3.0)), InputResult::kAccepted);
  r.update(ros::Time(3.5), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  EXPECT_TRUE(e.motion.linear_velocity.isApprox(Eigen::Vector3d(-2, 0, 0), 1e-9));
  EXPECT_TRUE(e.motion.positionAt(r.seconds(ros::Time(3.5))).isApprox(Eigen::Vector3d(0, 1, 0), 1e-9));
}

TEST(BodyRegistry, RigidUrdfLinksGetTheRigidBodyVelocityField) {
  const std::string urdf = testUrdf();
  BodyRegistry r(params(R"(
bodies:
  - {name: bot, odom_topic: /bot, robot_description: bot_description}
)"),
                 [&](const std::string& name, std::string& value) {
                   if (name != "bot_description") return false;
                   value = urdf;
                   return true;
                 },
                 vadop_ros::makeDefaultMeshLoader());
  // One error: the missing mesh, naming the link.
  const auto errors = r.geometryErrors();
  ASSERT_GE(errors.size(), 1u);
  EXPECT_NE(errors[0].find("body \"bot\""), std::string::npos);
  EXPECT_NE(errors[0].find("link \"broken\""), std::string::npos);

  FakeTf tf;
  // Spinning at 1 rad/s about z, moving at 1 m/s along x; child frame = base_link.
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 1.0, 0, 0, 1.0, "odom", "bot/base_link"), ros::Time(1.0)),
            InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  const double ts = r.seconds(ros::Time(1.0));
  const auto& bodies = r.bodies();
  bool saw_arm = false;
  for (const size_t ei : bodies[0].elements) {
    const auto& e = r.elements()[ei];
    ASSERT_TRUE(e.active) << e.id;
    EXPECT_TRUE(e.motion.angular_velocity.isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
    // Every link turns about the body's screw axis (here through (0, 1, 0): v = 1 along x, w = 1
    // about z), so it follows its arc.
    EXPECT_TRUE((e.motion.pivotAt(ts) - Eigen::Vector3d(0, 1, e.motion.pivotAt(ts).z())).isZero(1e-12)) << e.id;
    const Eigen::Vector3d rr = centre(e, ts);  // body at the origin
    const Eigen::Vector3d expected = Eigen::Vector3d(1, 0, 0) + Eigen::Vector3d(0, 0, 1).cross(rr);
    EXPECT_TRUE(centreVelocity(e, ts).isApprox(expected, 1e-12)) << e.id;
    if (e.link == "arm") {
      saw_arm = true;
      EXPECT_EQ(e.id, "bot/arm");
      EXPECT_TRUE(rr.isApprox(Eigen::Vector3d(0.2, 0, 0.3), 1e-12));
      EXPECT_TRUE(centreVelocity(e, ts).isApprox(Eigen::Vector3d(1, 0.2, 0), 1e-12));
      // Half a turn later the arm (0.2 m ahead of the body, 1.2 m from the axis through
      // (0, 1)) is on the other side of that axis: (-0.2, 2, 0.3), not pi m further along x.
      EXPECT_TRUE(centre(e, ts + M_PI).isApprox(Eigen::Vector3d(-0.2, 2, 0.3), 1e-9)) << centre(e, ts + M_PI);
    }
    if (e.link == "base_link" && e.id == "bot/base_link#1") {
      EXPECT_TRUE(rr.isApprox(Eigen::Vector3d(0, 0, 0.3), 1e-12));
    }
  }
  EXPECT_TRUE(saw_arm);
}

TEST(BodyRegistry, RigidUrdfBodyFrameMayBeAChildLink) {
  const std::string urdf = testUrdf();
  BodyRegistry r(params("bodies: [{name: bot, odom_topic: /bot, robot_description: d}]"),
                 [&](const std::string&, std::string& value) {
                   value = urdf;
                   return true;
                 },
                 vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  // The odometry reports the pose of the mast link (0.4 above base_link).
  auto m = odom(1.0, 0, 0, 0);
  m.child_frame_id = "mast";
  m.pose.pose.position.z = 1.4;
  ASSERT_EQ(r.onOdometry(0, m, ros::Time(1.0)), InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  for (const size_t ei : r.bodies()[0].elements) {
    const auto& e = r.elements()[ei];
    const double ts = r.seconds(ros::Time(1.0));
    if (e.id == "bot/base_link") EXPECT_NEAR(centre(e, ts).z(), 1.0 + 0.1, 1e-12);
    if (e.id == "bot/mast") EXPECT_NEAR(centre(e, ts).z(), 1.4 + 0.5, 1e-12);
  }
}

TEST(BodyRegistry, TfLinksGetTheirOwnVelocity) {
  const std::string urdf =
      "<robot name='r'><link name='base'><collision><geometry><sphere radius='0.2'/></geometry></collision></link>"
      "<link name='arm'><collision><origin xyz='1 0 0'/><geometry><sphere radius='0.1'/></geometry></collision></link>"
      "<joint name='j' type='revolute'><parent link='base'/><child link='arm'/><axis xyz='0 0 1'/>"
      "<limit lower='-3' upper='3' effort='1' velocity='1'/></joint></robot>";
  BodyRegistry r(params("bodies: [{name: r, odom_topic: /r, robot_description: d, tf_prefix: r}]"),
                 [&](const std::string&, std::string& value) {
                   value = urdf;
                   return true;
                 },
                 vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  tf.set("odom", "r/base", Eigen::Isometry3d::Identity(), ros::Time(1.0));
  tf.set("r/base", "r/arm", Eigen::Isometry3d::Identity(), ros::Time(1.0));
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 0, 0, 0, 0, "odom", "r/base"), ros::Time(1.0)), InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  // The arm joint turns at 0.5 rad/s: tf pose at t = 1.1 rotated by 0.05 rad.
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("r/base", "r/arm", turned, ros::Time(1.1));
  ASSERT_EQ(r.onOdometry(0, odom(1.1, 0, 0, 0, 0, 0, 0, "odom", "r/base"), ros::Time(1.1)), InputResult::kAccepted);
  r.update(ros::Time(1.1), tf);
  const auto& body = r.bodies()[0];
  ASSERT_EQ(body.elements.size(), 2u);
  const auto& arm = r.elements()[body.elements[1]];
  ASSERT_EQ(arm.link, "arm");
  ASSERT_TRUE(arm.active);
  EXPECT_EQ(arm.tf_frame, "r/arm");
  EXPECT_NEAR(arm.motion.angular_velocity.z(), 0.5, 1e-9);
  // The collision origin 1 m along the arm's x moves at w x r = 0.5 * (-sin, cos) and, turning
  // about the joint (its screw axis), stays on its circle.
  EXPECT_TRUE(arm.motion.pivotAt(r.seconds(ros::Time(1.1))).isZero(1e-9));
  const double ts = r.seconds(ros::Time(1.1));
  EXPECT_NEAR(centreVelocity(arm, ts).x(), -0.5 * std::sin(0.05), 1e-9);
  EXPECT_NEAR(centreVelocity(arm, ts).y(), 0.5 * std::cos(0.05), 1e-9);
  EXPECT_NEAR(centre(arm, ts + 1.0).norm(), 1.0, 1e-9);
  EXPECT_NEAR(std::atan2(centre(arm, ts + 1.0).y(), centre(arm, ts + 1.0).x()), 0.55, 1e-9);
  // Odometry newer than the link's tf (1.2 s against 1.1 s): the link pose is carried to the
  // odometry's stamp with the link's own motion (0.1 rad at 1.2 s, not the 0.05 rad of 1.1 s).
  ASSERT_EQ(r.onOdometry(0, odom(1.2, 0, 0, 0, 0, 0, 0, "odom", "r/base"), ros::Time(1.2)), InputResult::kAccepted);
  r.update(ros::Time(1.2), tf);
  const double t12 = r.seconds(ros::Time(1.2));
  EXPECT_NEAR(std::atan2(centre(arm, t12).y(), centre(arm, t12).x()), 0.1, 1e-9);
  // A missing link transform skips that link only.
  tf.erase("r/arm");
  ASSERT_EQ(r.onOdometry(0, odom(1.3, 0, 0, 0, 0, 0, 0, "odom", "r/base"), ros::Time(1.3)), InputResult::kAccepted);
  r.update(ros::Time(1.3), tf);
  EXPECT_TRUE(r.elements()[body.elements[0]].active);
  EXPECT_FALSE(r.elements()[body.elements[1]].active);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kTfMissing);
  EXPECT_EQ(r.bodies()[0].status.links_skipped, 1u);
}

TEST(BodyRegistry, BrokenUrdfLeavesTheOtherBodiesMonitored) {
  BodyRegistry r(params(R"(
bodies:
  - {name: broken, odom_topic: /x, robot_description: bad}
  - {name: missing, odom_topic: /y, robot_description: nowhere}
  - {name: fine, odom_topic: /z, shape: {type: sphere, radius: 1}}
)"),
                 [](const std::string& name, std::string& value) {
                   if (name != "bad") return false;
                   value = "<robot name='x'><link name='a'>";
                   return true;
                 },
                 vadop_ros::makeDefaultMeshLoader());
  const auto errors = r.geometryErrors();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("body \"broken\": robot_description \"bad\""), std::string::npos);
  EXPECT_NE(errors[1].find("body \"missing\": robot_description parameter \"nowhere\" does not exist"),
            std::string::npos);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kNoGeometry);
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(2, odom(1.0, 0, 0, 0), ros::Time(1.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 0), ros::Time(1.0)), InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kNoGeometry);
  EXPECT_EQ(r.bodies()[2].status.state, BodyState::kOk);
  EXPECT_EQ(r.elements().size(), 1u);
  EXPECT_TRUE(r.elements()[0].active);
}

TEST(BodyRegistry, StaticObstaclesArePosedOnce) {
  BodyRegistry r(params(R"(
static_obstacles:
  - {name: wall, shape: {type: box, size: [1, 10, 2]}, pose: {position: [5, 0, 1], rpy: [0, 0, 1.5707963267948966]}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  ASSERT_EQ(r.elements().size(), 1u);
  const auto& e = r.elements()[0];
  EXPECT_TRUE(e.active);
  EXPECT_TRUE(e.motion.position.isApprox(Eigen::Vector3d(5, 0, 1)));
  EXPECT_TRUE(e.motion.linear_velocity.isZero());
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kStatic);
}

TEST(BodyRegistry, BodyFrameOtherThanTheOdometryChildFrame) {
  BodyRegistry r(params(R"(
bodies:
  - {name: a, odom_topic: /a, frame: a/base_link, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translation() = Eigen::Vector3d(1.0, 0.0, 0.5);  // base_link 1 m ahead of base_footprint
  tf.set("a/base_footprint", "a/base_link", offset);
  // Turning at 1 rad/s on the spot: the base_link origin moves at w x r = (0, 1, 0).
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 0, 0, 0, 1.0, "odom", "a/base_footprint"), ros::Time(1.0)),
            InputResult::kAccepted);
  r.update(ros::Time(1.0), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  EXPECT_TRUE(e.motion.position.isApprox(Eigen::Vector3d(1.0, 0.0, 0.5), 1e-12));
  const double ts = r.seconds(ros::Time(1.0));
  EXPECT_TRUE(centreVelocity(e, ts).isApprox(Eigen::Vector3d(0.0, 1.0, 0.0), 1e-12));
  EXPECT_TRUE(e.motion.angular_velocity.isApprox(Eigen::Vector3d(0.0, 0.0, 1.0), 1e-12));
  // It turns about base_footprint: a quarter turn later it is at (0, 1, 0.5).
  EXPECT_TRUE(centre(e, ts + M_PI / 2).isApprox(Eigen::Vector3d(0.0, 1.0, 0.5), 1e-9)) << centre(e, ts + M_PI / 2);
}

// ----------------------------------------------------------------------------- issue 13

namespace {

ros::Time epoch(uint32_t sec, uint32_t nsec = 0) { return ros::Time(sec, nsec); }

nav_msgs::Odometry odomAt(const ros::Time& stamp, double x, double vx) {
  nav_msgs::Odometry m = odom(0.0, x, 0.0, vx);
  m.header.stamp = stamp;
  return m;
}

// A transform source like tf2's at stamps 2^31 s apart: its error path throws std::runtime_error
// (ros::Duration out of range) instead of returning false.
class ThrowingTf : public vadop_ros::TransformSource {
 public:
  bool lookup(const std::string&, const std::string&, const ros::Time&, Eigen::Isometry3d&, ros::Time&,
              std::string&) override {
    throw std::runtime_error("Duration is out of dual 32-bit range");
  }
};

}  // namespace

TEST(BodyRegistry, StampBeyondTwoToThe31SecondsNeitherThrowsNorBlinds) {
  // Old code: update() computed (t - base) as a ros::Duration: 4e9 - 100 s is beyond 2^31 s and
  // threw "Duration is out of dual 32-bit range" (the node aborted).
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(1, odom(100.0, 5, 0, -1), ros::Time(100.0)), InputResult::kAccepted);
  nav_msgs::Odometry far = odom(0.0, 0, 0, 1);
  far.header.stamp = epoch(4000000000u);
  EXPECT_EQ(r.onOdometry(0, far, ros::Time(100.0)), InputResult::kInvalid);  // 4e9 s ahead of the clock
  EXPECT_NE(r.bodies()[0].status.last_invalid.find("4000000000"), std::string::npos)
      << r.bodies()[0].status.last_invalid;
  EXPECT_NO_THROW(r.update(ros::Time(100.0), tf));
  EXPECT_TRUE(r.elements()[1].active);
  // The same stamp with a clock there (use_sim_time): accepted and predicted, in small seconds.
  ASSERT_EQ(r.onOdometry(0, far, epoch(4000000000u)), InputResult::kAccepted);
  EXPECT_NO_THROW(r.update(epoch(4000000000u, 500000000u), tf));
  ASSERT_TRUE(r.elements()[0].active);
  const double t = r.seconds(epoch(4000000000u, 500000000u));
  EXPECT_LE(std::fabs(t), BodyRegistry::kRebaseAfterSeconds);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(t).isApprox(Eigen::Vector3d(0.5, 0, 0), 1e-9));
  EXPECT_EQ(r.bodies()[1].status.state, BodyState::kStale);  // its last message is 4e9 s old
}

TEST(BodyRegistry, ClockJumpForwardAndBackNeverThrows) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(100.0, 0, 0, 1), ros::Time(100.0)), InputResult::kAccepted);
  r.update(ros::Time(100.0), tf);
  // /clock jumps to 4.2e9 s: old code threw in (now - last_receipt) and seconds(now).
  EXPECT_NO_THROW(r.update(epoch(4200000000u), tf));
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kStale);
  ASSERT_TRUE(r.elements()[0].active);
  EXPECT_LE(std::fabs(r.elements()[0].motion.t_ref), BodyRegistry::kRebaseAfterSeconds);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(r.seconds(epoch(4200000000u))).isApprox(Eigen::Vector3d(0, 0, 0),
                                                                                          1e-9));
  // The largest ROS time, and back to the start (without reset): still no exception.
  EXPECT_NO_THROW(r.update(epoch(4294967295u, 999999999u), tf));
  EXPECT_NO_THROW(r.update(ros::Time(1.0), tf));
  EXPECT_LE(std::fabs(r.seconds(ros::Time(1.0))), BodyRegistry::kRebaseAfterSeconds);
}

// A clock that goes back past the last receipt without a reset (the node resets on a jump back;
// a library user may not): the state's age is unknown, so the body stands still at its last pose
// (stale). Old code kept it moving from a reference time 2e7 s away: the frame's motion for its
// plan threw vadop::InvalidArgument out of update() (found by the fuzzer).
TEST(BodyRegistry, StateReceivedAfterTheClockIsStaleAndNeverThrows) {
  BodyRegistry r(params(R"(
stale_timeout: 0.5
bodies:
  - {name: a, odom_topic: /a, path_topic: /a/plan, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  const ros::Time later(2e7);
  nav_msgs::Path plan;
  plan.header.stamp = later;
  plan.header.frame_id = "odom";
  for (int k = 0; k < 3; ++k) {
    geometry_msgs::PoseStamped p;
    p.header.stamp = vadop_ros::addSeconds(later, 1.0 + k);
    p.pose.position.x = k;
    p.pose.orientation.w = 1.0;
    plan.poses.push_back(p);
  }
  ASSERT_EQ(r.onPath(0, plan, later, tf), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(0, odom(2e7, 3.0, 0, 1.0), later), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(5.0, 5, 0, -1), ros::Time(5.0)), InputResult::kAccepted);
  r.update(later, tf);
  ASSERT_EQ(r.bodies()[0].status.state, BodyState::kOk);
  // The clock goes back to 5 s.
  ASSERT_NO_THROW(r.update(ros::Time(5.0), tf));
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kStale);
  const double t = r.seconds(ros::Time(5.0));
  ASSERT_TRUE(r.elements()[0].active);
  EXPECT_TRUE(r.elements()[0].motion.linear_velocity.isZero());
  EXPECT_TRUE(r.elements()[0].motion.positionAt(t).isApprox(Eigen::Vector3d(3, 0, 0), 1e-9));
  EXPECT_EQ(r.bodies()[1].status.state, BodyState::kOk);
  EXPECT_TRUE(r.elements()[1].active);
  // Within the clock's lag a receipt just ahead of the clock is fresh (simulated /clock).
  ASSERT_EQ(r.onOdometry(1, odom(6.0, 5, 0, -1), ros::Time(6.0)), InputResult::kAccepted);
  r.update(ros::Time(5.9), tf);
  EXPECT_EQ(r.bodies()[1].status.state, BodyState::kOk);
}

// A twist body whose pose comes from tf stamped far from the clock: its frame's motion is beyond
// the library's time range. Left out as a whole and said why (old code: its elements were
// rejected one by one while the body stayed "ok" with a frame motion no reader could use).
TEST(BodyRegistry, TfPoseFarFromTheClockLeavesTheBodyOut) {
  BodyRegistry r(params(R"(
bodies:
  - {name: t, twist_topic: /t, frame: t_link, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  tf.set("odom", "t_link", Eigen::Isometry3d::Identity(), ros::Time(2e7));
  geometry_msgs::TwistStamped m;
  m.header.stamp = ros::Time(3.0);
  m.twist.linear.x = 2.0;
  ASSERT_EQ(r.onTwist(0, m, ros::Time(3.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(3.0, 5, 0, -1), ros::Time(3.0)), InputResult::kAccepted);
  ASSERT_NO_THROW(r.update(ros::Time(3.0), tf));
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kTfMissing);
  EXPECT_NE(r.bodies()[0].status.tf_error.find("out of range"), std::string::npos) << r.bodies()[0].status.tf_error;
  EXPECT_FALSE(r.elements()[0].active);
  EXPECT_FALSE(r.bodies()[0].frame_motion.valid);
  EXPECT_TRUE(r.elements()[1].active);
  tf.set("odom", "t_link", Eigen::Isometry3d::Identity(), ros::Time(3.0));
  r.update(ros::Time(3.0), tf);
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kOk);
  EXPECT_TRUE(r.elements()[0].active);
}

TEST(BodyRegistry, ThrowingTransformSourceOnlySkipsThatBody) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  ThrowingTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 1, 0, 0, 0, "map"), ros::Time(1.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(1.0, 5, 0, -1), ros::Time(1.0)), InputResult::kAccepted);
  EXPECT_NO_THROW(r.update(ros::Time(1.0), tf));
  EXPECT_EQ(r.bodies()[0].status.state, BodyState::kTfMissing);
  EXPECT_NE(r.bodies()[0].status.tf_error.find("Duration"), std::string::npos);
  EXPECT_TRUE(r.elements()[1].active);
}

TEST(BodyRegistry, FutureStampIsDroppedAndBlocksNothing) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  const ros::Time now(1000.0);
  // Old code: accepted, then every message until t = 101000 s was "out of order".
  EXPECT_EQ(r.onOdometry(0, odom(1000.0 + 1e5, 0, 0, 1), now), InputResult::kInvalid);
  EXPECT_NE(r.bodies()[0].status.last_invalid.find("ahead"), std::string::npos);
  EXPECT_EQ(r.onOdometry(0, odom(1000.1, 1, 0, 1), ros::Time(1000.1)), InputResult::kAccepted);
  // Behind by more than the skew: dropped too.
  EXPECT_EQ(r.onOdometry(0, odom(1000.2 - 100.0, 1, 0, 1), ros::Time(1000.2)), InputResult::kInvalid);
  EXPECT_NE(r.bodies()[0].status.last_invalid.find("behind"), std::string::npos);
  // Within the skew ahead (3 s): accepted; it holds back older stamps only while it is ahead of
  // the new message's receipt time.
  EXPECT_EQ(r.onOdometry(0, odom(1003.3, 2, 0, 1), ros::Time(1000.3)), InputResult::kAccepted);
  EXPECT_EQ(r.onOdometry(0, odom(1000.4, 3, 0, 1), ros::Time(1000.4)), InputResult::kAccepted);
  r.update(ros::Time(1000.4), tf);
  EXPECT_TRUE(r.elements()[0].motion.positionAt(r.seconds(ros::Time(1000.4))).isApprox(Eigen::Vector3d(3, 0, 0), 1e-9));
  // The ordinary rule still holds for stamps not ahead of the clock.
  EXPECT_EQ(r.onOdometry(0, odom(1000.35, 9, 0, 1), ros::Time(1000.5)), InputResult::kOutOfOrder);
  EXPECT_EQ(r.onOdometry(0, odom(1000.4, 9, 0, 1), ros::Time(1000.5)), InputResult::kOutOfOrder);
  // And while the clock lags the stamps by a few ms (a simulated /clock): a duplicate or an
  // older stamp arriving before the clock reached the last stamp is still out of order.
  EXPECT_EQ(r.onOdometry(0, odom(1000.45, 5, 0, 1), ros::Time(1000.448)), InputResult::kAccepted);
  EXPECT_EQ(r.onOdometry(0, odom(1000.45, 9, 0, 1), ros::Time(1000.449)), InputResult::kOutOfOrder);
  EXPECT_EQ(r.onOdometry(0, odom(1000.15, 9, 0, 1), ros::Time(1000.449)), InputResult::kOutOfOrder);
  // The skew is a parameter.
  r.setMaxStampSkew(1e5 + 10.0);
  EXPECT_EQ(r.onOdometry(0, odom(1000.6 + 1e5, 0, 0, 1), ros::Time(1000.6)), InputResult::kAccepted);
  EXPECT_EQ(r.onOdometry(0, odom(1000.7, 4, 0, 1), ros::Time(1000.7)), InputResult::kAccepted);
}

TEST(BodyRegistry, FutureStampInTwistStampedBlocksNothing) {
  BodyRegistry r(params(R"(
bodies:
  - {name: t, twist_topic: /t, frame: t_link, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  geometry_msgs::TwistStamped m;
  m.twist.linear.x = 1.0;
  m.header.stamp = ros::Time(50.0 + 1e5);
  EXPECT_EQ(r.onTwist(0, m, ros::Time(50.0)), InputResult::kInvalid);
  m.header.stamp = ros::Time(50.1);
  EXPECT_EQ(r.onTwist(0, m, ros::Time(50.1)), InputResult::kAccepted);
  m.header.stamp = ros::Time(54.0);  // 3.8 s ahead: within the skew
  EXPECT_EQ(r.onTwist(0, m, ros::Time(50.2)), InputResult::kAccepted);
  m.header.stamp = ros::Time(50.3);
  EXPECT_EQ(r.onTwist(0, m, ros::Time(50.3)), InputResult::kAccepted);
}

// Every rejected value is named by its field, and frame ids lose their leading slashes (the
// body's frames are kept from message to message: a shorter id must not keep the longer one's tail).
TEST(BodyRegistry, RejectionsNameTheFieldAndFramesLoseTheirSlash) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  auto rejected = [&](nav_msgs::Odometry m) {
    EXPECT_EQ(r.onOdometry(0, m, ros::Time(1.0)), InputResult::kInvalid);
    return r.bodies()[0].status.last_invalid;
  };
  EXPECT_NE(rejected(odom(1.0, 0, kNaN, 1)).find("NaN/Inf in pose.pose.position.y"), std::string::npos);
  auto q = odom(1.0, 0, 0, 1);
  q.pose.pose.orientation.x = kNaN;
  EXPECT_NE(rejected(q).find("NaN/Inf in pose.pose.orientation"), std::string::npos);
  q.pose.pose.orientation = geometry_msgs::Quaternion();
  EXPECT_NE(rejected(q).find("zero-norm quaternion in pose.pose.orientation"), std::string::npos);
  EXPECT_NE(rejected(odom(1.0, 0, 0, 0, 2e4)).find("twist.twist.linear.y = "), std::string::npos);
  EXPECT_NE(rejected(odom(1.0, 0, 0, 0, 0, 0, kNaN)).find("NaN/Inf in twist.twist.angular.z"), std::string::npos);
  EXPECT_NE(rejected(odom(1.0, 0, 0, 0, 0, 0, 2e4)).find("twist.twist.angular.z = "), std::string::npos);

  ASSERT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 1, 0, 0, 0, "//odom_long_frame_name", "/robot_a/base_footprint"),
                         ros::Time(1.0)),
            InputResult::kAccepted);
  EXPECT_EQ(r.bodies()[0].velocityState()->source_frame, "odom_long_frame_name");
  EXPECT_EQ(r.bodies()[0].velocityState()->child_frame, "robot_a/base_footprint");
  ASSERT_EQ(r.onOdometry(0, odom(1.1, 0, 0, 1, 0, 0, 0, "/map", "base"), ros::Time(1.1)), InputResult::kAccepted);
  EXPECT_EQ(r.bodies()[0].velocityState()->source_frame, "map");
  EXPECT_EQ(r.bodies()[0].velocityState()->child_frame, "base");
  // An empty (or all-slash) pose frame is the fixed frame.
  ASSERT_EQ(r.onOdometry(0, odom(1.2, 0, 0, 1, 0, 0, 0, "/"), ros::Time(1.2)), InputResult::kAccepted);
  EXPECT_EQ(r.bodies()[0].velocityState()->source_frame, r.fixedFrame());
  EXPECT_EQ(r.bodies()[0].velocityState()->child_frame, "");
}

TEST(BodyRegistry, MessageValuesAreCheckedAgainstTheLibraryRange) {
  BodyRegistry r(params(kThree), noParams(), vadop_ros::makeDefaultMeshLoader());
  // Old code accepted anything up to 1e9.
  EXPECT_EQ(r.onOdometry(0, odom(1.0, 2e7, 0, 0), ros::Time(1.0)), InputResult::kInvalid);    // > kMaxCoordinate
  EXPECT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 2e4), ros::Time(1.0)), InputResult::kInvalid);    // > kMaxLinearSpeed
  EXPECT_EQ(r.onOdometry(0, odom(1.0, 0, 0, 0, 0, 0, 2e4), ros::Time(1.0)), InputResult::kInvalid);  // rad/s
  EXPECT_EQ(r.bodies()[0].status.dropped_invalid, 3u);
}

TEST(BodyRegistry, ElementOutOfRangeOverTheWindowIsLeftOutAndMarked) {
  // stale_timeout 5000 s: a body whose last message (t = 100 s, x = 5e6 m, 9 km/s) is 2000 s old
  // is still extrapolated, to 2.3e7 m: beyond kMaxReach. Old code passed it to the world (its
  // check allowed 1e12), whose predict then failed for every body.
  BodyRegistry r(params(R"(
stale_timeout: 5000
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: far, odom_topic: /f, shape: {type: sphere, radius: 0.5}}
  - {name: wide, odom_topic: /w, shape: {type: sphere, radius: 0.5}}
)"),
                 noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onOdometry(0, odom(2100.0, 0, 0, 1), ros::Time(2100.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onOdometry(1, odom(100.0, 5e6, 0, 9e3), ros::Time(100.0)), InputResult::kAccepted);
  // Each component within kMaxCoordinate, the distance from the origin beyond it.
  nav_msgs::Odometry wide = odom(2100.0, 9e6, 9e6, 0);
  wide.pose.pose.position.z = 9e6;
  ASSERT_EQ(r.onOdometry(2, wide, ros::Time(2100.0)), InputResult::kAccepted);
  r.update(ros::Time(2100.0), tf);
  EXPECT_TRUE(r.elements()[0].active);
  EXPECT_FALSE(r.elements()[1].active);
  EXPECT_FALSE(r.elements()[2].active);
  EXPECT_NE(r.bodies()[1].status.last_invalid.find("out of range"), std::string::npos) << r.bodies()[1].status.last_invalid;
  EXPECT_EQ(r.bodies()[1].status.last_invalid_receipt, ros::Time(2100.0));  // marked bad input now
  EXPECT_GE(r.bodies()[2].status.elements_left_out, 1u);
  // The window is the largest horizon: stated at t = -1200 s at 9e6 m moving at 9 km/s, the
  // element is at 1.98e7 m at t = 0 (within kMaxReach) and 2.03e7 m at t = 60 s (beyond).
  const vadop::Motion m =
      vadop::makeMotion({9e6, 0, 0}, Eigen::Quaterniond::Identity(), {9e3, 0, 0}, {0, 0, 0}, -1200.0);
  EXPECT_TRUE(BodyRegistry::motionRangeError(m, 0.0, 2.0).empty());
  EXPECT_FALSE(BodyRegistry::motionRangeError(m, 0.0, BodyRegistry::kMotionCheckWindow).empty());
}

// update() on several threads (a TransformSource that takes concurrent lookups) gives every
// element the motion and every body the state of one thread: 1,100 bodies of five kinds
// (spheres on odometry, rigid URDF robots, bodies posed through tf with half of the transforms
// missing, bodies waiting or stale, twist bodies), updated at two times.
TEST(BodyRegistry, UpdateOnThreadsEqualsOneThread) {
  // Records the threads that looked up transforms: the update must really be shared out.
  class ThreadsTf : public FakeTf {
   public:
    bool lookup(const std::string& target, const std::string& source, const ros::Time& time, Eigen::Isometry3d& pose,
                ros::Time& stamp, std::string& error) override {
      {
        const std::lock_guard<std::mutex> lock(mutex_);
        threads_.insert(std::this_thread::get_id());
      }
      // A lookup that takes a moment, as tf2's does: on a loaded machine the calling thread
      // could otherwise finish every chunk before the pool's threads wake.
      std::this_thread::sleep_for(std::chrono::microseconds(20));
      return FakeTf::lookup(target, source, time, pose, stamp, error);
    }
    size_t threads() const { return threads_.size(); }

   private:
    std::mutex mutex_;
    std::set<std::thread::id> threads_;
  };
  const int n = 1100;
  std::string yaml_text = "stale_timeout: 0.5\nbodies:\n";
  for (int i = 0; i < n; ++i) {
    const std::string id = std::to_string(i);
    switch (i % 5) {
      case 0: yaml_text += "  - {name: s" + id + ", odom_topic: /s" + id + ", shape: {type: sphere, radius: 0.3}}\n"; break;
      case 1: yaml_text += "  - {name: u" + id + ", odom_topic: /u" + id + ", robot_description: d}\n"; break;
      case 2:
        yaml_text += "  - {name: f" + id + ", odom_topic: /f" + id + ", frame: f" + id +
                     "/base_link, shape: {type: box, size: [0.4, 0.3, 0.2]}}\n";
        break;
      case 3: yaml_text += "  - {name: w" + id + ", odom_topic: /w" + id + ", shape: {type: sphere, radius: 0.3}}\n"; break;
      default:
        yaml_text += "  - {name: t" + id + ", twist_topic: /t" + id + ", frame: t" + id +
                     "_link, shape: {type: capsule, radius: 0.2, length: 0.5}}\n";
    }
  }
  const std::string urdf = testUrdf();
  auto read = [&](const std::string&, std::string& value) {
    value = urdf;
    return true;
  };
  BodyRegistry one(params(yaml_text), read, vadop_ros::makeDefaultMeshLoader());
  BodyRegistry many(params(yaml_text), read, vadop_ros::makeDefaultMeshLoader());
  many.setThreads(4);
  ThreadsTf tf;
  tf.concurrent_lookups = true;
  for (int i = 0; i < n; ++i) {
    const double x = 0.37 * i, y = 0.11 * (i % 17), v = 0.1 * (i % 13), w = 0.05 * (i % 7) - 0.15;
    const std::string id = std::to_string(i);
    const int kind = i % 5;
    if (kind == 2 && i % 2 == 0) {
      Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
      offset.translation() = Eigen::Vector3d(0.5, 0.1 * (i % 3), 0.2);
      tf.set("f" + id + "/base_footprint", "f" + id + "/base_link", offset, ros::Time(9.0));
    }
    if (kind == 4) {
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(x, y, 0);
      pose.linear() = Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      tf.set("odom", "t" + id + "_link", pose, ros::Time(10.0));
      geometry_msgs::TwistStamped m;
      m.header.stamp = ros::Time(10.0);
      m.twist.linear.x = v;
      m.twist.angular.z = w;
      for (BodyRegistry* r : {&one, &many}) ASSERT_EQ(r->onTwist(i, m, ros::Time(10.0)), InputResult::kAccepted);
      continue;
    }
    if (kind == 3 && i % 2 == 0) continue;  // waiting; the others stale (a message 2 s old)
    const double stamp = kind == 3 ? 8.0 : 10.0;
    const std::string child = kind == 1 ? "u" + id + "/base_link" : kind == 2 ? "f" + id + "/base_footprint" : "";
    for (BodyRegistry* r : {&one, &many}) {
      ASSERT_EQ(r->onOdometry(i, odom(stamp, x, y, v, 0.0, 0.1 * i, w, "odom", child), ros::Time(stamp)),
                InputResult::kAccepted);
    }
  }
  size_t active = 0, missing = 0, stale = 0;
  for (const double now : {10.05, 10.4}) {
    one.update(ros::Time(now), tf);
    many.update(ros::Time(now), tf);
    ASSERT_EQ(one.elements().size(), many.elements().size());
    for (size_t k = 0; k < one.elements().size(); ++k) {
      const vadop_ros::Element& a = one.elements()[k];
      const vadop_ros::Element& b = many.elements()[k];
      ASSERT_EQ(a.active, b.active) << a.id;
      if (!a.active) continue;
      ++active;
      EXPECT_EQ(a.motion.position, b.motion.position) << a.id;
      EXPECT_EQ(a.motion.orientation.coeffs(), b.motion.orientation.coeffs()) << a.id;
      EXPECT_EQ(a.motion.linear_velocity, b.motion.linear_velocity) << a.id;
      EXPECT_EQ(a.motion.angular_velocity, b.motion.angular_velocity) << a.id;
      EXPECT_EQ(a.motion.pivot_offset, b.motion.pivot_offset) << a.id;
      EXPECT_EQ(a.motion.t_ref, b.motion.t_ref) << a.id;
    }
    for (size_t i = 0; i < one.bodies().size(); ++i) {
      const vadop_ros::BodyStatus& a = one.bodies()[i].status;
      const vadop_ros::BodyStatus& b = many.bodies()[i].status;
      EXPECT_EQ(a.state, b.state) << one.bodies()[i].name;
      EXPECT_EQ(a.tf_error, b.tf_error) << one.bodies()[i].name;
      EXPECT_EQ(a.links_skipped, b.links_skipped) << one.bodies()[i].name;
      EXPECT_EQ(a.elements_left_out, b.elements_left_out) << one.bodies()[i].name;
      missing += a.state == BodyState::kTfMissing;
      stale += a.state == BodyState::kStale;
    }
  }
  // Not vacuous: every kind took part, and the lookups ran on more than one thread.
  EXPECT_GT(active, 1500u);
  EXPECT_EQ(missing, 2u * 110u);  // the f bodies without their transform, at both times
  EXPECT_EQ(stale, 2u * 110u);
  EXPECT_GT(tf.threads(), 1u);
}
