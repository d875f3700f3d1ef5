// Tracked objects (~tracks, tracks.h): objects appear, update, expire and re-appear; duplicate
// ids; bad objects dropped naming the source, the id and the field with the rest of the array
// kept; frames; stamps; and through MonitorCore: impacts naming "<prefix>/<id>", ~ignore_pairs
// globs, a velocity gate limited by a tracked object, and objects joining and leaving the world
// without disturbing the bodies.
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/monitor_diagnostics.h"
#include "vadop_ros/tracks.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <shape_msgs/SolidPrimitive.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

using vadop_ros::InputResult;
using vadop_ros::MonitorCore;
using vadop_ros::Tracks;
using vadop_test::FakeTf;

namespace {

vadop_ros::TrackParams people(double timeout = 0.5) {
  vadop_ros::TrackParams p;
  p.topic = "/people/tracks";
  p.prefix = "people";
  p.has_default_shape = true;
  p.default_shape = vadop::makeCylinder(0.3, 1.8);
  p.timeout = timeout;
  return p;
}

vadop::TrackedObject object(const std::string& id, double x, double y, double vx = 0.0, double vy = 0.0) {
  vadop::TrackedObject o;
  o.id = id;
  o.pose.position.x = x;
  o.pose.position.y = y;
  o.pose.orientation.w = 1.0;
  o.twist.linear.x = vx;
  o.twist.linear.y = vy;
  return o;  // shape type 0: the default
}

vadop::TrackedObjectArray array(double stamp, std::vector<vadop::TrackedObject> objects,
                                const std::string& frame = "odom") {
  vadop::TrackedObjectArray a;
  a.header.stamp = ros::Time(stamp);
  a.header.frame_id = frame;
  a.objects = std::move(objects);
  return a;
}

const vadop_ros::TrackedObject* find(const Tracks& t, const std::string& name) {
  for (const auto& s : t.slots()) {
    if (s.alive && s.name == name) return &s;
  }
  return nullptr;
}

}  // namespace

TEST(Tracks, AppearUpdateExpireReappear) {
  Tracks t({people()}, "odom", 5.0);
  FakeTf tf;
  ASSERT_EQ(t.onArray(0, array(100.0, {object("1", 0, 0, 1.0), object("2", 5, 0)}), ros::Time(100.0), tf),
            InputResult::kAccepted);
  EXPECT_EQ(t.alive(), 2u);
  ASSERT_NE(find(t, "people/1"), nullptr);
  EXPECT_EQ(find(t, "people/1")->shape.type, vadop::ShapeType::kCylinder);  // the default shape
  EXPECT_DOUBLE_EQ(find(t, "people/1")->v.x(), 1.0);
  const size_t slot2 = static_cast<size_t>(find(t, "people/2") - t.slots().data());
  // "2" is missing from the next array: it stays until its timeout.
  t.onArray(0, array(100.2, {object("1", 0.2, 0, 1.0)}), ros::Time(100.2), tf);
  EXPECT_DOUBLE_EQ(find(t, "people/1")->pose.translation().x(), 0.2);
  std::vector<size_t> left;
  t.expire(ros::Time(100.45), left);
  EXPECT_TRUE(left.empty());
  EXPECT_EQ(t.alive(), 2u);
  t.expire(ros::Time(100.55), left);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0], slot2);
  EXPECT_EQ(find(t, "people/2"), nullptr);
  EXPECT_EQ(t.status(0).objects_expired, 1u);
  EXPECT_EQ(t.status(0).objects, 1u);
  // It comes back: the same name, in a free slot (the one it left).
  t.onArray(0, array(101.0, {object("1", 1.0, 0, 1.0), object("2", 6, 0)}), ros::Time(101.0), tf);
  ASSERT_NE(find(t, "people/2"), nullptr);
  EXPECT_EQ(static_cast<size_t>(find(t, "people/2") - t.slots().data()), slot2);
  EXPECT_DOUBLE_EQ(find(t, "people/2")->pose.translation().x(), 6.0);
  EXPECT_EQ(t.status(0).arrays_accepted, 3u);
}

TEST(Tracks, DuplicateIdKeepsTheLastAndWarns) {
  Tracks t({people()}, "odom", 5.0);
  FakeTf tf;
  t.onArray(0, array(100.0, {object("a", 1, 0), object("b", 3, 0), object("a", 2, 0)}), ros::Time(100.0), tf);
  EXPECT_EQ(t.alive(), 2u);
  EXPECT_DOUBLE_EQ(find(t, "people/a")->pose.translation().x(), 2.0);
  EXPECT_EQ(t.status(0).objects_dropped, 1u);
  EXPECT_NE(t.status(0).last_problem.find("objects[0] (id \"a\")"), std::string::npos) << t.status(0).last_problem;
  EXPECT_NE(t.status(0).last_problem.find("objects[2] is kept"), std::string::npos) << t.status(0).last_problem;
}

TEST(Tracks, BadObjectsAreDroppedNamingTheFieldAndTheRestKept) {
  using shape_msgs::SolidPrimitive;
  struct Case {
    std::function<void(vadop::TrackedObject&)> spoil;
    std::string expected;  // in last_problem
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {[&](vadop::TrackedObject& o) { o.pose.position.y = nan; }, "NaN/Inf in objects[1].pose.position.y"},
      {[&](vadop::TrackedObject& o) { o.twist.linear.x = std::numeric_limits<double>::infinity(); },
       "NaN/Inf in objects[1].twist.linear.x"},
      {[](vadop::TrackedObject& o) { o.pose.orientation.w = 0.0; }, "zero-norm quaternion in objects[1].pose.orientation"},
      {[](vadop::TrackedObject& o) {
         o.shape.type = SolidPrimitive::CONE;
         o.shape.dimensions = {1.0, 0.5};
       },
       "objects[1].shape.type = 4 is not supported"},
      {[](vadop::TrackedObject& o) {
         o.shape.type = SolidPrimitive::BOX;
         o.shape.dimensions = {1.0, -0.5, 1.0};
       },
       "objects[1].shape.dimensions[1] = -0.500000 is not > 0"},
      {[](vadop::TrackedObject& o) {
         o.shape.type = SolidPrimitive::CYLINDER;
         o.shape.dimensions = {1.0};
       },
       "objects[1].shape.dimensions has 1 values, a CYLINDER needs 2 (height, radius)"},
      {[](vadop::TrackedObject& o) {
         o.shape.type = SolidPrimitive::SPHERE;
         o.shape.dimensions = {0.0};
       },
       "objects[1].shape.dimensions[0] = 0.000000 is not > 0"},
      {[](vadop::TrackedObject& o) { o.id.clear(); }, "empty id"},
      {[](vadop::TrackedObject& o) { o.pose.position.x = 1e9; }, "objects[1].pose.position.x = 1e+09 is out of range"},
  };
  for (const Case& c : cases) {
    Tracks t({people()}, "odom", 5.0);
    FakeTf tf;
    t.onArray(0, array(100.0, {object("keep", 0, 0)}), ros::Time(100.0), tf);
    vadop::TrackedObject bad = object("bad", 3, 0);
    c.spoil(bad);
    EXPECT_EQ(t.onArray(0, array(100.1, {object("keep", 0.1, 0), bad, object("new", 5, 0)}), ros::Time(100.1), tf),
              InputResult::kAccepted);
    EXPECT_EQ(t.status(0).objects_dropped, 1u) << c.expected;
    EXPECT_NE(t.status(0).last_problem.find(c.expected), std::string::npos)
        << "expected \"" << c.expected << "\" in: " << t.status(0).last_problem;
    EXPECT_NE(t.status(0).last_problem.find("objects[1] (id \"" + bad.id + "\")"), std::string::npos);
    // The rest of the array is kept; the bad object never enters.
    EXPECT_EQ(t.alive(), 2u) << c.expected;
    EXPECT_DOUBLE_EQ(find(t, "people/keep")->pose.translation().x(), 0.1);
    EXPECT_NE(find(t, "people/new"), nullptr);
    EXPECT_EQ(find(t, "people/bad"), nullptr);
  }
  // A source without default_shape: type 0 is refused.
  vadop_ros::TrackParams no_default = people();
  no_default.has_default_shape = false;
  Tracks t({no_default}, "odom", 5.0);
  FakeTf tf;
  vadop::TrackedObject sphere = object("s", 0, 0);
  sphere.shape.type = shape_msgs::SolidPrimitive::SPHERE;
  sphere.shape.dimensions = {0.4};
  t.onArray(0, array(100.0, {object("d", 0, 0), sphere}), ros::Time(100.0), tf);
  EXPECT_EQ(t.alive(), 1u);
  EXPECT_EQ(find(t, "people/s")->shape.type, vadop::ShapeType::kSphere);
  EXPECT_NE(t.status(0).last_problem.find("has no default_shape"), std::string::npos);
}

TEST(Tracks, ArraysInAnotherFrameAreTransformedAndUnresolvableOnesDropped) {
  Tracks t({people()}, "odom", 5.0);
  FakeTf tf;
  Eigen::Isometry3d map_in_odom = Eigen::Isometry3d::Identity();
  map_in_odom.translation() = Eigen::Vector3d(10, 0, 0);
  map_in_odom.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  tf.set("odom", "map", map_in_odom);
  t.onArray(0, array(100.0, {object("1", 1, 0, 1.0)}, "map"), ros::Time(100.0), tf);
  const auto* o = find(t, "people/1");
  ASSERT_NE(o, nullptr);
  EXPECT_NEAR((o->pose.translation() - Eigen::Vector3d(10, 1, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((o->v - Eigen::Vector3d(0, 1, 0)).norm(), 0.0, 1e-12);  // turned with the frame
  // A frame tf does not know: the whole array is dropped, the objects keep their state.
  EXPECT_EQ(t.onArray(0, array(100.1, {object("1", 2, 0)}, "nowhere"), ros::Time(100.1), tf), InputResult::kInvalid);
  EXPECT_EQ(t.status(0).arrays_dropped, 1u);
  EXPECT_NE(t.status(0).last_problem.find("header.frame_id \"nowhere\""), std::string::npos) << t.status(0).last_problem;
  EXPECT_NEAR(find(t, "people/1")->pose.translation().x(), 10.0, 1e-12);
  EXPECT_EQ(t.onArray(0, array(100.2, {object("1", 2, 0)}, ""), ros::Time(100.2), tf), InputResult::kInvalid);
  EXPECT_NE(t.status(0).last_problem.find("header.frame_id is empty"), std::string::npos);
}

TEST(Tracks, StampsFarOffAreDroppedAndOlderArraysOutOfOrder) {
  Tracks t({people()}, "odom", 5.0);
  FakeTf tf;
  EXPECT_EQ(t.onArray(0, array(90.0, {object("1", 0, 0)}), ros::Time(100.0), tf), InputResult::kInvalid);
  EXPECT_NE(t.status(0).last_problem.find("max_stamp_skew"), std::string::npos);
  EXPECT_EQ(t.onArray(0, array(100.0, {object("1", 0, 0)}), ros::Time(100.0), tf), InputResult::kAccepted);
  EXPECT_EQ(t.onArray(0, array(99.9, {object("1", 5, 0)}), ros::Time(100.1), tf), InputResult::kOutOfOrder);
  EXPECT_DOUBLE_EQ(find(t, "people/1")->pose.translation().x(), 0.0);
  // Stamp zero: the receipt.
  EXPECT_EQ(t.onArray(0, array(0.0, {object("1", 1, 0)}), ros::Time(100.2), tf), InputResult::kAccepted);
  EXPECT_EQ(find(t, "people/1")->stamp, ros::Time(100.2));
}

namespace {

nav_msgs::Odometry odom(double stamp, double x, double vx) {
  nav_msgs::Odometry m;
  m.header.stamp = ros::Time(stamp);
  m.header.frame_id = "odom";
  m.pose.pose.position.x = x;
  m.pose.pose.orientation.w = 1.0;
  m.twist.twist.linear.x = vx;
  return m;
}

MonitorCore makeCore(const std::string& extra = "") {
  const std::string text = R"(
horizon: 2.0
bodies:
  - {name: robot, odom_topic: /robot/odom, shape: {type: box, size: [0.6, 0.6, 0.4]},
     gate: {cmd_vel_in: /in, cmd_vel_out: /out, time_before_collision: 2.0}}
tracks:
  - {topic: /people/tracks, default_shape: {type: cylinder, radius: 0.3, length: 1.8}, prefix: people}
)" + extra;
  return MonitorCore(vadop_ros::parseParams(vadop_test::yaml(text)),
                     [](const std::string&, std::string&) { return false; });
}

}  // namespace

TEST(TracksInTheMonitor, ImpactsNameTheObjectAndObjectsLeaveWithoutDisturbingBodies) {
  MonitorCore core = makeCore();
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, 0.0, 1.0), ros::Time(100.0));
  // Person 7 walks towards the robot: gap 4 - 0.3 - 0.3 = 3.4 m closing at 2 m/s: 1.7 s.
  core.tracks().onArray(0, array(100.0, {object("7", 4.0, 0.0, -1.0), object("8", 0.0, 20.0)}), ros::Time(100.0), tf);
  const vadop::ImpactArray& out = core.cycle(ros::Time(100.0), tf);
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_EQ(out.impacts[0].body_a, "robot");
  EXPECT_EQ(out.impacts[0].body_b, "people/7");
  EXPECT_EQ(out.impacts[0].link_b, "");
  EXPECT_NEAR(out.impacts[0].time_to_impact, 1.7, 1e-4);
  EXPECT_EQ(core.lastStats().elements_in_world, 3u);
  EXPECT_EQ(core.lastStats().tracked_objects, 2u);
  auto drawn = [&](const std::string& ns) {
    const visualization_msgs::MarkerArray m = core.markers();
    size_t n = 0;
    for (const auto& x : m.markers) n += x.ns == ns && x.action == visualization_msgs::Marker::ADD;
    return n;
  };
  EXPECT_GT(drawn("people/7"), 0u);
  // The gate: the robot's command is limited by the person.
  const vadop_ros::CommandCheck check =
      core.checkCommand(0, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::Zero(), ros::Time(100.0), tf, 2.0, 0.5);
  ASSERT_EQ(check.status, vadop_ros::CommandCheck::Status::kChecked);
  ASSERT_TRUE(check.limited);
  EXPECT_EQ(core.elementKey(check.other).body, "people/7");
  EXPECT_LT(check.scale.scale, 1.0);
  // The tracker stops reporting 7: after the timeout it leaves, 8 stays while reported.
  core.registry().onOdometry(0, odom(100.3, 0.3, 1.0), ros::Time(100.3));
  core.tracks().onArray(0, array(100.3, {object("8", 0.0, 20.0)}), ros::Time(100.3), tf);
  core.cycle(ros::Time(100.3), tf);
  EXPECT_EQ(core.lastStats().tracked_objects, 2u);  // 7 not yet expired (seen at 100.0)
  core.registry().onOdometry(0, odom(100.6, 0.6, 1.0), ros::Time(100.6));
  core.tracks().onArray(0, array(100.6, {object("8", 0.0, 20.0)}), ros::Time(100.6), tf);
  const vadop::ImpactArray& later = core.cycle(ros::Time(100.6), tf);
  EXPECT_TRUE(later.impacts.empty());
  EXPECT_EQ(core.lastStats().tracked_objects, 1u);
  EXPECT_EQ(core.lastStats().elements_in_world, 2u);
  EXPECT_EQ(core.tracks().status(0).objects_expired, 1u);
  EXPECT_EQ(drawn("people/7"), 0u);  // its markers went with it (each array starts with DELETEALL)
  EXPECT_GT(drawn("people/8"), 0u);
  // 7 comes back on the other side, walking in: predicted again, under its name.
  core.registry().onOdometry(0, odom(100.9, 0.9, 1.0), ros::Time(100.9));
  core.tracks().onArray(0, array(100.9, {object("8", 0.0, 20.0), object("7", 3.0, 0.0, -1.0)}), ros::Time(100.9), tf);
  const vadop::ImpactArray& again = core.cycle(ros::Time(100.9), tf);
  ASSERT_EQ(again.impacts.size(), 1u);
  EXPECT_EQ(again.impacts[0].body_b, "people/7");
  EXPECT_NEAR(again.impacts[0].time_to_impact, (3.0 - 0.9 - 0.6) / 2.0, 1e-4);
  // The robot stayed in the world all along: its insertion key is the first one.
  EXPECT_TRUE(core.predictorForTesting().contains(0));
}

TEST(TracksInTheMonitor, IgnorePairsAndGateIgnoreMatchTheObjectNames) {
  MonitorCore core = makeCore("ignore_pairs: [[\"robot\", \"people/*\"]]\n");
  FakeTf tf;
  core.registry().onOdometry(0, odom(100.0, 0.0, 1.0), ros::Time(100.0));
  core.tracks().onArray(0, array(100.0, {object("7", 4.0, 0.0, -1.0)}), ros::Time(100.0), tf);
  EXPECT_TRUE(core.cycle(ros::Time(100.0), tf).impacts.empty());
  // Without the rule, the same scene has the impact (the test above), so the glob matched.
  MonitorCore plain = makeCore();
  plain.registry().onOdometry(0, odom(100.0, 0.0, 1.0), ros::Time(100.0));
  plain.tracks().onArray(0, array(100.0, {object("7", 4.0, 0.0, -1.0)}), ros::Time(100.0), tf);
  EXPECT_EQ(plain.cycle(ros::Time(100.0), tf).impacts.size(), 1u);
  const vadop_ros::CommandCheck check = plain.checkCommand(
      0, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::Zero(), ros::Time(100.0), tf, 2.0, 0.5,
      [&](size_t e) { return vadop_ros::patternMatches("people/*", plain.elementKey(e)); });
  ASSERT_EQ(check.status, vadop_ros::CommandCheck::Status::kChecked);
  EXPECT_FALSE(check.limited);
  EXPECT_DOUBLE_EQ(check.scale.scale, 1.0);
}

TEST(Tracks, DiagnosticsCountObjectsAndDrops) {
  Tracks t({people()}, "odom", 5.0);
  FakeTf tf;
  vadop::TrackedObject bad = object("9", 0, 0);
  bad.pose.position.x = std::numeric_limits<double>::quiet_NaN();
  t.onArray(0, array(100.0, {object("1", 0, 0), object("2", 1, 0), bad}), ros::Time(100.0), tf);
  diagnostic_updater::DiagnosticStatusWrapper stat;
  t.report(stat, ros::Time(100.1));
  EXPECT_EQ(stat.message, "2 tracked objects from 1 source(s); bad input recently (see last problem)");
  EXPECT_EQ(stat.level, diagnostic_msgs::DiagnosticStatus::WARN);
  std::map<std::string, std::string> kv;
  for (const auto& v : stat.values) kv[v.key] = v.value;
  EXPECT_EQ(kv["people: objects"], "2");
  EXPECT_EQ(kv["people: objects dropped"], "1");
  EXPECT_EQ(kv["people: arrays accepted"], "1");
  EXPECT_NE(kv["people: last problem"].find("objects[2] (id \"9\")"), std::string::npos);
  diagnostic_updater::DiagnosticStatusWrapper later;
  t.report(later, ros::Time(200.0));  // long after the bad input
  EXPECT_EQ(later.level, diagnostic_msgs::DiagnosticStatus::OK);
}

TEST(TracksInTheMonitor, Parameters) {
  const auto p = vadop_ros::parseParams(vadop_test::yaml(R"(
tracks:
  - {topic: /perception/people}
  - {topic: /carts/tracks, prefix: carts, default_shape: {type: box, size: [1, 0.6, 1]}, timeout: 1.5}
)"));
  ASSERT_EQ(p.tracks.size(), 2u);
  EXPECT_EQ(p.tracks[0].prefix, "people");
  EXPECT_FALSE(p.tracks[0].has_default_shape);
  EXPECT_DOUBLE_EQ(p.tracks[0].timeout, 0.5);
  EXPECT_EQ(p.tracks[1].prefix, "carts");
  EXPECT_TRUE(p.tracks[1].has_default_shape);
  EXPECT_DOUBLE_EQ(p.tracks[1].timeout, 1.5);
  auto error = [](const std::string& text) {
    try {
      vadop_ros::parseParams(vadop_test::yaml(text));
    } catch (const vadop_ros::ParamError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("tracks: [{prefix: p}]"), "~tracks[0].topic: is required (a vadop/TrackedObjectArray topic)");
  EXPECT_EQ(error("tracks: [{topic: /a/x}, {topic: /b/x}]"),
            "~tracks[1].prefix: \"x\" is the prefix of another source (objects would share names)");
  EXPECT_EQ(error("tracks: [{topic: /a, timeout: 0}]"), "~tracks[0].timeout: must be in (0, 3600], got 0");
  EXPECT_EQ(error("tracks: [{topic: /a, colour: red}]"),
            "~tracks[0].colour: unknown key (expected one of: default_shape, prefix, timeout, topic)");
  EXPECT_EQ(error("tracks: [{topic: /a, default_shape: {type: cone}}]"),
            "~tracks[0].default_shape.type: must be sphere, box, cylinder or capsule, got \"cone\"");
}
