// A body's planned path (path_topic, nav_msgs/Path): the registry puts its elements on the
// plan from their pose now through the poses stamped after now, then holds or continues; bad
// paths are dropped with the field named and the previous plan kept; a plan that has ended, an
// empty one or a stale body falls back to the twist. The parameters path_topic / after_path.
// (The end-to-end prediction along a plan is in test_monitor_core.cpp.)
#include "vadop_ros/body_registry.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>
#include <vadop/joint_chain.h>

#include <cmath>
#include <limits>

using vadop_ros::BodyRegistry;
using vadop_ros::InputResult;
using vadop_test::FakeTf;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

vadop_ros::ParamReader noParams() {
  return [](const std::string&, std::string&) { return false; };
}

BodyRegistry makeRegistry(const std::string& after = "") {
  const std::string text = R"(
stale_timeout: 0.5
bodies:
  - {name: robot, odom_topic: /robot/odom, path_topic: /robot/plan, shape: {type: box, size: [0.6, 0.4, 0.3]})" +
                           (after.empty() ? std::string() : ", after_path: " + after) + R"(}
  - {name: other, odom_topic: /other/odom, shape: {type: sphere, radius: 0.3}}
)";
  return BodyRegistry(vadop_ros::parseParams(vadop_test::yaml(text)), noParams(), vadop_ros::makeDefaultMeshLoader());
}

// The reference arc: from the origin heading +x at t = 100 s, turning left at 0.5 rad/s with
// speed 1 m/s (radius 2 m about (0, 2)).
constexpr double kStart = 100.0, kRadius = 2.0, kRate = 0.5;
Eigen::Isometry3d arcPose(double t) {
  const double th = kRate * (t - kStart);
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(kRadius * std::sin(th), kRadius - kRadius * std::cos(th), 0.0);
  p.linear() = Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

geometry_msgs::PoseStamped stamped(double t, const Eigen::Isometry3d& p, const std::string& frame = "") {
  geometry_msgs::PoseStamped s;
  s.header.stamp = ros::Time(t);
  s.header.frame_id = frame;
  s.pose.position.x = p.translation().x();
  s.pose.position.y = p.translation().y();
  s.pose.position.z = p.translation().z();
  const Eigen::Quaterniond q(p.linear());
  s.pose.orientation.x = q.x();
  s.pose.orientation.y = q.y();
  s.pose.orientation.z = q.z();
  s.pose.orientation.w = q.w();
  return s;
}

// The arc sampled every `dt` over [from, to].
nav_msgs::Path arcPath(double stamp, double from, double to, double dt = 0.1, const std::string& frame = "odom") {
  nav_msgs::Path m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = frame;
  for (double t = from; t <= to + 1e-9; t += dt) m.poses.push_back(stamped(t, arcPose(t)));
  return m;
}

// Odometry on the arc at t (twist in the body frame: vx = 1, wz = 0.5), or driving straight.
nav_msgs::Odometry arcOdom(double t, bool turning = true) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(t);
  m.header.frame_id = "odom";
  const geometry_msgs::PoseStamped s = stamped(t, arcPose(t));
  m.pose.pose = s.pose;
  m.twist.twist.linear.x = kRadius * kRate;
  m.twist.twist.angular.z = turning ? kRate : 0.0;
  return m;
}

double poseError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() + (a.linear() - b.linear()).norm();
}

}  // namespace

TEST(PathInput, ElementsFollowThePlanFromTheirPoseNow) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  // The odometry says "straight on"; the plan says "turn left": the plan wins over its span.
  ASSERT_EQ(r.onOdometry(0, arcOdom(100.0, false), ros::Time(100.0)), InputResult::kAccepted);
  ASSERT_EQ(r.onPath(0, arcPath(100.0, 100.0, 103.0), ros::Time(100.0), tf), InputResult::kAccepted);
  r.update(ros::Time(100.0), tf);
  const vadop_ros::Element& e = r.elements()[0];
  ASSERT_TRUE(e.active);
  ASSERT_TRUE(e.chain);
  EXPECT_TRUE(r.bodies()[0].status.on_path);
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "path");
  // On the arc at every time of the plan (the pieces between samples of a constant-twist arc
  // are exact), and beyond its end the last piece's twist goes on: still the arc.
  for (double t = 100.0; t <= 104.0; t += 0.037) {
    EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(t))), arcPose(t)), 1e-9) << "t = " << t;
  }
  // The element's own motion stays the twist (what the gates and the fallback use).
  EXPECT_NEAR(e.motion.positionAt(r.seconds(ros::Time(101.0))).y(), 0.0, 1e-12);
  // The other body has no path input.
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[1]), "none");
}

TEST(PathInput, HoldStopsAtTheLastPose) {
  BodyRegistry r = makeRegistry("hold");
  FakeTf tf;
  r.onOdometry(0, arcOdom(100.0), ros::Time(100.0));
  ASSERT_EQ(r.onPath(0, arcPath(100.0, 100.0, 101.5), ros::Time(100.0), tf), InputResult::kAccepted);
  r.update(ros::Time(100.2), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.chain);
  EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(101.0))), arcPose(101.0)), 1e-9);
  EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(103.0))), arcPose(101.5)), 1e-9);
}

TEST(PathInput, StartsFromTheCurrentPoseNotFromOldPlanPoses) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  // The robot is 0.1 m left of where the plan put it at 100.5 s: the prediction starts from
  // where it is and joins the plan at its first pose after now.
  nav_msgs::Odometry o = arcOdom(100.5);
  o.pose.pose.position.y += 0.1;
  r.onOdometry(0, o, ros::Time(100.5));
  r.onPath(0, arcPath(100.0, 100.0, 103.0), ros::Time(100.5), tf);
  r.update(ros::Time(100.5), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.chain);
  const double now = r.seconds(ros::Time(100.5));
  EXPECT_NEAR(e.chain->poseAt(now).translation().y(), arcPose(100.5).translation().y() + 0.1, 1e-9);
  EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(100.6))), arcPose(100.6)), 1e-9);
  EXPECT_EQ(e.chain->base().keyframes().size(), 26u);  // now, then 100.6 .. 103.0
}

TEST(PathInput, RigidLinksKeepTheirPlaceOnTheBody) {
  const std::string text = R"(
bodies:
  - {name: robot, odom_topic: /robot/odom, path_topic: /robot/plan, robot_description: /d}
)";
  std::string urdf = vadop_test::readFile(VADOP_TEST_DATA_DIR "/two_link.urdf");
  for (size_t p = urdf.find("@DATA_DIR@"); p != std::string::npos; p = urdf.find("@DATA_DIR@")) {
    urdf.replace(p, 10, VADOP_TEST_DATA_DIR);
  }
  BodyRegistry r(vadop_ros::parseParams(vadop_test::yaml(text)),
                 [&](const std::string&, std::string& v) {
                   v = urdf;
                   return true;
                 },
                 vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  r.onOdometry(0, arcOdom(100.0, false), ros::Time(100.0));
  r.onPath(0, arcPath(100.0, 100.0, 102.0), ros::Time(100.0), tf);
  r.update(ros::Time(100.0), tf);
  const double now = r.seconds(ros::Time(100.0));
  ASSERT_GE(r.bodies()[0].elements.size(), 2u);
  for (const size_t ei : r.bodies()[0].elements) {
    const auto& e = r.elements()[ei];
    ASSERT_TRUE(e.active && e.chain) << e.id;
    const Eigen::Isometry3d in_body = arcPose(100.0).inverse() * e.motion.poseAt(now);
    for (double t = 100.0; t <= 102.0; t += 0.25) {
      EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(t))), arcPose(t) * in_body), 1e-9) << e.id << " " << t;
    }
  }
}

TEST(PathInput, PathInAnotherFrameIsTransformed) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  Eigen::Isometry3d odom_map = Eigen::Isometry3d::Identity();
  odom_map.translation() = Eigen::Vector3d(5.0, -1.0, 0.0);
  odom_map.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("odom", "map", odom_map);
  r.onOdometry(0, arcOdom(100.0), ros::Time(100.0));
  nav_msgs::Path p = arcPath(100.0, 100.0, 102.0, 0.1, "map");
  ASSERT_EQ(r.onPath(0, p, ros::Time(100.0), tf), InputResult::kAccepted);
  r.update(ros::Time(100.0), tf);
  const auto& e = r.elements()[0];
  ASSERT_TRUE(e.chain);
  EXPECT_LT(poseError(e.chain->poseAt(r.seconds(ros::Time(101.0))), odom_map * arcPose(101.0)), 1e-9);
}

TEST(PathInput, EndedEmptyOrStalePlansFallBackToTheTwist) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, arcOdom(100.0), ros::Time(100.0));
  r.onPath(0, arcPath(100.0, 100.0, 101.0), ros::Time(100.0), tf);
  r.onOdometry(0, arcOdom(101.2), ros::Time(101.2));
  r.update(ros::Time(101.2), tf);  // the plan's last pose is past
  EXPECT_FALSE(r.elements()[0].chain);
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "odometry");

  r.onPath(0, arcPath(101.2, 101.2, 103.0), ros::Time(101.2), tf);
  r.update(ros::Time(101.3), tf);
  EXPECT_TRUE(r.elements()[0].chain);
  nav_msgs::Path empty;
  empty.header.stamp = ros::Time(101.3);
  ASSERT_EQ(r.onPath(0, empty, ros::Time(101.3), tf), InputResult::kAccepted);  // the planner has none
  r.update(ros::Time(101.3), tf);
  EXPECT_FALSE(r.elements()[0].chain);

  r.onPath(0, arcPath(101.4, 101.4, 105.0), ros::Time(101.4), tf);
  r.update(ros::Time(102.0), tf);  // odometry 0.8 s old: stale, stands still
  EXPECT_FALSE(r.elements()[0].chain);
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "stale");
}

TEST(PathInput, BadPathsAreDroppedNamingTheFieldAndThePlanIsKept) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, arcOdom(100.0), ros::Time(100.0));
  ASSERT_EQ(r.onPath(0, arcPath(100.0, 100.0, 103.0), ros::Time(100.0), tf), InputResult::kAccepted);
  struct Case {
    const char* field;
    std::function<void(nav_msgs::Path&)> spoil;
  };
  const std::vector<Case> cases = {
      {"poses[3].pose.position.x", [](nav_msgs::Path& p) { p.poses[3].pose.position.x = kNaN; }},
      {"poses[2].pose.orientation", [](nav_msgs::Path& p) { p.poses[2].pose.orientation = geometry_msgs::Quaternion(); }},
      {"poses[5].header.stamp", [](nav_msgs::Path& p) { p.poses[5].header.stamp = p.poses[4].header.stamp; }},
      {"poses[1].header.stamp is zero", [](nav_msgs::Path& p) { p.poses[1].header.stamp = ros::Time(); }},
      {"poses[4].header.frame_id", [](nav_msgs::Path& p) { p.poses[4].header.frame_id = "map"; }},
      {"header.frame_id is empty", [](nav_msgs::Path& p) { p.header.frame_id = ""; }},
      {"header.frame_id \"nowhere\"", [](nav_msgs::Path& p) { p.header.frame_id = "nowhere"; }},
      {"pose.position.y = 1e+09", [](nav_msgs::Path& p) { p.poses[0].pose.position.y = 1e9; }},
      {"header.stamp", [](nav_msgs::Path& p) { p.header.stamp = ros::Time(5000.0); }},
  };
  uint64_t dropped = 0;
  for (const Case& c : cases) {
    nav_msgs::Path p = arcPath(100.1, 100.1, 104.0, 0.1);
    for (auto& s : p.poses) s.pose.position.y += 7.0;  // a different plan, were it taken
    c.spoil(p);
    EXPECT_EQ(r.onPath(0, p, ros::Time(100.1), tf), InputResult::kInvalid) << c.field;
    EXPECT_EQ(r.bodies()[0].source("path")->counts().dropped, ++dropped);
    EXPECT_NE(r.bodies()[0].status.last_invalid.find(c.field), std::string::npos)
        << c.field << " not in: " << r.bodies()[0].status.last_invalid;
  }
  // The first plan is still followed.
  r.update(ros::Time(100.2), tf);
  ASSERT_TRUE(r.elements()[0].chain);
  EXPECT_LT(poseError(r.elements()[0].chain->poseAt(r.seconds(ros::Time(102.0))), arcPose(102.0)), 1e-9);
  EXPECT_EQ(r.bodies()[0].source("path")->counts().accepted, 1u);
  // An older path than the accepted one is out of order.
  EXPECT_EQ(r.onPath(0, arcPath(99.0, 100.0, 102.0), ros::Time(100.2), tf), InputResult::kOutOfOrder);
}

TEST(PathInput, PlanThatCannotBeFollowedFallsBackToTheTwist) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, arcOdom(100.0), ros::Time(100.0));
  // Two poses 2 ms apart and a kilometre apart in between: beyond the library's speed range.
  nav_msgs::Path p = arcPath(100.0, 100.0, 101.0);
  p.poses.insert(p.poses.begin() + 5, stamped(100.402, arcPose(100.4)));
  p.poses[5].pose.position.x += 1000.0;
  p.poses[6].header.stamp = ros::Time(100.404);
  ASSERT_EQ(r.onPath(0, p, ros::Time(100.0), tf), InputResult::kAccepted);
  r.update(ros::Time(100.0), tf);
  EXPECT_TRUE(r.elements()[0].active);
  EXPECT_FALSE(r.elements()[0].chain);
  EXPECT_NE(r.bodies()[0].status.last_invalid.find("path: not followed"), std::string::npos)
      << r.bodies()[0].status.last_invalid;
}

TEST(PathInput, Parameters) {
  const auto parse = [](const std::string& body) {
    return vadop_ros::parseParams(vadop_test::yaml("bodies:\n  - {name: r, odom_topic: /o, shape: {type: sphere, "
                                                   "radius: 1}" + body + "}\n"));
  };
  EXPECT_TRUE(parse("").bodies[0].path_topic.empty());
  const auto p = parse(", path_topic: /r/plan");
  EXPECT_EQ(p.bodies[0].path_topic, "/r/plan");
  EXPECT_TRUE(p.bodies[0].path_continue);
  EXPECT_FALSE(parse(", path_topic: /r/plan, after_path: hold").bodies[0].path_continue);
  const auto error = [&](const std::string& body) {
    try {
      parse(body);
    } catch (const vadop_ros::ParamError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error(", path_topic: /r/plan, after_path: stop").find("after_path"), std::string::npos);
  EXPECT_NE(error(", after_path: hold").find("only with path_topic"), std::string::npos);
  EXPECT_NE(error(", path_topic: ''").find("path_topic"), std::string::npos);
  EXPECT_NE(error(", path_topic: /o").find("must differ"), std::string::npos);
  EXPECT_NE(error(", path_topic: 'bad topic'").find("path_topic"), std::string::npos);
}
