// ~parameters of vadop_monitor: defaults, the documented example config, templates, and
// malformed values -> ParamError naming the parameter.
#include "vadop_ros/params.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <string>
#include <vector>

using vadop_ros::MonitorParams;
using vadop_ros::ParamError;
using vadop_ros::parseParams;
using vadop_test::yaml;

namespace {

// The message of the ParamError thrown for `text` (fails the test when none is thrown).
std::string errorOf(const std::string& text) {
  try {
    parseParams(yaml(text));
  } catch (const ParamError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ParamError for:\n" << text;
  return "";
}

const char* kTwoBodies = R"(
bodies:
  - {name: a, odom_topic: /a/odom, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b/odom, shape: {type: sphere, radius: 0.5}}
)";

}  // namespace

TEST(Params, DefaultsWhenEmpty) {
  const MonitorParams p = parseParams(XmlRpc::XmlRpcValue());
  EXPECT_EQ(p.fixed_frame, "odom");
  EXPECT_DOUBLE_EQ(p.rate, 30.0);
  EXPECT_DOUBLE_EQ(p.horizon, 2.0);
  EXPECT_DOUBLE_EQ(p.padding, 0.0);
  EXPECT_DOUBLE_EQ(p.stale_timeout, 0.5);
  EXPECT_EQ(p.axes, 32);
  EXPECT_DOUBLE_EQ(p.phi_deg, 25.0);
  EXPECT_EQ(p.threads, 0);  // every core
  EXPECT_EQ(p.broad_phase, "grid");  // VADOP's volumes remove nothing after the cull (docs/performance.md)
  EXPECT_EQ(p.time_slices, 8);
  EXPECT_DOUBLE_EQ(p.coherence_clearance, 0.0);  // off
  EXPECT_DOUBLE_EQ(p.coherence_lookahead, 0.5);
  EXPECT_FALSE(p.self_collision);
  EXPECT_TRUE(p.bodies.empty());
  EXPECT_TRUE(p.static_obstacles.empty());
}

TEST(Params, ExampleConfigParses) {
  const MonitorParams p = parseParams(yaml(vadop_test::readFile(VADOP_CONFIG_DIR "/monitor.yaml")));
  ASSERT_EQ(p.bodies.size(), 5u);  // two robots and the agent template x 3, all named example_*
  EXPECT_EQ(p.bodies[0].name, "example_robot_1");
  EXPECT_EQ(p.bodies[0].source, vadop_ros::VelocitySource::kOdometry);
  EXPECT_EQ(p.bodies[0].shape.type, vadop::ShapeType::kCylinder);
  EXPECT_DOUBLE_EQ(p.bodies[0].shape.half_length, 0.25);
  EXPECT_EQ(p.bodies[0].max_linear_decel, 1.0);  // the gated robot brakes (issue 48)
  EXPECT_EQ(p.bodies[0].max_angular_decel, 2.0);
  EXPECT_EQ(p.bodies[0].gate.reaction_time, 0.1);
  EXPECT_TRUE(p.bodies[0].gate.others_may_stop);
  EXPECT_FALSE(p.bodies[1].hasBraking());  // stops at once in the others_may_stop future
  EXPECT_EQ(p.bodies[1].source, vadop_ros::VelocitySource::kTwist);
  EXPECT_EQ(p.bodies[1].frame, "example_robot_2/base_link");
  EXPECT_EQ(p.bodies[4].name, "example_agent_2");
  EXPECT_EQ(p.bodies[4].topic, "/example_agent_2/odom");
  EXPECT_EQ(p.bodies[4].tf_prefix, "example_agent_2");
  EXPECT_TRUE(p.bodies[4].links_from_tf);
  EXPECT_EQ(p.bodies[4].robot_description, "/example_agent_description");
  ASSERT_EQ(p.static_obstacles.size(), 2u);
  EXPECT_NEAR(p.static_obstacles[0].pose.translation().x(), 2.0, 1e-12);
  ASSERT_EQ(p.ignore_pairs.size(), 2u);
  EXPECT_EQ(p.ignore_pairs[1].first, "*/example_gripper*");
  ASSERT_EQ(p.tracks.size(), 1u);
  EXPECT_EQ(p.tracks[0].prefix, "example_people");
}

// The reference's examples cannot bite: every name it configures starts with "example_" (a
// user whose robots are named robot_1 and robot_2 does not inherit its ignore_pairs); the file
// monitor.launch loads by default is minimal and valid.
TEST(Params, ReferenceExamplesAreNamedSoNoRealRobotMatchesThem) {
  const MonitorParams p = parseParams(yaml(vadop_test::readFile(VADOP_CONFIG_DIR "/monitor.yaml")));
  const auto example = [](const std::string& name) { return name.rfind("example_", 0) == 0; };
  for (const auto& b : p.bodies) EXPECT_TRUE(example(b.name)) << b.name;
  for (const auto& o : p.static_obstacles) EXPECT_TRUE(example(o.name)) << o.name;
  for (const auto& t : p.tracks) EXPECT_TRUE(example(t.prefix)) << t.prefix;
  for (const auto& pair : p.ignore_pairs) {
    EXPECT_NE(pair.first.find("example_"), std::string::npos) << pair.first;
    EXPECT_NE(pair.second.find("example_"), std::string::npos) << pair.second;
  }
  const MonitorParams minimal = parseParams(yaml(vadop_test::readFile(VADOP_CONFIG_DIR "/minimal.yaml")));
  EXPECT_TRUE(minimal.bodies.empty());
  EXPECT_TRUE(minimal.static_obstacles.empty());
  EXPECT_TRUE(minimal.ignore_pairs.empty());
}

// ~region and ~region_margin: a box in the fixed frame, each min below its max; the margin
// with a region only.
TEST(Params, RegionIsABoxAndItsMarginNeedsIt) {
  const MonitorParams p = parseParams(yaml("region: {min: [-1, -2, -3], max: [1, 2, 3]}\nregion_margin: 4.5\n"));
  EXPECT_TRUE(p.region.bounded);
  EXPECT_EQ(p.region.min, Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(p.region.max, Eigen::Vector3d(1, 2, 3));
  EXPECT_DOUBLE_EQ(p.region_margin, 4.5);
  EXPECT_TRUE(p.region.contains({5.4, 0, 0}, 4.5));
  EXPECT_FALSE(p.region.contains({5.6, 0, 0}, 4.5));
  EXPECT_FALSE(parseParams(yaml("rate: 10")).region.bounded);
  EXPECT_TRUE(parseParams(yaml("rate: 10")).region.contains({1e6, 0, 0}, 0.0));
  EXPECT_EQ(errorOf("region_margin: 1"), "~region_margin: applies with ~region only");
  EXPECT_EQ(errorOf("region: {min: [0, 0, 0], max: [1, 0, 1]}"), "~region.max[1]: must be above min[1] (0), got 0");
  EXPECT_NE(errorOf("region: {min: [0, 0, 0]}").find("~region.max: is required"), std::string::npos);
  EXPECT_NE(errorOf("region: {min: [0, 0], max: [1, 1, 1]}").find("~region.min"), std::string::npos);
  EXPECT_NE(errorOf("region: {mn: [0, 0, 0], max: [1, 1, 1]}").find("did you mean \"min\"?"), std::string::npos);
  EXPECT_NE(errorOf("region: {min: [0, 0, 0], max: [1, 1, 1]}\nregion_margin: -1").find("~region_margin"),
            std::string::npos);
}

TEST(Params, ShapesAsInTheSceneFormat) {
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - {name: s, odom_topic: s, shape: {type: sphere, radius: 1}}
  - {name: b, odom_topic: b, shape: {type: box, size: [1, 2, 3]}}
  - {name: c, odom_topic: c, shape: {type: cylinder, radius: 0.5, length: 2}}
  - {name: k, odom_topic: k, shape: {type: capsule, radius: 0.5, length: 0}}
)"));
  ASSERT_EQ(p.bodies.size(), 4u);
  EXPECT_DOUBLE_EQ(p.bodies[0].shape.radius, 1.0);
  EXPECT_DOUBLE_EQ(p.bodies[1].shape.half_extents.z(), 1.5);
  EXPECT_DOUBLE_EQ(p.bodies[2].shape.half_length, 1.0);
  EXPECT_EQ(p.bodies[3].shape.type, vadop::ShapeType::kCapsule);
}

TEST(Params, TopLevelErrorsNameTheParameter) {
  EXPECT_NE(errorOf("rate: -1").find("~rate"), std::string::npos);
  EXPECT_NE(errorOf("rate: 0").find("~rate"), std::string::npos);
  EXPECT_NE(errorOf("horizon: abc").find("~horizon: must be a number"), std::string::npos);
  EXPECT_NE(errorOf("horizon: 100").find("~horizon"), std::string::npos);
  EXPECT_NE(errorOf("padding: -0.1").find("~padding"), std::string::npos);
  EXPECT_NE(errorOf("stale_timeout: 0").find("~stale_timeout"), std::string::npos);
  EXPECT_NE(errorOf("fixed_frame: 3").find("~fixed_frame: must be a string"), std::string::npos);
  EXPECT_NE(errorOf("fixed_frame: ''").find("~fixed_frame"), std::string::npos);
  EXPECT_NE(errorOf("self_collision: 1").find("~self_collision"), std::string::npos);
  EXPECT_NE(errorOf("axes: 2.5").find("~axes"), std::string::npos);
  EXPECT_NE(errorOf("axes: 1").find("~axes"), std::string::npos);
  EXPECT_NE(errorOf("phi_deg: 95").find("~phi_deg"), std::string::npos);
  EXPECT_NE(errorOf("bodies: {name: a}").find("~bodies: must be a list"), std::string::npos);
  EXPECT_NE(errorOf("ignore_pairs: [[a]]").find("~ignore_pairs[0]"), std::string::npos);
  EXPECT_NE(errorOf("ignore_pairs: [[a, 3]]").find("~ignore_pairs[0][1]"), std::string::npos);
  EXPECT_NE(errorOf("horizon: .nan").find("~horizon"), std::string::npos);
  EXPECT_EQ(errorOf("threads: -1"), "~threads: must be an integer in [0, 256] (0: one per hardware thread), got -1");
  EXPECT_NE(errorOf("threads: 1.5").find("~threads: must be an integer"), std::string::npos);
  EXPECT_EQ(parseParams(yaml("threads: 2")).threads, 2);
  EXPECT_EQ(parseParams(yaml("{}")).ingest_threads, 0);  // on the receiving thread
  EXPECT_EQ(errorOf("ingest_threads: 17"),
            "~ingest_threads: must be an integer in [0, 16] (0: on the receiving thread), got 17");
  EXPECT_EQ(errorOf("ingest_threads: -1"),
            "~ingest_threads: must be an integer in [0, 16] (0: on the receiving thread), got -1");
  EXPECT_EQ(parseParams(yaml("ingest_threads: 2")).ingest_threads, 2);
  EXPECT_FALSE(parseParams(yaml("{}")).ingest_udp);
  EXPECT_TRUE(parseParams(yaml("ingest_udp: true")).ingest_udp);
  EXPECT_NE(errorOf("ingest_udp: 1.5").find("~ingest_udp"), std::string::npos);
  EXPECT_EQ(errorOf("time_slices: 0"), "~time_slices: must be an integer in [1, 64] (1: no cull), got 0");
  EXPECT_EQ(errorOf("time_slices: 65"), "~time_slices: must be an integer in [1, 64] (1: no cull), got 65");
  EXPECT_NE(errorOf("time_slices: 2.5").find("~time_slices: must be an integer"), std::string::npos);
  EXPECT_EQ(parseParams(yaml("time_slices: 1")).time_slices, 1);
  EXPECT_EQ(errorOf("broad_phase: octree"),
            "~broad_phase: unknown broad phase \"octree\" (expected vadop, vadop_sap, sap, grid or brute)");
  EXPECT_EQ(parseParams(yaml("broad_phase: grid")).broad_phase, "grid");
  EXPECT_EQ(errorOf("coherence_clearance: -0.1"), "~coherence_clearance: must be in [0, 10], got -0.1");
  EXPECT_EQ(errorOf("coherence_clearance: 0.0001"),
            "~coherence_clearance: must be 0 (off) or in [0.001, 10] m, got 0.0001");
  EXPECT_NE(errorOf("coherence_clearance: .nan").find("~coherence_clearance: must be a finite number"), std::string::npos);
  EXPECT_EQ(errorOf("coherence_lookahead: 11"), "~coherence_lookahead: must be in [0, 10], got 11");
  const MonitorParams coherent = parseParams(yaml("coherence_clearance: 0.3\ncoherence_lookahead: 1.5"));
  EXPECT_DOUBLE_EQ(coherent.coherence_clearance, 0.3);
  EXPECT_DOUBLE_EQ(coherent.coherence_lookahead, 1.5);
  EXPECT_DOUBLE_EQ(parseParams(yaml("coherence_clearance: 0")).coherence_clearance, 0.0);
}

TEST(Params, BodyErrorsNameTheBodyAndField) {
  EXPECT_EQ(errorOf(R"(
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: -1}}
)"),
            "~bodies[1] (\"b\").shape.radius: must be a number > 0, got -1");
  EXPECT_NE(errorOf("bodies: [{name: a, shape: {type: sphere, radius: 1}}]").find("~bodies[0] (\"a\").odom_topic: is required"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, twist_topic: y, frame: f, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\"): give one velocity source"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, twist_topic: y, shape: {type: sphere, radius: 1}}]").find("~bodies[0] (\"a\").frame"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x}]").find("~bodies[0] (\"a\").shape: is required"), std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, robot_description: d, shape: {type: sphere, radius: 1}}]")
                .find("give one geometry source"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, odom_topc: y, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").odom_topc: unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{odom_topic: x, shape: {type: sphere, radius: 1}}]").find("~bodies[0].name: is required"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a/b, odom_topic: x, shape: {type: sphere, radius: 1}}]").find("must not contain '/'"),
            std::string::npos);
  EXPECT_NE(errorOf(R"(
bodies:
  - {name: a, odom_topic: x, shape: {type: sphere, radius: 1}}
  - {name: a, odom_topic: y, shape: {type: sphere, radius: 1}}
)").find("~bodies[1] (\"a\").name: duplicate body name"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, shape: {type: box, size: [1, 2]}}]").find(".shape.size: must be a list of 3"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, shape: {type: box, size: [1, 0, 2]}}]").find(".shape.size[1]"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, shape: {type: cone, radius: 1}}]").find(".shape.type: must be sphere"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, shape: {type: cylinder, radius: 1}}]").find(".shape.length: is required"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, shape: {type: sphere, radius: 1, lenght: 2}}]").find(".shape.lenght: unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: x, tf_prefix: p, shape: {type: sphere, radius: 1}}]").find(".tf_prefix"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, count: 2, odom_topic: x, shape: {type: sphere, radius: 1}}]").find(".name: must contain {i}"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 0, odom_topic: x, shape: {type: sphere, radius: 1}}]").find(".count"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [3]").find("~bodies[0]: must be a dictionary"), std::string::npos);
}

TEST(Params, ObstacleErrorsNameTheObstacle) {
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: box, size: [1, 1, 1]}, pose: {orientation: [0, 0, 0, 0]}}]")
                .find("~static_obstacles[0] (\"w\").pose.orientation: must not be a zero quaternion"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0, 0]}}]")
                .find("~static_obstacles[0] (\"w\").pose.position"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kTwoBodies) + "static_obstacles: [{name: a, shape: {type: sphere, radius: 1}}]")
                .find("duplicate body name"),
            std::string::npos);
}

TEST(Params, TemplateExpandsEveryField) {
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - name: "agent_{i}"
    count: 3
    odom_topic: "/agent_{i}/odom"
    robot_description: "/agent_{i}_description"
    tf_prefix: "agent_{i}/"
)"));
  ASSERT_EQ(p.bodies.size(), 3u);
  EXPECT_EQ(p.bodies[2].name, "agent_2");
  EXPECT_EQ(p.bodies[2].topic, "/agent_2/odom");
  EXPECT_EQ(p.bodies[2].robot_description, "/agent_2_description");
  EXPECT_EQ(p.bodies[2].tf_prefix, "agent_2");  // trailing '/' dropped
}

// An unknown key at any level stops the node naming it and, when it looks like a typo of a
// valid key, that key; a word that is no typo gets the list alone.
TEST(Params, UnknownKeysAtAnyLevelNameTheNearestValidKey) {
  EXPECT_EQ(errorOf("rate: 10\npading: 0.1\n").rfind("~pading: unknown key; did you mean \"padding\"? (expected one of: ", 0),
            0u)
      << errorOf("pading: 0.1");
  EXPECT_NE(errorOf("horizn: 3").find("did you mean \"horizon\"?"), std::string::npos);
  EXPECT_NE(errorOf("publish_makers: true").find("did you mean \"publish_markers\"?"), std::string::npos);
  const std::string far = errorOf("colour: red");
  EXPECT_EQ(far.rfind("~colour: unknown key (expected one of: ", 0), 0u) << far;
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
  // Inside a body and a shape.
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: 1}, paddin: 1}]")
                .find("~bodies[0] (\"a\").paddin: unknown key"),
            std::string::npos);
  const std::string shape = errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radus: 1}}]");
  EXPECT_NE(shape.find("did you mean \"radius\"?"), std::string::npos) << shape;
  const std::string odom = errorOf("bodies: [{name: a, odom_topc: /a, shape: {type: sphere, radius: 1}}]");
  EXPECT_NE(odom.find("did you mean \"odom_topic\"?"), std::string::npos) << odom;
  // Transposed neighbours are one edit; a key of 3 characters or fewer allows one edit.
  EXPECT_NE(errorOf("raet: 10").find("did you mean \"rate\"?"), std::string::npos);
  const std::string gat = errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: 1}, gat: {}}]");
  EXPECT_NE(gat.find("did you mean \"gate\"?"), std::string::npos) << gat;
  EXPECT_EQ(errorOf("xyz: 1").find("did you mean"), std::string::npos);
}

// Issue 13, item 2: the start-up range of ~rate is cfg/Monitor.cfg's, [0.1, 1000] Hz (1e-10
// passed (0, 1000] and aborted the node in ros::Duration(1 / rate); 1e-9 never cycled).
TEST(Params, RateRangeIsTheReconfigureRange) {
  EXPECT_EQ(errorOf("rate: 1e-10"), "~rate: must be in [0.1, 1000], got 1e-10");
  EXPECT_NE(errorOf("rate: 1.0e-9").find("~rate: must be in [0.1, 1000]"), std::string::npos);
  EXPECT_NE(errorOf("rate: 0.09").find("~rate"), std::string::npos);
  EXPECT_NE(errorOf("rate: 1000.5").find("~rate"), std::string::npos);
  EXPECT_DOUBLE_EQ(parseParams(yaml("rate: 0.1")).rate, 0.1);
  EXPECT_DOUBLE_EQ(parseParams(yaml("rate: 1000")).rate, 1000.0);
  EXPECT_DOUBLE_EQ(vadop_ros::kMinRate, 0.1);
  EXPECT_DOUBLE_EQ(vadop_ros::kMaxRate, 1000.0);
}

// Issue 13, item 2: every topic, parameter and frame name is checked when parsed, with an error
// naming the parameter (a bad topic name used to abort the node in NodeHandle::subscribe).
TEST(Params, TopicAndParameterNamesFollowTheRosRules) {
  EXPECT_EQ(errorOf(R"(
bodies:
  - {name: a, odom_topic: /a/odom, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: "/a b/odom!", shape: {type: sphere, radius: 0.5}}
)"),
            "~bodies[1] (\"b\").odom_topic: must be a valid ROS topic name (a letter or '/' first, then letters, "
            "digits, '_' and '/'), got \"/a b/odom!\"");
  EXPECT_NE(errorOf("bodies: [{name: a, twist_topic: 1vel, frame: f, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").twist_topic: must be a valid ROS topic name"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a-b, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").odom_topic"),
            std::string::npos);
  // '~' names: the node's NodeHandle throws on them.
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: ~odom, shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").odom_topic: must not be a private (~) topic name"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, robot_description: 'my description'}]")
                .find("~bodies[0] (\"a\").robot_description: must be a valid ROS parameter name"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, robot_description: ~robot_description}]")
                .find("~bodies[0] (\"a\").robot_description: must not be a private (~) parameter name"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, robot_description: 'env?'}]")
                .find("~static_obstacles[0] (\"w\").robot_description: must be a valid ROS parameter name"),
            std::string::npos);
  // Templates: each copy after substitution.
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 2, odom_topic: '/a {i}', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a{i}\").odom_topic (copy 0): must be a valid ROS topic name"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 2, odom_topic: '{i}/odom', shape: {type: sphere, radius: 1}}]")
                .find(".odom_topic (copy 0)"),
            std::string::npos);
  // Valid names pass: absolute, relative, with digits and underscores.
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - {name: a, odom_topic: /robot_1/odom, shape: {type: sphere, radius: 1}}
  - {name: b, odom_topic: robot2/odom_filtered, robot_description: /fleet/robot_description}
)"));
  EXPECT_EQ(p.bodies[1].topic, "robot2/odom_filtered");
}

TEST(Params, FramesFollowTheTf2Rules) {
  EXPECT_NE(errorOf("fixed_frame: 'od om'").find("~fixed_frame: must be a valid tf frame id"), std::string::npos);
  EXPECT_NE(errorOf("fixed_frame: 'map!'").find("~fixed_frame: must be a valid tf frame id"), std::string::npos);
  EXPECT_NE(errorOf("fixed_frame: 'a//b'").find("~fixed_frame: must be a valid tf frame id (no empty segment"),
            std::string::npos);
  EXPECT_NE(errorOf("fixed_frame: '/'").find("~fixed_frame: must not be empty"), std::string::npos);
  EXPECT_EQ(parseParams(yaml("fixed_frame: /map")).fixed_frame, "map");  // tf1 style accepted
  EXPECT_EQ(parseParams(yaml("fixed_frame: world-2.north")).fixed_frame, "world-2.north");
  EXPECT_NE(errorOf("bodies: [{name: a, twist_topic: /v, frame: 'base link', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").frame: must be a valid tf frame id"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, frame: 'a/', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a\").frame"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, robot_description: d, tf_prefix: 'a b'}]")
                .find("~bodies[0] (\"a\").tf_prefix: must be a valid tf frame id"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 3, odom_topic: '/a{i}', robot_description: d, tf_prefix: 'a {i}'}]")
                .find("~bodies[0] (\"a{i}\").tf_prefix (copy 0)"),
            std::string::npos);
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - {name: a, twist_topic: /v, frame: /robot/base_link, shape: {type: sphere, radius: 1}}
  - {name: b, odom_topic: /b, robot_description: d, tf_prefix: ''}
  - {name: c, odom_topic: /c, robot_description: d, tf_prefix: /c/}
)"));
  EXPECT_EQ(p.bodies[0].frame, "robot/base_link");  // leading '/' removed, as tf2 wants
  EXPECT_EQ(p.bodies[1].tf_prefix, "");
  EXPECT_TRUE(p.bodies[1].links_from_tf);
  EXPECT_EQ(p.bodies[2].tf_prefix, "c");
}

// Issue 13, item 6: one numerical range (vadop/error.h) and no NaN/Inf anywhere.
TEST(Params, StaticPosesWithinMaxCoordinate) {
  EXPECT_EQ(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {position: [1e200, 0, 0]}}]"),
            "~static_obstacles[0] (\"w\").pose.position[0]: must be within 1e+07 m (vadop/error.h), got 1e+200");
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {position: [0, 0, -1.1e7]}}]")
                .find("~static_obstacles[0] (\"w\").pose.position[2]: must be within 1e+07 m"),
            std::string::npos);
  // UTM-sized coordinates are fine.
  const MonitorParams p = parseParams(
      yaml("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {position: [1e7, -5.3e6, 0]}}]"));
  EXPECT_DOUBLE_EQ(p.static_obstacles[0].pose.translation().x(), 1e7);
  // A quaternion whose norm overflows.
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {orientation: [1e300, 0, 0, 1e300]}}]")
                .find("~static_obstacles[0] (\"w\").pose.orientation: must have a finite norm"),
            std::string::npos);
}

TEST(Params, ShapeDimensionsWithinMaxSize) {
  const std::string body = "bodies: [{name: a, odom_topic: /a, shape: ";
  EXPECT_EQ(errorOf(body + "{type: sphere, radius: 1e6}}]"),
            "~bodies[0] (\"a\").shape.radius: must be within 100000 m (vadop/error.h), got 1e+06");
  EXPECT_NE(errorOf(body + "{type: box, size: [1, 1, 2e5]}}]").find("~bodies[0] (\"a\").shape.size[2]: must be within 100000 m"),
            std::string::npos);
  EXPECT_NE(errorOf(body + "{type: cylinder, radius: 1, length: 1e300}}]").find("~bodies[0] (\"a\").shape.length: must be within"),
            std::string::npos);
  EXPECT_NE(errorOf(body + "{type: capsule, radius: 2e5, length: 0}}]").find(".shape.radius: must be within"),
            std::string::npos);
  EXPECT_NE(errorOf(body + "{type: capsule, radius: 1, length: -1}}]").find(".shape.length: must be a number >= 0, got -1"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: box, size: [1e6, 1, 1]}}]")
                .find("~static_obstacles[0] (\"w\").shape.size[0]: must be within 100000 m"),
            std::string::npos);
  EXPECT_NO_THROW(parseParams(yaml(body + "{type: box, size: [1e5, 1e5, 1e5]}}]")));
  EXPECT_NE(errorOf("padding: 10.5").find("~padding: must be in [0, 10]"), std::string::npos);
}

TEST(Params, NanAndInfAreRefusedEverywhere) {
  // .nan as YAML (the test's reader turns it into a double NaN, as rosparam does).
  EXPECT_NE(errorOf("rate: .nan").find("~rate: must be a finite number"), std::string::npos);
  EXPECT_NE(errorOf("padding: .nan").find("~padding: must be a finite number"), std::string::npos);
  EXPECT_NE(errorOf("stale_timeout: .nan").find("~stale_timeout"), std::string::npos);
  EXPECT_NE(errorOf("max_stamp_skew: .nan").find("~max_stamp_skew"), std::string::npos);
  EXPECT_NE(errorOf("phi_deg: .nan").find("~phi_deg"), std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: .nan}}]")
                .find("~bodies[0] (\"a\").shape.radius: must be a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {position: [0, .nan, 0]}}]")
                .find("~static_obstacles[0] (\"w\").pose.position[1]: must be a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {rpy: [0, 0, .nan]}}]")
                .find(".pose.rpy[2]: must be a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {orientation: [0, 0, 0, .nan]}}]")
                .find(".pose.orientation[3]: must be a finite number"),
            std::string::npos);
  // .inf: rosparam gives a double infinity (set here directly: the test's YAML reader keeps
  // ".inf" a string).
  auto withInf = [](const std::string& text, const std::function<void(XmlRpc::XmlRpcValue&)>& put) {
    XmlRpc::XmlRpcValue root = yaml(text);
    put(root);
    try {
      parseParams(root);
    } catch (const ParamError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NE(withInf("rate: 1", [&](XmlRpc::XmlRpcValue& r) { r["rate"] = inf; }).find("~rate: must be a finite number, got inf"),
            std::string::npos);
  EXPECT_NE(withInf("horizon: 1", [&](XmlRpc::XmlRpcValue& r) { r["horizon"] = -inf; }).find("~horizon: must be a finite number"),
            std::string::npos);
  EXPECT_NE(withInf("static_obstacles: [{name: w, shape: {type: sphere, radius: 1}, pose: {position: [0, 0, 0]}}]",
                    [&](XmlRpc::XmlRpcValue& r) { r["static_obstacles"][0]["pose"]["position"][0] = inf; })
                .find("~static_obstacles[0] (\"w\").pose.position[0]: must be a finite number"),
            std::string::npos);
  EXPECT_NE(withInf("bodies: [{name: a, odom_topic: /a, shape: {type: box, size: [1, 1, 1]}}]",
                    [&](XmlRpc::XmlRpcValue& r) { r["bodies"][0]["shape"]["size"][1] = inf; })
                .find("~bodies[0] (\"a\").shape.size[1]: must be a finite number"),
            std::string::npos);
}

// Issue 13, item 8: the body limit is what ROS starts within about a minute (see kMaxBodies).
TEST(Params, MovingBodiesAtMostKMaxBodies) {
  EXPECT_EQ(vadop_ros::kMaxBodies, 20000);
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 20001, odom_topic: '/a{i}', shape: {type: sphere, radius: 1}}]")
                .find("~bodies[0] (\"a{i}\").count: must be in [1, 20000], got 20001"),
            std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: 'a{i}', count: 1000000, odom_topic: '/a{i}', shape: {type: sphere, radius: 1}}]")
                .find(".count: must be in [1, 20000]"),
            std::string::npos);
  // In all: two templates together, or a single body after a full template.
  EXPECT_NE(errorOf(R"(
bodies:
  - {name: 'a{i}', count: 15000, odom_topic: '/a{i}', shape: {type: sphere, radius: 1}}
  - {name: 'b{i}', count: 5001, odom_topic: '/b{i}', shape: {type: sphere, radius: 1}}
)").find("~bodies[1] (\"b{i}\").count: makes 20001 moving bodies, more than the limit of 20000"),
            std::string::npos);
  EXPECT_NE(errorOf(R"(
bodies:
  - {name: 'a{i}', count: 20000, odom_topic: '/a{i}', shape: {type: sphere, radius: 1}}
  - {name: c, odom_topic: /c, shape: {type: sphere, radius: 1}}
)").find("~bodies[1] (\"c\"): makes 20001 moving bodies"),
            std::string::npos);
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - {name: 'a{i}', count: 19999, odom_topic: '/a{i}', shape: {type: sphere, radius: 1}}
  - {name: c, odom_topic: /c, shape: {type: sphere, radius: 1}}
)"));
  EXPECT_EQ(p.bodies.size(), 20000u);
}

TEST(Params, GatesParseWithDefaultsAndTemplates) {
  const MonitorParams p = parseParams(yaml(R"(
stale_timeout: 0.8
bodies:
  - {name: a, odom_topic: /a/odom, shape: {type: sphere, radius: 0.5},
     gate: {cmd_vel_in: /a/cmd_vel_in, cmd_vel_out: /a/cmd_vel}}
  - name: "r_{i}"
    count: 2
    odom_topic: "/r_{i}/odom"
    shape: {type: sphere, radius: 0.5}
    gate: {cmd_vel_in: "/r_{i}/nav_vel", cmd_vel_out: "/r_{i}/cmd_vel", time_before_collision: 2.5,
           cmd_timeout: 0.2, state_timeout: 0.3, ignore: ["r_{i}_dock", "cart/*"]}
  - {name: c, odom_topic: /c/odom, shape: {type: sphere, radius: 0.5}}
)"));
  ASSERT_EQ(p.bodies.size(), 4u);
  ASSERT_TRUE(p.bodies[0].has_gate);
  EXPECT_EQ(p.bodies[0].gate.cmd_vel_in, "/a/cmd_vel_in");
  EXPECT_EQ(p.bodies[0].gate.time_before_collision, 1.0);
  EXPECT_EQ(p.bodies[0].gate.cmd_timeout, 0.5);
  EXPECT_EQ(p.bodies[0].gate.state_timeout, 0.8);  // the node's stale_timeout
  EXPECT_TRUE(p.bodies[0].gate.ignore.empty());
  ASSERT_TRUE(p.bodies[2].has_gate);
  EXPECT_EQ(p.bodies[2].gate.cmd_vel_in, "/r_1/nav_vel");
  EXPECT_EQ(p.bodies[2].gate.cmd_vel_out, "/r_1/cmd_vel");
  EXPECT_EQ(p.bodies[2].gate.time_before_collision, 2.5);
  EXPECT_EQ(p.bodies[2].gate.cmd_timeout, 0.2);
  EXPECT_EQ(p.bodies[2].gate.state_timeout, 0.3);
  ASSERT_EQ(p.bodies[2].gate.ignore.size(), 2u);
  EXPECT_EQ(p.bodies[2].gate.ignore[0], "r_1_dock");
  EXPECT_FALSE(p.bodies[3].has_gate);
}

TEST(Params, GateErrorsNameTheField) {
  auto gate = [](const std::string& fields) {
    return errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: 1}, gate: {" + fields + "}}]");
  };
  const std::string p = "~bodies[0] (\"a\").gate";
  EXPECT_NE(gate("cmd_vel_out: /o").find(p + ".cmd_vel_in: is required"), std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i").find(p + ".cmd_vel_out: is required"), std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /i").find(p + ".cmd_vel_out: must differ"), std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: '/i j', cmd_vel_out: /o").find(p + ".cmd_vel_in: must be a valid ROS topic"),
            std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, time_before_collision: 0").find(p + ".time_before_collision"),
            std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, time_before_collision: .nan").find(p + ".time_before_collision"),
            std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, cmd_timeout: -1").find(p + ".cmd_timeout"), std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, state_timeout: .inf").find(p + ".state_timeout"), std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, ignore: [1]").find(p + ".ignore[0]: must be a string"),
            std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, ignore: ['']").find(p + ".ignore[0]: must not be empty"),
            std::string::npos);
  EXPECT_NE(gate("cmd_vel_in: /i, cmd_vel_out: /o, timeout: 1").find(p + ".timeout: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: 1}, gate: 3}]")
                .find(p + ": must be a dictionary"),
            std::string::npos);
}

// Issue 48: the braking model of a body (max_linear_decel, max_angular_decel) and the gate's
// reaction_time and others_may_stop.
namespace {

std::string bodyWith(const std::string& keys) {
  return "bodies: [{name: a, odom_topic: /a, shape: {type: sphere, radius: 1}" + (keys.empty() ? "" : ", " + keys) + "}]";
}

std::string gateWith(const std::string& keys) {
  return bodyWith("gate: {cmd_vel_in: /i, cmd_vel_out: /o" + (keys.empty() ? "" : ", " + keys) + "}");
}

}  // namespace

TEST(Params, BrakingAndReactionDefaults) {
  const MonitorParams p = parseParams(yaml(gateWith("")));
  ASSERT_EQ(p.bodies.size(), 1u);
  EXPECT_EQ(p.bodies[0].max_linear_decel, 0.0);
  EXPECT_EQ(p.bodies[0].max_angular_decel, 0.0);
  EXPECT_FALSE(p.bodies[0].hasBraking());
  EXPECT_EQ(p.bodies[0].gate.reaction_time, 0.1);
  EXPECT_TRUE(p.bodies[0].gate.others_may_stop);
}

TEST(Params, BrakingAndReactionAcceptedValues) {
  MonitorParams p = parseParams(yaml(bodyWith("max_linear_decel: 1.5, max_angular_decel: 2")));  // an integer too
  EXPECT_EQ(p.bodies[0].max_linear_decel, 1.5);
  EXPECT_EQ(p.bodies[0].max_angular_decel, 2.0);
  EXPECT_TRUE(p.bodies[0].hasBraking());
  EXPECT_FALSE(p.bodies[0].has_gate);  // a body without a gate may brake too (the others_may_stop future)
  p = parseParams(yaml(bodyWith("max_linear_decel: 100, max_angular_decel: 1000")));  // the upper bounds
  EXPECT_EQ(p.bodies[0].max_linear_decel, 100.0);
  EXPECT_EQ(p.bodies[0].max_angular_decel, 1000.0);
  p = parseParams(yaml(bodyWith("max_linear_decel: 1e-3, max_angular_decel: 1e-3")));
  EXPECT_EQ(p.bodies[0].max_linear_decel, 1e-3);
  EXPECT_EQ(p.bodies[0].max_angular_decel, 1e-3);
  EXPECT_TRUE(p.bodies[0].hasBraking());  // any deceleration > 0 is a braking model, however gentle
  p = parseParams(yaml(gateWith("reaction_time: 0, others_may_stop: false")));
  EXPECT_EQ(p.bodies[0].gate.reaction_time, 0.0);  // a closed interval: 0 is a base that reacts at once
  EXPECT_FALSE(p.bodies[0].gate.others_may_stop);
  p = parseParams(yaml(gateWith("reaction_time: 2, others_may_stop: true")));
  EXPECT_EQ(p.bodies[0].gate.reaction_time, 2.0);
  EXPECT_TRUE(p.bodies[0].gate.others_may_stop);
  p = parseParams(yaml(gateWith("reaction_time: 0.06")));
  EXPECT_EQ(p.bodies[0].gate.reaction_time, 0.06);
}

TEST(Params, DecelerationErrorsNameTheKey) {
  const std::string lin = "~bodies[0] (\"a\").max_linear_decel: ";
  const std::string ang = "~bodies[0] (\"a\").max_angular_decel: ";
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 0, max_angular_decel: 1")), lin + "must be in (0, 100], got 0");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: -1, max_angular_decel: 1")), lin + "must be in (0, 100], got -1");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 100.5, max_angular_decel: 1")), lin + "must be in (0, 100], got 100.5");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: .nan, max_angular_decel: 1")), lin + "must be a finite number, got nan");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: fast, max_angular_decel: 1")), lin + "must be a number, got a string");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1, max_angular_decel: 0")), ang + "must be in (0, 1000], got 0");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1, max_angular_decel: -2")), ang + "must be in (0, 1000], got -2");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1, max_angular_decel: 1000.5")),
            ang + "must be in (0, 1000], got 1000.5");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1, max_angular_decel: .nan")), ang + "must be a finite number, got nan");
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1, max_angular_decel: [2]")), ang + "must be a number, got a list");
  // +-Inf as rosparam gives it (the test's YAML reader keeps ".inf" a string).
  XmlRpc::XmlRpcValue root = yaml(bodyWith("max_linear_decel: 1, max_angular_decel: 1"));
  root["bodies"][0]["max_linear_decel"] = std::numeric_limits<double>::infinity();
  try {
    parseParams(root);
    ADD_FAILURE() << "an infinite max_linear_decel was accepted";
  } catch (const ParamError& e) {
    EXPECT_EQ(std::string(e.what()), lin + "must be a finite number, got inf");
  }
}

TEST(Params, DecelerationsBothOrNeither) {
  EXPECT_EQ(errorOf(bodyWith("max_linear_decel: 1")),
            "~bodies[0] (\"a\").max_angular_decel: is required with max_linear_decel (give both decelerations or "
            "neither)");
  EXPECT_EQ(errorOf(bodyWith("max_angular_decel: 2")),
            "~bodies[0] (\"a\").max_linear_decel: is required with max_angular_decel (give both decelerations or "
            "neither)");
  // The body named in a list, and a template's entry by its own name.
  EXPECT_NE(errorOf(std::string(kTwoBodies) +
                    "  - {name: 'c{i}', count: 2, odom_topic: '/c{i}', shape: {type: sphere, radius: 1}, "
                    "max_linear_decel: 1}\n")
                .find("~bodies[2] (\"c{i}\").max_angular_decel: is required"),
            std::string::npos);
}

TEST(Params, ReactionTimeAndOthersMayStopErrorsNameTheKey) {
  const std::string p = "~bodies[0] (\"a\").gate.";
  EXPECT_EQ(errorOf(gateWith("reaction_time: -0.01")), p + "reaction_time: must be in [0, 2], got -0.01");
  EXPECT_EQ(errorOf(gateWith("reaction_time: 2.01")), p + "reaction_time: must be in [0, 2], got 2.01");
  EXPECT_EQ(errorOf(gateWith("reaction_time: .nan")), p + "reaction_time: must be a finite number, got nan");
  EXPECT_EQ(errorOf(gateWith("reaction_time: soon")), p + "reaction_time: must be a number, got a string");
  EXPECT_EQ(errorOf(gateWith("others_may_stop: 1")), p + "others_may_stop: must be true or false, got an integer");
  EXPECT_EQ(errorOf(gateWith("others_may_stop: maybe")), p + "others_may_stop: must be true or false, got a string");
  // Body keys, not gate keys (and the other way round): a misplaced key is named, not ignored.
  EXPECT_NE(errorOf(gateWith("max_linear_decel: 1")).find(p + "max_linear_decel: unknown key"), std::string::npos);
  EXPECT_NE(errorOf(bodyWith("reaction_time: 0.1")).find("~bodies[0] (\"a\").reaction_time: unknown key"),
            std::string::npos);
}

TEST(Params, TemplatesCarryBrakingAndReaction) {
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - name: "r_{i}"
    count: 3
    odom_topic: "/r_{i}/odom"
    shape: {type: sphere, radius: 0.3}
    max_linear_decel: 1.0
    max_angular_decel: 2.0
    gate: {cmd_vel_in: "/r_{i}/nav_vel", cmd_vel_out: "/r_{i}/cmd_vel", reaction_time: 0.25, others_may_stop: false}
  - {name: "w_{i}", count: 2, odom_topic: "/w_{i}/odom", shape: {type: sphere, radius: 0.3}}
)"));
  ASSERT_EQ(p.bodies.size(), 5u);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(p.bodies[k].name);
    EXPECT_EQ(p.bodies[k].max_linear_decel, 1.0);
    EXPECT_EQ(p.bodies[k].max_angular_decel, 2.0);
    EXPECT_TRUE(p.bodies[k].hasBraking());
    EXPECT_EQ(p.bodies[k].gate.reaction_time, 0.25);
    EXPECT_FALSE(p.bodies[k].gate.others_may_stop);
  }
  for (int k = 3; k < 5; ++k) EXPECT_FALSE(p.bodies[k].hasBraking());
}

TEST(Params, GatedBodyWithoutBrakingIsWarnedAbout) {
  const MonitorParams p = parseParams(yaml(R"(
bodies:
  - {name: held, odom_topic: /a, shape: {type: sphere, radius: 1}, gate: {cmd_vel_in: /a/i, cmd_vel_out: /a/o}}
  - {name: braked, odom_topic: /b, shape: {type: sphere, radius: 1}, max_linear_decel: 1, max_angular_decel: 2,
     gate: {cmd_vel_in: /b/i, cmd_vel_out: /b/o}}
  - {name: walker, odom_topic: /c, shape: {type: sphere, radius: 1}}
  - {name: "g_{i}", count: 2, odom_topic: "/g{i}", shape: {type: sphere, radius: 1},
     gate: {cmd_vel_in: "/g{i}/i", cmd_vel_out: "/g{i}/o"}}
)"));
  const std::vector<std::string> warnings = vadop_ros::paramWarnings(p);
  ASSERT_EQ(warnings.size(), 3u);  // held, g_0, g_1: not the braked gate, not the ungated walker
  EXPECT_EQ(warnings[0],
            "gate of \"held\": no braking model (max_linear_decel / max_angular_decel not given): commands are "
            "checked as held over time_before_collision, starting after reaction_time");
  EXPECT_EQ(warnings[1].rfind("gate of \"g_0\": no braking model", 0), 0u);
  EXPECT_EQ(warnings[2].rfind("gate of \"g_1\": no braking model", 0), 0u);
  EXPECT_TRUE(vadop_ros::paramWarnings(parseParams(yaml(kTwoBodies))).empty());
}
