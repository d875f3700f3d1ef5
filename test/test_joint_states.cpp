// A URDF body with joint_states_topic: its links posed by the URDF's kinematics (kdl) at the
// joint positions and moving with the joint velocities over the horizon, checked against this
// file's own planar forward kinematics; joint limits; bad joint states dropped naming the field
// with the state kept; stale joint states stop; the parameters.
// (The first contact of a two-joint arm against dense ground truth: test_monitor_core.cpp.)
#include "vadop_ros/body_registry.h"
#include "vadop_ros/joint_kinematics.h"
#include "fake_tf.h"
#include "planar_arm.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>
#include <vadop/joint_chain.h>

#include <functional>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

using vadop_ros::BodyRegistry;
using vadop_ros::InputResult;
using vadop_test::FakeTf;

namespace {


// The arm as the body `arm` with joint states and a trajectory topic (and `extra` parameters).
BodyRegistry makeRegistry(const std::string& extra = "") {
  const std::string text = R"(
stale_timeout: 0.5
bodies:
  - {name: arm, odom_topic: /arm/odom, robot_description: /arm_description, joint_states_topic: /arm/joint_states,
     joint_trajectory_topic: /arm/trajectory)" + extra + R"(}
)";
  return BodyRegistry(vadop_ros::parseParams(vadop_test::yaml(text)),
                      [](const std::string&, std::string& v) {
                        v = vadop_test::kPlanarArm;
                        return true;
                      },
                      vadop_ros::makeDefaultMeshLoader());
}

// The base at (2, 1), turned 0.5 rad, still (or driving at vx along its heading).
nav_msgs::Odometry baseOdom(double t, double vx = 0.0) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(t);
  m.header.frame_id = "odom";
  m.child_frame_id = "base_link";
  m.pose.pose.position.x = 2.0 + vx * std::cos(0.5) * (t - 100.0);
  m.pose.pose.position.y = 1.0 + vx * std::sin(0.5) * (t - 100.0);
  m.pose.pose.orientation.z = std::sin(0.25);
  m.pose.pose.orientation.w = std::cos(0.25);
  m.twist.twist.linear.x = vx;
  return m;
}

sensor_msgs::JointState joints(double t, double q1, double q2, double v1, double v2) {
  sensor_msgs::JointState m;
  m.header.stamp = ros::Time(t);
  m.name = {"elbow", "shoulder"};  // any order
  m.position = {q2, q1};
  m.velocity = {v2, v1};
  return m;
}

// This file's kinematics: the sphere's centre and the box's centre in the fixed frame.
Eigen::Vector3d base(double t, double vx) {
  return {2.0 + vx * std::cos(0.5) * (t - 100.0), 1.0 + vx * std::sin(0.5) * (t - 100.0), 0.0};
}
Eigen::Vector3d sphereCentre(double t, double q1, double q2, double vx = 0.0) {
  const double a = 0.5 + q1, b = a + q2;
  return base(t, vx) + Eigen::Vector3d(std::cos(a) + 0.8 * std::cos(b), std::sin(a) + 0.8 * std::sin(b), 0.0);
}
Eigen::Vector3d boxCentre(double t, double q1, double vx = 0.0) {
  return base(t, vx) + 0.5 * Eigen::Vector3d(std::cos(0.5 + q1), std::sin(0.5 + q1), 0.0);
}

const vadop_ros::Element& element(const BodyRegistry& r, const std::string& link) {
  for (const auto& e : r.elements()) {
    if (e.link == link) return e;
  }
  throw std::runtime_error("no element " + link);
}

Eigen::Vector3d centreAt(const BodyRegistry& r, const vadop_ros::Element& e, double t) {
  return e.chain ? e.chain->poseAt(r.seconds(ros::Time(t))).translation() : e.motion.positionAt(r.seconds(ros::Time(t)));
}

}  // namespace

TEST(JointStates, LinksFollowTheJointMotionOverTheHorizon) {
  for (const double vx : {0.0, 0.7}) {
    BodyRegistry r = makeRegistry();
    FakeTf tf;
    ASSERT_EQ(r.onOdometry(0, baseOdom(100.0, vx), ros::Time(100.0)), InputResult::kAccepted);
    ASSERT_EQ(r.onJointState(0, joints(100.0, -0.5, 0.4, 0.3, -0.2), ros::Time(100.0)), InputResult::kAccepted);
    r.update(ros::Time(100.1), tf);
    const auto& fore = element(r, "fore");
    const auto& upper = element(r, "upper");
    ASSERT_TRUE(fore.active && fore.chain);
    ASSERT_TRUE(upper.active && upper.chain);
    EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "odometry + joint states");
    double worst = 0.0;
    for (double t = 100.1; t <= 102.1; t += 0.0037) {
      const double q1 = -0.5 + 0.3 * (t - 100.0), q2 = 0.4 - 0.2 * (t - 100.0);
      worst = std::max(worst, (centreAt(r, fore, t) - sphereCentre(t, q1, q2, vx)).norm());
      worst = std::max(worst, (centreAt(r, upper, t) - boxCentre(t, q1, vx)).norm());
    }
    // Each link is a vadop::LinkChain: exactly the joint motion, at every time.
    EXPECT_LT(worst, 1e-9) << "vx " << vx;
  }
}

// The chain of steps between any two links (up, undoing joints, then down) is their relative
// pose at every joint position: a 3D tree with rotated origins, prismatic, fixed and continuous
// joints and two branches.
TEST(JointStates, ChainBetweenLinksIsTheirRelativePose) {
  const char* tree = R"(<robot name="tree">
  <link name="root"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
  <joint name="j1" type="revolute"><parent link="root"/><child link="a"/><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.9"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0.5 0 0" rpy="0 0.4 0"/>
    <axis xyz="0.6 0 0.8"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j3" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0 0.3 0" rpy="1 0 0"/></joint>
  <joint name="j4" type="continuous"><parent link="c"/><child link="d"/><origin xyz="0.2 0 0.1"/><axis xyz="1 1 0"/></joint>
  <joint name="j5" type="continuous"><parent link="a"/><child link="e"/><origin xyz="0 0 0.4" rpy="0 0 -0.7"/><axis xyz="0 0 1"/></joint>
</robot>)";
  const vadop_ros::JointKinematics kin(tree);
  const std::vector<std::string> links = {"root", "a", "b", "c", "d", "e"};
  double worst = 0.0;
  std::srand(5);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> q(kin.joints().size());
    for (size_t j = 0; j < q.size(); ++j) q[j] = kin.clamp(j, 4.0 * std::rand() / RAND_MAX - 2.0);
    for (const std::string& from : links) {
      for (const std::string& to : links) {
        std::vector<vadop_ros::JointKinematics::Step> steps;
        ASSERT_TRUE(kin.chain(from, to, steps));
        Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
        for (const auto& st : steps) {
          x = x * st.origin;
          const double qs = st.joint >= 0 ? st.sign * q[static_cast<size_t>(st.joint)] : 0.0;
          if (st.kind == vadop_ros::JointKinematics::Step::Kind::kRevolute) x.rotate(Eigen::AngleAxisd(qs, st.axis.normalized()));
          if (st.kind == vadop_ros::JointKinematics::Step::Kind::kPrismatic) x.translate(qs * st.axis.normalized());
        }
        Eigen::Isometry3d pf, pt;
        ASSERT_TRUE(kin.linkPose(q, from, pf));
        ASSERT_TRUE(kin.linkPose(q, to, pt));
        worst = std::max(worst, (x.matrix() - (pf.inverse() * pt).matrix()).norm());
      }
    }
  }
  EXPECT_LT(worst, 1e-12);
  std::vector<vadop_ros::JointKinematics::Step> steps;
  EXPECT_FALSE(kin.chain("root", "nowhere", steps));
}

// A mobile manipulator driving its plan (path_topic) while its arm moves: the odometry says
// "straight on", the plan turns left on an arc (radius 2 m, from (2, 1) heading 0.5 rad at
// t = 100 s, 1 m/s); each link follows the arc's pose composed with the arm's own kinematics at
// the joints' positions then, at every time of the horizon (the plan's pieces between samples
// of a constant-twist arc are exact). Still joints: the links ride rigidly on the plan.
TEST(JointStates, ArmMovesWithItsJointsOnTheBaseAlongThePlan) {
  const auto yaw = [](double t) { return 0.5 + 0.5 * (t - 100.0); };
  const auto arcBase = [&](double t) {
    return Eigen::Vector3d(2.0 + 2.0 * (std::sin(yaw(t)) - std::sin(0.5)), 1.0 - 2.0 * (std::cos(yaw(t)) - std::cos(0.5)),
                           0.0);
  };
  nav_msgs::Path plan;
  plan.header.frame_id = "odom";
  plan.header.stamp = ros::Time(100.0);
  for (double t = 100.2; t <= 103.0 + 1e-9; t += 0.2) {
    geometry_msgs::PoseStamped ps;
    ps.header.stamp = ros::Time(t);
    ps.pose.position.x = arcBase(t).x();
    ps.pose.position.y = arcBase(t).y();
    ps.pose.orientation.z = std::sin(0.5 * yaw(t));
    ps.pose.orientation.w = std::cos(0.5 * yaw(t));
    plan.poses.push_back(ps);
  }
  for (const double rate : {1.0, 0.0}) {
    BodyRegistry r = makeRegistry(", path_topic: /arm/plan");
    FakeTf tf;
    ASSERT_EQ(r.onOdometry(0, baseOdom(100.0, 1.0), ros::Time(100.0)), InputResult::kAccepted);
    ASSERT_EQ(r.onPath(0, plan, ros::Time(100.0), tf), InputResult::kAccepted);
    ASSERT_EQ(r.onJointState(0, joints(100.0, -0.5, 0.4, 0.3 * rate, -0.2 * rate), ros::Time(100.0)),
              InputResult::kAccepted);
    r.update(ros::Time(100.0), tf);
    EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), rate != 0.0 ? "path + joint states" : "path");
    const auto& fore = element(r, "fore");
    const auto& upper = element(r, "upper");
    ASSERT_TRUE(fore.active && fore.chain);
    ASSERT_TRUE(upper.active && upper.chain);
    double worst = 0.0;
    for (double t = 100.0; t <= 102.0; t += 0.0037) {
      const double q1 = -0.5 + 0.3 * rate * (t - 100.0), q2 = 0.4 - 0.2 * rate * (t - 100.0);
      const double a = yaw(t) + q1, b = a + q2;
      const Eigen::Vector3d sphere = arcBase(t) + Eigen::Vector3d(std::cos(a) + 0.8 * std::cos(b),
                                                                  std::sin(a) + 0.8 * std::sin(b), 0.0);
      const Eigen::Vector3d box = arcBase(t) + 0.5 * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
      worst = std::max(worst, (centreAt(r, fore, t) - sphere).norm());
      worst = std::max(worst, (centreAt(r, upper, t) - box).norm());
    }
    EXPECT_LT(worst, 1e-9) << "joint rate " << rate;
    // The plan ended: the odometry's twist again.
    ASSERT_EQ(r.onOdometry(0, baseOdom(103.4, 1.0), ros::Time(103.4)), InputResult::kAccepted);
    ASSERT_EQ(r.onJointState(0, joints(103.4, 0.5, 0.0, 0.3 * rate, -0.2 * rate), ros::Time(103.4)),
              InputResult::kAccepted);
    r.update(ros::Time(103.5), tf);
    EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), rate != 0.0 ? "odometry + joint states" : "odometry");
    EXPECT_FALSE(r.bodies()[0].status.on_path);
  }
}

TEST(JointStates, StillJointsGiveRigidLinksAtTheirPositions) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, baseOdom(100.0), ros::Time(100.0));
  sensor_msgs::JointState m = joints(100.0, 0.2, -0.7, 0, 0);
  m.velocity.clear();  // no velocities: zero
  ASSERT_EQ(r.onJointState(0, m, ros::Time(100.0)), InputResult::kAccepted);
  r.update(ros::Time(100.0), tf);
  const auto& fore = element(r, "fore");
  ASSERT_TRUE(fore.active);
  EXPECT_FALSE(fore.chain);
  EXPECT_LT((centreAt(r, fore, 101.0) - sphereCentre(101.0, 0.2, -0.7)).norm(), 1e-9);
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "odometry");
}

TEST(JointStates, JointsStopAtTheirLimitsAndWhenStale) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, baseOdom(100.0), ros::Time(100.0));
  r.onJointState(0, joints(100.0, 0.0, 1.8, 0.0, 0.5), ros::Time(100.0));
  r.update(ros::Time(100.0), tf);
  // The elbow reaches its 2 rad limit at 100.4 s and stays there.
  EXPECT_LT((centreAt(r, element(r, "fore"), 101.5) - sphereCentre(101.5, 0.0, 2.0)).norm(), 1e-6);
  EXPECT_LT((centreAt(r, element(r, "fore"), 100.2) - sphereCentre(100.2, 0.0, 1.9)).norm(), 1e-9);
  // Odometry keeps coming, the joint states stop: after stale_timeout the joints hold their
  // last reported positions (as a stale body holds its last pose).
  r.onOdometry(0, baseOdom(100.8), ros::Time(100.8));
  r.update(ros::Time(100.8), tf);
  EXPECT_FALSE(element(r, "fore").chain);
  EXPECT_LT((centreAt(r, element(r, "fore"), 102.0) - sphereCentre(102.0, 0.0, 1.8)).norm(), 1e-9);
}

TEST(JointStates, BadJointStatesAreDroppedNamingTheFieldAndTheStateIsKept) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, baseOdom(100.0), ros::Time(100.0));
  ASSERT_EQ(r.onJointState(0, joints(100.0, 0.1, 0.2, 0, 0), ros::Time(100.0)), InputResult::kAccepted);
  struct Case {
    const char* field;
    std::function<void(sensor_msgs::JointState&)> spoil;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"name[1] \"wrist\" is not a movable joint", [](sensor_msgs::JointState& m) { m.name[1] = "wrist"; }},
      {"name[1] \"elbow\" repeats", [](sensor_msgs::JointState& m) { m.name[1] = "elbow"; }},
      {"position has 1 values for 2 names", [](sensor_msgs::JointState& m) { m.position.pop_back(); }},
      {"velocity has 3 values", [](sensor_msgs::JointState& m) { m.velocity.push_back(0.0); }},
      {"NaN/Inf in position[0]", [nan](sensor_msgs::JointState& m) { m.position[0] = nan; }},
      {"NaN/Inf in velocity[1]", [](sensor_msgs::JointState& m) { m.velocity[1] = INFINITY; }},
      {"velocity[0] = 1e+06 is out of range", [](sensor_msgs::JointState& m) { m.velocity[0] = 1e6; }},
      {"header.stamp", [](sensor_msgs::JointState& m) { m.header.stamp = ros::Time(9000.0); }},
  };
  uint64_t dropped = 0;
  for (const Case& c : cases) {
    sensor_msgs::JointState m = joints(100.05, 1.0, 1.0, 0.0, 0.0);
    c.spoil(m);
    EXPECT_EQ(r.onJointState(0, m, ros::Time(100.05)), InputResult::kInvalid) << c.field;
    EXPECT_EQ(r.bodies()[0].source("joint_states")->counts().dropped, ++dropped);
    EXPECT_NE(r.bodies()[0].status.last_invalid.find(c.field), std::string::npos)
        << c.field << " not in: " << r.bodies()[0].status.last_invalid;
  }
  EXPECT_EQ(r.onJointState(0, joints(99.0, 1.0, 1.0, 0, 0), ros::Time(100.05)), InputResult::kOutOfOrder);
  r.update(ros::Time(100.1), tf);
  EXPECT_LT((centreAt(r, element(r, "fore"), 100.1) - sphereCentre(100.1, 0.1, 0.2)).norm(), 1e-9);
  // A message naming only some joints updates those; the others keep their state.
  sensor_msgs::JointState partial;
  partial.header.stamp = ros::Time(100.2);
  partial.name = {"shoulder"};
  partial.position = {0.6};
  ASSERT_EQ(r.onJointState(0, partial, ros::Time(100.2)), InputResult::kAccepted);
  r.update(ros::Time(100.2), tf);
  EXPECT_LT((centreAt(r, element(r, "fore"), 100.2) - sphereCentre(100.2, 0.6, 0.2)).norm(), 1e-9);
}

trajectory_msgs::JointTrajectory trajectory(double stamp, bool with_velocities) {
  trajectory_msgs::JointTrajectory m;
  m.header.stamp = ros::Time(stamp);
  m.joint_names = {"shoulder"};
  const double q[] = {0.0, 0.4, 1.0}, v[] = {0.0, 0.5, 0.0}, t[] = {0.0, 0.8, 1.6};
  for (int k = 0; k < 3; ++k) {
    trajectory_msgs::JointTrajectoryPoint p;
    p.positions = {q[k]};
    if (with_velocities) p.velocities = {v[k]};
    p.time_from_start = ros::Duration(t[k]);
    m.points.push_back(p);
  }
  return m;
}

// This file's interpolation of trajectory(): cubic Hermite (or linear) between the points.
double shoulderOnTrajectory(double s, bool with_velocities) {
  const double q[] = {0.0, 0.4, 1.0}, v[] = {0.0, 0.5, 0.0}, t[] = {0.0, 0.8, 1.6};
  if (s <= 0.0) return q[0];
  if (s >= 1.6) return q[2];
  const int k = s < 0.8 ? 0 : 1;
  const double h = t[k + 1] - t[k], u = (s - t[k]) / h;
  if (!with_velocities) return q[k] + (q[k + 1] - q[k]) * u;
  const double h00 = 2 * u * u * u - 3 * u * u + 1, h10 = u * u * u - 2 * u * u + u, h01 = -2 * u * u * u + 3 * u * u,
               h11 = u * u * u - u * u;
  return h00 * q[k] + h10 * h * v[k] + h01 * q[k + 1] + h11 * h * v[k + 1];
}

TEST(JointStates, TrajectoryIsFollowedThenItsLastPointHeld) {
  for (const bool with_velocities : {true, false}) {
    BodyRegistry r = makeRegistry();
    FakeTf tf;
    r.onOdometry(0, baseOdom(100.0), ros::Time(100.0));
    // The elbow from joint states (still at 0.3); the shoulder from the trajectory.
    r.onJointState(0, joints(100.0, 0.0, 0.3, 0.0, 0.0), ros::Time(100.0));
    // Stamped zero: its times count from its receipt, 100.2 s.
    ASSERT_EQ(r.onJointTrajectory(0, trajectory(0.0, with_velocities), ros::Time(100.2)), InputResult::kAccepted);
    r.update(ros::Time(100.3), tf);
    const auto& fore = element(r, "fore");
    ASSERT_TRUE(fore.chain);
    EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "joint trajectory");
    double worst = 0.0;
    for (double t = 100.3; t <= 102.3; t += 0.0041) {
      worst = std::max(worst, (centreAt(r, fore, t) - sphereCentre(t, shoulderOnTrajectory(t - 100.2, with_velocities), 0.3))
                                  .norm());
    }
    // The chain follows the cubic (or the straight lines) itself.
    EXPECT_LT(worst, 1e-9) << "with_velocities " << with_velocities;
    std::printf("trajectory (%s): largest deviation from this test's interpolation %.2e m\n",
                with_velocities ? "cubic" : "linear", worst);
    // After its end (101.8 s) the trajectory no longer drives the prediction: the joint states do.
    r.onOdometry(0, baseOdom(101.9), ros::Time(101.9));
    r.onJointState(0, joints(101.9, 1.0, 0.3, 0.0, 0.0), ros::Time(101.9));
    r.update(ros::Time(101.9), tf);
    EXPECT_FALSE(element(r, "fore").chain);
    EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[0]), "odometry");
  }
}

// Odometry of the forearm: the upper arm hangs above it in the tree, reached by undoing the
// elbow, whose trajectory (cubic, with velocities) the chain must follow backwards too.
TEST(JointStates, ALinkAboveTheOdometryFrameFollowsTheTrajectoryBackwards) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  nav_msgs::Odometry odom = baseOdom(100.0);
  odom.child_frame_id = "fore";
  ASSERT_EQ(r.onOdometry(0, odom, ros::Time(100.0)), InputResult::kAccepted);
  r.onJointState(0, joints(100.0, 0.0, 0.0, 0.0, 0.0), ros::Time(100.0));
  trajectory_msgs::JointTrajectory elbow = trajectory(0.0, true);
  elbow.joint_names = {"elbow"};
  ASSERT_EQ(r.onJointTrajectory(0, elbow, ros::Time(100.2)), InputResult::kAccepted);
  r.update(ros::Time(100.3), tf);
  const auto& upper = element(r, "upper");
  ASSERT_TRUE(upper.chain);
  double worst = 0.0;
  for (double t = 100.3; t <= 102.3; t += 0.0041) {
    // The forearm's frame holds at (2, 1), turned 0.5; the upper arm's is that frame turned by
    // -q_elbow and moved 1 m back along its x, the box 0.5 m forward along it.
    const double a = 0.5 - shoulderOnTrajectory(t - 100.2, true);
    const Eigen::Vector3d want = Eigen::Vector3d(2.0, 1.0, 0.0) - 0.5 * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
    worst = std::max(worst, (centreAt(r, upper, t) - want).norm());
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(JointStates, BadTrajectoriesAreDroppedNamingTheField) {
  BodyRegistry r = makeRegistry();
  FakeTf tf;
  r.onOdometry(0, baseOdom(100.0), ros::Time(100.0));
  ASSERT_EQ(r.onJointTrajectory(0, trajectory(100.0, true), ros::Time(100.0)), InputResult::kAccepted);
  struct Case {
    const char* field;
    std::function<void(trajectory_msgs::JointTrajectory&)> spoil;
  };
  const std::vector<Case> cases = {
      {"joint_names[0] \"wrist\" is not a movable joint", [](auto& m) { m.joint_names[0] = "wrist"; }},
      {"joint_names[1] \"shoulder\" repeats",
       [](auto& m) {
         m.joint_names.push_back("shoulder");
         for (auto& p : m.points) p.positions.push_back(0.0), p.velocities.push_back(0.0);
       }},
      {"points[1].positions has 2 values", [](auto& m) { m.points[1].positions.push_back(0.0); }},
      {"points[2].velocities has 2 values", [](auto& m) { m.points[2].velocities.push_back(0.0); }},
      {"NaN/Inf in points[1].positions[0]", [](auto& m) { m.points[1].positions[0] = NAN; }},
      {"points[2].time_from_start does not increase", [](auto& m) { m.points[2].time_from_start = ros::Duration(0.8); }},
      {"points[0].time_from_start = -0.5", [](auto& m) { m.points[0].time_from_start = ros::Duration(-0.5); }},
      {"header.stamp", [](auto& m) { m.header.stamp = ros::Time(5000.0); }},
  };
  for (const Case& c : cases) {
    trajectory_msgs::JointTrajectory m = trajectory(100.0, true);
    c.spoil(m);
    EXPECT_EQ(r.onJointTrajectory(0, m, ros::Time(100.0)), InputResult::kInvalid) << c.field;
    EXPECT_NE(r.bodies()[0].status.last_invalid.find(c.field), std::string::npos)
        << c.field << " not in: " << r.bodies()[0].status.last_invalid;
  }
  EXPECT_EQ(r.bodies()[0].source("joint_trajectory")->counts().dropped, cases.size());
  r.update(ros::Time(100.4), tf);  // the first trajectory still runs
  EXPECT_LT((centreAt(r, element(r, "fore"), 101.2) - sphereCentre(101.2, shoulderOnTrajectory(1.2, true), 0.0)).norm(),
            1e-3);
  // No points: cancelled.
  trajectory_msgs::JointTrajectory cancel;
  ASSERT_EQ(r.onJointTrajectory(0, cancel, ros::Time(100.5)), InputResult::kAccepted);
  r.update(ros::Time(100.5), tf);
  EXPECT_FALSE(element(r, "fore").chain);
}

TEST(JointStates, Parameters) {
  const auto error = [](const std::string& body) {
    try {
      vadop_ros::parseParams(vadop_test::yaml("bodies:\n  - {name: r, odom_topic: /o, " + body + "}\n"));
    } catch (const vadop_ros::ParamError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("robot_description: /d, joint_states_topic: /r/joint_states"), "no error");
  EXPECT_NE(error("shape: {type: sphere, radius: 1}, joint_states_topic: /j").find("robot_description bodies only"),
            std::string::npos);
  EXPECT_NE(error("robot_description: /d, tf_prefix: r, joint_states_topic: /j").find("not both"), std::string::npos);
  // A mobile manipulator: its plan moves the body frame, its joints the links on it.
  EXPECT_EQ(error("robot_description: /d, path_topic: /p, joint_states_topic: /j, joint_trajectory_topic: /t"),
            "no error");
  EXPECT_NE(error("robot_description: /d, joint_states_topic: /o").find("must differ"), std::string::npos);
}
