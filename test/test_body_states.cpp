// Fleet arrays (states_topic, vadop/BodyStateArray): entries routed by name to the bodies of
// their topic, entries naming no body of the topic counted and ignored, a bad entry dropped
// (its warning naming it) with the rest of the array kept, the pose taken through tf from the
// array's header frame, the twist in the body frame; the parameters; a cycle and a gate for
// such bodies as for odometry bodies.
#include "vadop_ros/body_registry.h"
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/monitor_diagnostics.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using vadop_ros::BodyRegistry;
using vadop_ros::BodyState;
using vadop_ros::BodyStatesCounts;
using vadop_test::FakeTf;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

vadop_ros::ParamReader noParams() {
  return [](const std::string&, std::string&) { return false; };
}

vadop_ros::MonitorParams params(const std::string& text) { return vadop_ros::parseParams(vadop_test::yaml(text)); }

// Three bodies of a template on /fleet, one on /other, one odometry body.
const char* kFleet = R"(
stale_timeout: 0.5
bodies:
  - {name: "cart_{i}", count: 3, states_topic: /fleet, shape: {type: sphere, radius: 0.5}}
  - {name: solo, states_topic: /other, shape: {type: sphere, radius: 0.5}}
  - {name: odo, odom_topic: /odo, shape: {type: sphere, radius: 0.5}}
)";

// An entry at (x, y) heading `yaw`, moving at (vx, vy) in its body frame and turning at wz.
vadop::BodyState entry(const std::string& name, double x, double y, double yaw = 0.0, double vx = 0.0,
                       double vy = 0.0, double wz = 0.0) {
  vadop::BodyState s;
  s.name = name;
  s.pose.position.x = x;
  s.pose.position.y = y;
  s.pose.orientation.z = std::sin(yaw / 2);
  s.pose.orientation.w = std::cos(yaw / 2);
  s.twist.linear.x = vx;
  s.twist.linear.y = vy;
  s.twist.angular.z = wz;
  return s;
}

vadop::BodyStateArray states(double stamp, std::vector<vadop::BodyState> entries, const std::string& frame = "odom") {
  vadop::BodyStateArray m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = frame;
  m.states = std::move(entries);
  return m;
}

// The element of the body named `name` (primitive bodies: one element each).
const vadop_ros::Element& elementOf(const BodyRegistry& r, const std::string& name) {
  return r.elements()[r.bodies()[r.find(name)].elements.at(0)];
}

}  // namespace

TEST(BodyStates, EntriesGoToTheBodiesTheyNameOnTheirTopic) {
  BodyRegistry r(params(kFleet), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  // Out of the bodies' order; "ghost" names no body, "solo" a body of another topic.
  const BodyStatesCounts c = r.onBodyStates(
      "/fleet",
      states(10.0, {entry("cart_2", 1, 2, M_PI / 2, 1.0), entry("ghost", 0, 0), entry("cart_0", -3, 0, 0, 0.5),
                    entry("solo", 7, 7)}),
      ros::Time(10.0));
  EXPECT_EQ(c.accepted, 2u);
  EXPECT_EQ(c.unknown, 2u);
  EXPECT_EQ(c.dropped, 0u);
  r.update(ros::Time(10.2), tf);
  const double now = r.seconds(ros::Time(10.2));
  // cart_2 heading +y: its body-frame vx = 1 is +y in the fixed frame.
  const auto& e2 = elementOf(r, "cart_2");
  ASSERT_TRUE(e2.active);
  EXPECT_TRUE(e2.motion.positionAt(now).isApprox(Eigen::Vector3d(1.0, 2.2, 0.0), 1e-9));
  EXPECT_TRUE(e2.motion.linear_velocity.isApprox(Eigen::Vector3d(0, 1, 0), 1e-9));
  const auto& e0 = elementOf(r, "cart_0");
  ASSERT_TRUE(e0.active);
  EXPECT_TRUE(e0.motion.positionAt(now).isApprox(Eigen::Vector3d(-2.9, 0.0, 0.0), 1e-9));
  // Named nowhere or only on another topic: still waiting.
  EXPECT_EQ(r.bodies()[r.find("cart_1")].status.state, BodyState::kWaiting);
  EXPECT_EQ(r.bodies()[r.find("solo")].status.state, BodyState::kWaiting);
  EXPECT_FALSE(elementOf(r, "solo").active);
  EXPECT_STREQ(vadop_ros::motionSource(r.bodies()[r.find("cart_2")]), "body states");

  // solo takes its entry from its own topic; a topic no body names brings nothing.
  EXPECT_EQ(r.onBodyStates("/other", states(10.1, {entry("solo", 7, 7), entry("cart_1", 0, 0)}), ros::Time(10.1)).accepted,
            1u);
  EXPECT_EQ(r.onBodyStates("/nobody", states(10.1, {entry("solo", 1, 1)}), ros::Time(10.1)).unknown, 1u);
  r.update(ros::Time(10.2), tf);
  EXPECT_TRUE(elementOf(r, "solo").active);
  EXPECT_FALSE(elementOf(r, "cart_1").active);

  // The totals per topic, as the diagnostics list them.
  const auto topics = r.bodyStatesTopics();
  ASSERT_EQ(topics.size(), 2u);
  EXPECT_EQ(topics[0].first, "/fleet");
  EXPECT_EQ(topics[0].second.arrays, 1u);
  EXPECT_EQ(topics[0].second.accepted, 2u);
  EXPECT_EQ(topics[0].second.unknown, 2u);
  EXPECT_EQ(topics[1].first, "/other");
  EXPECT_EQ(topics[1].second.unknown, 1u);
  diagnostic_updater::DiagnosticStatusWrapper stat;
  vadop_ros::reportBodies(stat, r, ros::Time(10.2));
  bool listed = false;
  for (const auto& kv : stat.values) {
    if (kv.key == "states_topic /fleet") {
      listed = true;
      EXPECT_NE(kv.value.find("2 naming no body"), std::string::npos) << kv.value;
    }
  }
  EXPECT_TRUE(listed);
}

TEST(BodyStates, ABadEntryIsDroppedNamingItAndTheRestKept) {
  BodyRegistry r(params(kFleet), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  ASSERT_EQ(r.onBodyStates("/fleet", states(1.0, {entry("cart_0", 0, 0, 0, 1.0)}), ros::Time(1.0)).accepted, 1u);
  vadop::BodyState nan_entry = entry("cart_0", kNaN, 0);
  vadop::BodyState zero_q = entry("cart_1", 1, 0);
  zero_q.pose.orientation.w = 0.0;
  vadop::BodyState inf_twist = entry("cart_1", 1, 0);
  inf_twist.twist.angular.z = std::numeric_limits<double>::infinity();
  const BodyStatesCounts c =
      r.onBodyStates("/fleet", states(1.1, {nan_entry, zero_q, entry("cart_2", 5, 0, 0, -1.0)}), ros::Time(1.1));
  EXPECT_EQ(c.dropped, 2u);
  EXPECT_EQ(c.accepted, 1u);
  const auto& s0 = r.bodies()[r.find("cart_0")].status;
  EXPECT_EQ(s0.dropped_invalid, 1u);
  EXPECT_NE(s0.last_invalid.find("entry \"cart_0\" (states[0] of /fleet): NaN/Inf in pose.position.x"),
            std::string::npos)
      << s0.last_invalid;
  const auto& s1 = r.bodies()[r.find("cart_1")].status;
  EXPECT_NE(s1.last_invalid.find("entry \"cart_1\" (states[1] of /fleet): zero-norm quaternion in pose.orientation"),
            std::string::npos)
      << s1.last_invalid;
  EXPECT_EQ(r.onBodyStates("/fleet", states(1.15, {inf_twist}), ros::Time(1.15)).dropped, 1u);
  EXPECT_NE(s1.last_invalid.find("twist.angular"), std::string::npos) << s1.last_invalid;
  // cart_0 keeps its last good state, cart_2 took its entry, cart_1 has none.
  r.update(ros::Time(1.2), tf);
  const double now = r.seconds(ros::Time(1.2));
  ASSERT_TRUE(elementOf(r, "cart_0").active);
  EXPECT_TRUE(elementOf(r, "cart_0").motion.positionAt(now).isApprox(Eigen::Vector3d(0.2, 0, 0), 1e-9));
  ASSERT_TRUE(elementOf(r, "cart_2").active);
  EXPECT_TRUE(elementOf(r, "cart_2").motion.positionAt(now).isApprox(Eigen::Vector3d(4.9, 0, 0), 1e-9));
  EXPECT_FALSE(elementOf(r, "cart_1").active);
  // A stamp not newer than the body's last: ignored, counted.
  EXPECT_EQ(r.onBodyStates("/fleet", states(1.0, {entry("cart_2", 9, 9)}), ros::Time(1.2)).out_of_order, 1u);
}

TEST(BodyStates, PoseInTheHeaderFrameGoesThroughTf) {
  BodyRegistry r(params(kFleet), noParams(), vadop_ros::makeDefaultMeshLoader());
  FakeTf tf;
  Eigen::Isometry3d map_in_odom = Eigen::Isometry3d::Identity();
  map_in_odom.translation() = Eigen::Vector3d(10, 0, 0);
  map_in_odom.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("odom", "map", map_in_odom);
  // In map: at (1, 0) heading +x at 2 m/s, turning at 0.5 rad/s. In odom: at (10, 1) heading +y.
  ASSERT_EQ(r.onBodyStates("/fleet", states(5.0, {entry("cart_1", 1, 0, 0, 2.0, 0, 0.5)}, "/map"), ros::Time(5.0))
                .accepted,
            1u);
  r.update(ros::Time(5.0), tf);
  const auto& e = elementOf(r, "cart_1");
  ASSERT_TRUE(e.active);
  EXPECT_TRUE(e.motion.positionAt(r.seconds(ros::Time(5.0))).isApprox(Eigen::Vector3d(10, 1, 0), 1e-9));
  EXPECT_TRUE(e.motion.velocityOfPoint(Eigen::Vector3d(10, 1, 0), r.seconds(ros::Time(5.0)))
                  .isApprox(Eigen::Vector3d(0, 2, 0), 1e-9));
  // A header frame tf does not know: the body is skipped, flagged.
  ASSERT_EQ(r.onBodyStates("/fleet", states(5.1, {entry("cart_1", 1, 0)}, "nowhere"), ros::Time(5.1)).accepted, 1u);
  r.update(ros::Time(5.1), tf);
  EXPECT_FALSE(elementOf(r, "cart_1").active);
  EXPECT_EQ(r.bodies()[r.find("cart_1")].status.state, BodyState::kTfMissing);
}

TEST(BodyStates, ParametersNameTheKeys) {
  auto errorOf = [](const std::string& text) {
    try {
      params(text);
    } catch (const vadop_ros::ParamError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, states_topic: /f, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\"): give one velocity source: odom_topic, twist_topic or states_topic, not "
                      "odom_topic and states_topic"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, twist_topic: /a, states_topic: /f, frame: f, shape: {type: sphere, radius: 1}}]")
                .find("not twist_topic and states_topic"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, states_topic: '', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").states_topic: must not be empty"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, states_topic: 'bad topic', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").states_topic"),
            std::string::npos);
  // A template shares one topic; the frame is optional.
  const auto p = params("bodies: [{name: 'c{i}', count: 2, states_topic: /f, shape: {type: sphere, radius: 1}}]");
  ASSERT_EQ(p.bodies.size(), 2u);
  EXPECT_EQ(p.bodies[1].source, vadop_ros::VelocitySource::kStates);
  EXPECT_EQ(p.bodies[1].topic, "/f");
}

// A cycle and a gate for fleet bodies as for odometry bodies.
TEST(BodyStates, ImpactsAndGatesAsForOdometryBodies) {
  vadop_ros::MonitorCore core(params(R"(
fixed_frame: odom
horizon: 3.0
bodies:
  - {name: "c{i}", count: 2, states_topic: /fleet, shape: {type: sphere, radius: 0.5},
     gate: {cmd_vel_in: "/c{i}/in", cmd_vel_out: "/c{i}/out"}}
)"),
                              noParams());
  FakeTf tf;
  // Head-on along x: gap 3 m, closing at 2 m/s -> contact 1.5 s after the stamp.
  core.registry().onBodyStates("/fleet", states(100.0, {entry("c0", -2, 0, 0, 1.0), entry("c1", 2, 0, M_PI, 1.0)}),
                               ros::Time(100.0));
  const vadop::ImpactArray& out = core.cycle(ros::Time(100.25), tf);
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_EQ(out.impacts[0].body_a, "c0");
  EXPECT_EQ(out.impacts[0].body_b, "c1");
  EXPECT_NEAR(out.impacts[0].time_to_impact, 1.25, 1e-4);
  // c0 driving on at 1 m/s: c1 (coming at 1 m/s) reached in 1.25 s, within a 2 s window: not
  // clear at full speed; backing away is.
  const vadop_ros::CommandCheck ahead =
      core.checkCommand(0, {1, 0, 0}, Eigen::Vector3d::Zero(), ros::Time(100.25), tf, 2.0, 0.5);
  ASSERT_EQ(ahead.status, vadop_ros::CommandCheck::Status::kChecked);
  EXPECT_LT(ahead.scale.scale, 1.0);
  const vadop_ros::CommandCheck away =
      core.checkCommand(0, {-1, 0, 0}, Eigen::Vector3d::Zero(), ros::Time(100.25), tf, 2.0, 0.5);
  ASSERT_EQ(away.status, vadop_ros::CommandCheck::Status::kChecked);
  EXPECT_DOUBLE_EQ(away.scale.scale, 1.0);
}
