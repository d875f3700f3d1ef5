// MonitorCore: the cycle from registry to published impacts, without ROS transport.
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/monitor_diagnostics.h"
#include "fake_tf.h"
#include "planar_arm.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>
#include <vadop/error.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <utility>

using vadop_ros::MonitorCore;
using vadop_ros::MonitorParams;
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

// A parameter server whose every robot_description is `urdf`.
vadop_ros::ParamReader urdfParams(const std::string& urdf) {
  return [urdf](const std::string&, std::string& v) {
    v = urdf;
    return true;
  };
}

// The odometry of a URDF body's base_link: at (x, 0), moving along x at vx.
nav_msgs::Odometry baseOdom(double stamp, double x, double vx) {
  nav_msgs::Odometry o = odom(stamp, x, 0.0, vx);
  o.child_frame_id = "base_link";
  return o;
}

// The planar arm's joints (planar_arm.h) at t = 100 s: shoulder at -0.5 rad turning at 0.3 rad/s,
// elbow at 0.4 rad at -0.2 rad/s.
sensor_msgs::JointState planarArmJoints() {
  sensor_msgs::JointState js;
  js.header.stamp = ros::Time(100.0);
  js.name = {"shoulder", "elbow"};
  js.position = {-0.5, 0.4};
  js.velocity = {0.3, -0.2};
  return js;
}

// The first t in [0, 3] with |centre(t) - post| <= 0.2 (the sphere's and the post's radii), by
// steps of 1e-4 s and bisection: the truth of the arm tests; -1 when there is none.
double firstContact(const std::function<Eigen::Vector3d(double)>& centre, const Eigen::Vector3d& post) {
  double lo = 0.0, hi = -1.0;
  for (double t = 0.0; t <= 3.0; t += 1e-4) {
    if ((centre(t) - post).norm() <= 0.2) {
      hi = t;
      break;
    }
    lo = t;
  }
  for (int k = 0; hi > 0.0 && k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    ((centre(mid) - post).norm() <= 0.2 ? hi : lo) = mid;
  }
  return hi;
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
  // Issue 14, item 5: a-b and w1-w2 are filtered before the narrow phase, so never raw impacts.
  EXPECT_EQ(core.lastStats().raw_impacts, out.impacts.size());
  EXPECT_EQ(core.lastStats().ignored_tested, 0u);
}

// Issue 14, item 5: ignored pairs never produce narrow-phase calls. The same scene with and
// without ~ignore_pairs: one candidate fewer (a-b), the static pair w1-w2 in neither, the
// impacts identical but for a-b.
TEST(MonitorCore, IgnoredPairsNeverReachTheNarrowPhase) {
  const std::string scene = R"(
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
static_obstacles:
  - {name: w1, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0, 5, 0]}}
  - {name: w2, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0.5, 5, 0]}}
)";
  std::vector<std::string> lines[2];
  size_t candidates[2] = {0, 0};
  for (int filtered = 0; filtered < 2; ++filtered) {
    MonitorCore core = makeCore((filtered ? "ignore_pairs: [[\"a\", \"b*\"]]\n" : "") + scene);
    FakeTf tf;
    core.registry().onOdometry(0, odom(1.0, 0.0, 0.0, 0.0), ros::Time(1.0));
    core.registry().onOdometry(1, odom(1.0, 0.5, 0.0, 0.0, 2.0), ros::Time(1.0));
    const auto& out = core.cycle(ros::Time(1.0), tf);
    candidates[filtered] = core.lastStats().candidates;
    EXPECT_EQ(core.lastStats().ignored_tested, 0u);
    EXPECT_EQ(core.lastStats().raw_impacts, out.impacts.size());
    for (const auto& i : out.impacts) {
      EXPECT_FALSE(i.body_a.front() == 'w' && i.body_b.front() == 'w');
      if (filtered == 0 && i.body_a == "a" && i.body_b == "b") continue;
      lines[filtered].push_back(MonitorCore::describe(i));
    }
  }
  EXPECT_EQ(candidates[1] + 1, candidates[0]);
  EXPECT_FALSE(lines[1].empty());
  EXPECT_EQ(lines[1], lines[0]);
}

// ~coherence_clearance: separated pairs come from certificates after the first cycle, and the
// impacts are those of a monitor without it, cycle after cycle.
TEST(MonitorCore, CoherenceReusesCertificatesAndReportsTheSameImpacts) {
  // The plain grid: VADOP's volumes, aligned with c and d's parallel velocities, would prune c-d.
  const std::string scene = std::string("broad_phase: grid\n") + kFour;
  MonitorCore plain = makeCore("coherence_clearance: 0\n" + scene);
  MonitorCore coherent = makeCore("coherence_clearance: 0.1\ncoherence_lookahead: 0.5\n" + scene);
  FakeTf tf;
  size_t reused = 0;
  // The "cycle" status every 10 cycles: the certificates' answers summed over its window (a
  // status samples one cycle of many: the last cycle alone may show none of them).
  vadop_ros::CycleTimeWindow window;
  size_t in_window = 0;
  auto value = [](const diagnostic_updater::DiagnosticStatusWrapper& stat, const std::string& key) {
    for (const auto& kv : stat.values) {
      if (kv.key == key) return kv.value;
    }
    return std::string("(missing)");
  };
  for (int k = 0; k < 40; ++k) {
    const double t = 100.0 + k / 30.0, s = t - 100.0;
    for (MonitorCore* core : {&plain, &coherent}) {
      // a, b head-on (contact at 1.5 s); c, d on parallel diagonal tracks in opposite directions,
      // 1.3 m apart (a gap of 0.3 m), candidates until they have passed (s = 1.47).
      const double r = std::sqrt(0.5);
      core->registry().onOdometry(0, odom(t, -2.0 + s, 0.0, 1.0), ros::Time(t));
      core->registry().onOdometry(1, odom(t, 2.0 - s, 0.0, -1.0), ros::Time(t));
      core->registry().onOdometry(2, odom(t, 10.0 + r * s, r * s, r, r), ros::Time(t));
      core->registry().onOdometry(3, odom(t, 10.0 + 2.0 - 1.3 * r - r * s, 2.0 + 1.3 * r - r * s, -r, -r), ros::Time(t));
    }
    const vadop::ImpactArray expected = plain.cycle(ros::Time(t), tf);
    const vadop::ImpactArray& got = coherent.cycle(ros::Time(t), tf);
    ASSERT_EQ(got.impacts.size(), expected.impacts.size()) << k;
    for (size_t i = 0; i < got.impacts.size(); ++i) {
      EXPECT_EQ(MonitorCore::describe(got.impacts[i]), MonitorCore::describe(expected.impacts[i])) << k;
    }
    EXPECT_EQ(plain.lastStats().reused, 0u);
    EXPECT_EQ(coherent.lastStats().candidates, plain.lastStats().candidates);
    EXPECT_LE(coherent.lastStats().reused, 1u);  // c-d only
    reused += coherent.lastStats().reused;
    window.add(coherent.lastStats());
    in_window += coherent.lastStats().reused;
    if (k % 10 == 9) {
      diagnostic_updater::DiagnosticStatusWrapper stat;
      window.report(stat, 30.0);
      EXPECT_EQ(value(stat, "candidates answered by certificates in window"), std::to_string(in_window)) << k;
      EXPECT_EQ(value(stat, "candidates answered by certificates"), std::to_string(coherent.lastStats().reused)) << k;
      EXPECT_EQ(value(stat, "cycles in window"), "10") << k;
      in_window = 0;
    }
  }
  // Certified at k = 0 over the window + 0.5 s, then again as each certificate runs out.
  EXPECT_GE(reused, 34u);
}

// The "cycle" status's p95: over the window's cycles (the last CycleTimeWindow::kMaxSamples of
// a longer window), each window on its own, against the sorted window (brute force).
TEST(CycleTimeWindow, P95IsTheSortedWindowsValueAtItsRank) {
  using vadop_ros::CycleTimeWindow;
  std::mt19937 rng(3);
  auto value = [](const diagnostic_updater::DiagnosticStatusWrapper& stat, const std::string& key) {
    for (const auto& kv : stat.values) {
      if (kv.key == key) return std::stod(kv.value);
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  CycleTimeWindow window;
  {
    diagnostic_updater::DiagnosticStatusWrapper stat;
    vadop_ros::CycleStats one;
    one.cycle_seconds = 0.004;
    window.add(one);
    window.report(stat, 30.0);
    EXPECT_NEAR(value(stat, "cycle time p95 (ms)"), 4.0, 1e-9);
  }
  const size_t cap = CycleTimeWindow::kMaxSamples;
  for (size_t n : {size_t{2}, size_t{3}, size_t{20}, size_t{30}, size_t{101}, cap, cap + 1, 2 * cap + 37}) {
    // Distinct times 3 us apart (the status shows 1 us), in random order.
    std::vector<double> times(n);
    for (size_t k = 0; k < n; ++k) times[k] = 1e-3 + 3e-6 * static_cast<double>(k);
    std::shuffle(times.begin(), times.end(), rng);
    for (double t : times) {
      vadop_ros::CycleStats s;
      s.cycle_seconds = t;
      window.add(s);
    }
    std::vector<double> last(times.end() - static_cast<std::ptrdiff_t>(std::min(n, cap)), times.end());
    std::sort(last.begin(), last.end());
    const double expected = last[static_cast<size_t>(std::lround(0.95 * static_cast<double>(last.size() - 1)))];
    diagnostic_updater::DiagnosticStatusWrapper stat;
    window.report(stat, 30.0);
    EXPECT_NEAR(value(stat, "cycle time p95 (ms)"), expected * 1e3, 1e-6) << n;
    EXPECT_NEAR(value(stat, "cycle time max (ms)"), *std::max_element(times.begin(), times.end()) * 1e3, 1e-6) << n;
    EXPECT_EQ(value(stat, "cycles in window"), static_cast<double>(n));
  }
  EXPECT_TRUE(std::isnan(CycleTimeWindow::percentile({}, 0.95)));
}

// The groups and the predicate of Predictor reach the world: pairs left out cost no call.
TEST(Predictor, GroupsAndIgnoredPairsLeaveCandidatesOutBeforeTheNarrowPhase) {
  using vadop_ros::Predictor;
  using vadop_ros::PredictorConfig;
  Predictor p(PredictorConfig{});
  std::string error;
  const vadop::Motion still = vadop::makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                                Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0);
  // Three overlapping spheres: 0 and 1 in a group that does not collide with itself.
  ASSERT_TRUE(p.set(0, "s0", vadop::makeSphere(1.0), still, error, 2u, ~2u));
  ASSERT_TRUE(p.set(1, "s1", vadop::makeSphere(1.0), still, error, 2u, ~2u));
  ASSERT_TRUE(p.set(2, "s2", vadop::makeSphere(1.0), still, error));
  EXPECT_EQ(p.predict(0.0, 1.0).size(), 2u);
  EXPECT_EQ(p.lastCandidateCount(), 2u);
  std::vector<std::pair<size_t, size_t>> asked;
  p.setIgnored([&](size_t a, size_t b) {
    asked.emplace_back(a, b);
    return a == 0 && b == 2;
  });
  const auto out = p.predict(0.0, 1.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].a_user, 1u);
  EXPECT_EQ(out[0].b_user, 2u);
  EXPECT_EQ(p.lastCandidateCount(), 1u);
  std::sort(asked.begin(), asked.end());
  EXPECT_EQ(asked, (std::vector<std::pair<size_t, size_t>>{{0, 2}, {1, 2}}));
  p.setIgnored(nullptr);
  EXPECT_EQ(p.predict(0.0, 1.0).size(), 2u);
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

// The cycle in phases (the node predicts outside its lock) reports what cycle() does; a new
// padding that comes while the world predicts takes effect at the next cycle's start.
TEST(MonitorCore, CycleInPhasesDefersANewPaddingToTheNextCycle) {
  MonitorCore core = makeCore(kFour), twin = makeCore(kFour);
  FakeTf tf;
  for (MonitorCore* c : {&core, &twin}) {
    c->registry().onOdometry(0, odom(1.0, -2.0, 0.0, 1.0), ros::Time(1.0));
    c->registry().onOdometry(1, odom(1.0, 2.0, 0.0, -1.0), ros::Time(1.0));
  }
  twin.cycle(ros::Time(1.0), tf);
  core.startCycle(ros::Time(1.0), tf);
  core.predictCycle();
  EXPECT_TRUE(core.setPadding(0.1));
  EXPECT_FALSE(core.retryCycle(ros::Time(1.0)));
  const vadop::ImpactArray& out = core.finishCycle(ros::Time(1.0));
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_NEAR(out.impacts[0].time_to_impact, 1.5, 1e-4);
  EXPECT_EQ(out.impacts[0].time_to_impact, twin.lastImpacts().impacts.at(0).time_to_impact);
  // The world this cycle predicted is still there (its elements, the markers of its bodies).
  EXPECT_EQ(core.lastStats().elements_in_world, twin.lastStats().elements_in_world);
  EXPECT_EQ(core.markers().markers.size(), twin.markers().markers.size());
  EXPECT_EQ(core.padding(), 0.1);
  ASSERT_EQ(core.cycle(ros::Time(1.0) + ros::Duration(0.001), tf).impacts.size(), 1u);
  EXPECT_NEAR(core.lastImpacts().impacts[0].time_to_impact, 1.399, 1e-4);
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
  // Checked where they are used: by the VADOP broad phase.
  EXPECT_THROW(makeCore("broad_phase: vadop\naxes: 3\nphi_deg: 1.0\n"), vadop_ros::ParamError);
}

TEST(MonitorCore, ParamsBuiltInCodeAreRejectedUnderTheirOwnNames) {
  // A program (the bench, a test) may fill MonitorParams without parseParams: a bad predictor
  // setting is named as the parser names it, not as the VADOP pool's (~axes / ~phi_deg).
  auto errorOf = [](void (*spoil)(MonitorParams&)) -> std::string {
    MonitorParams p;
    spoil(p);
    try {
      MonitorCore core(p, noParams());
    } catch (const vadop_ros::ParamError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(errorOf([](MonitorParams& p) { p.time_slices = 0; }),
            "~time_slices: must be an integer in [1, 64] (1: no cull), got 0");
  EXPECT_EQ(errorOf([](MonitorParams& p) { p.threads = -2; }),
            "~threads: must be an integer in [0, 256] (0: one per hardware thread), got -2");
  EXPECT_EQ(errorOf([](MonitorParams& p) { p.broad_phase = "octree"; }),
            "~broad_phase: unknown broad phase \"octree\" (expected vadop, vadop_sap, sap, grid or brute)");
  EXPECT_EQ(errorOf([](MonitorParams& p) { p.coherence_lookahead = -1.0; }),
            "~coherence_lookahead: must be in [0, 10], got -1");
  EXPECT_EQ(errorOf([](MonitorParams& p) { p.coherence_clearance = std::nan(""); }),
            "~coherence_clearance: must be in [0, 10], got nan");
  EXPECT_EQ(errorOf([](MonitorParams&) {}), "");
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
  nav_msgs::Odometry m = baseOdom(10.0, 0.0, 1.0);
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

// ----------------------------------------------------------------------------- issue 13

namespace {

nav_msgs::Odometry odomAt(const ros::Time& stamp, double x, double y, double vx) {
  nav_msgs::Odometry m = odom(0.0, x, y, vx);
  m.header.stamp = stamp;
  return m;
}

// a and b head-on (impact 1.5 s after `t`), c and d far away standing still.
void headOn(MonitorCore& core, const ros::Time& t) {
  auto& reg = core.registry();
  ASSERT_EQ(reg.onOdometry(0, odomAt(t, -2.0, 0.0, 1.0), t), vadop_ros::InputResult::kAccepted);
  ASSERT_EQ(reg.onOdometry(1, odomAt(t, 2.0, 0.0, -1.0), t), vadop_ros::InputResult::kAccepted);
}

void expectHeadOn(const vadop::ImpactArray& out, double tti) {
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_EQ(out.impacts[0].body_a, "a");
  EXPECT_EQ(out.impacts[0].body_b, "b");
  EXPECT_NEAR(out.impacts[0].time_to_impact, tti, 1e-4);
}

}  // namespace

TEST(MonitorCore, HugeStampsAndClockJumpsNeitherThrowNorStopThePrediction) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  headOn(core, ros::Time(100.0));
  // Odometry stamped secs = 4e9 (old code: the node aborted with "Duration is out of dual
  // 32-bit range"): dropped as 4e9 s ahead of the clock; a and b are still predicted.
  nav_msgs::Odometry far = odom(0.0, 5.0, 5.0, 0.0);
  far.header.stamp = ros::Time(4000000000u, 0);
  EXPECT_EQ(core.registry().onOdometry(2, far, ros::Time(100.0)), vadop_ros::InputResult::kInvalid);
  expectHeadOn(core.cycle(ros::Time(100.5), tf), 1.0);
  // /clock jumps to 4.2e9 s: a and b are stale there (standing still 2 m apart: no impact) and
  // fresh messages at the new time are predicted as before.
  const ros::Time jump(4200000000u, 0);
  EXPECT_NO_THROW(core.cycle(jump, tf));
  EXPECT_TRUE(core.lastStats().error.empty()) << core.lastStats().error;
  headOn(core, jump);
  const vadop::ImpactArray& out = core.cycle(jump + ros::Duration(0.5), tf);
  expectHeadOn(out, 1.0);
  EXPECT_NEAR((out.impacts[0].time_of_impact - jump).toSec(), 1.5, 1e-4);
  // At the very end of ROS time the impact time saturates instead of throwing.
  const ros::Time end(4294967295u, 0);
  headOn(core, end);
  ASSERT_NO_THROW(core.cycle(end + ros::Duration(0.5), tf));
  expectHeadOn(core.lastImpacts(), 1.0);
  EXPECT_EQ(core.lastImpacts().impacts[0].time_of_impact, ros::TIME_MAX);
}

TEST(MonitorCore, RebaseKeepsImpactsStaleChecksAndTheWorldRight) {
  MonitorCore core = makeCore(R"(
stale_timeout: 0.5
horizon: 3.0
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
  - {name: c, odom_topic: /c, shape: {type: sphere, radius: 0.5}}
static_obstacles:
  - {name: wall, shape: {type: box, size: [1, 1, 1]}, pose: {position: [0, 10, 0]}}
)");
  FakeTf tf;
  auto& reg = core.registry();
  const ros::Time t0(1000.0);
  headOn(core, t0);
  expectHeadOn(core.cycle(t0, tf), 1.5);
  const ros::Time base = reg.timeBase();
  EXPECT_EQ(reg.rebases(), 1u);
  // An hour later, just before the rebase: a and b head-on again, c heads for the wall (its
  // face at y = 9.5: 3 m to go at 1.5 m/s).
  const double h = vadop_ros::BodyRegistry::kRebaseAfterSeconds;
  const ros::Time before = t0 + ros::Duration(h - 0.2);
  headOn(core, before);
  nav_msgs::Odometry up = odomAt(before, 0.0, 6.0, 0.0);
  up.twist.twist.linear.y = 1.5;
  ASSERT_EQ(reg.onOdometry(2, up, before), vadop_ros::InputResult::kAccepted);
  const vadop::ImpactArray& pre = core.cycle(before + ros::Duration(0.1), tf);
  EXPECT_EQ(reg.timeBase(), base);
  ASSERT_EQ(pre.impacts.size(), 2u);
  const double pre_wall = pre.impacts[1].time_to_impact;
  EXPECT_NEAR(pre.impacts[0].time_to_impact, 1.4, 1e-4);
  EXPECT_EQ(pre.impacts[1].body_a + pre.impacts[1].body_b, "wallc");  // the wall entered the world first
  EXPECT_NEAR(pre_wall, 1.9, 1e-4);
  const size_t in_world = core.lastStats().elements_in_world;
  // Across the rebase (0.2 s later): the same states give the same impacts, 0.2 s closer.
  const ros::Time after = before + ros::Duration(0.3);
  const vadop::ImpactArray& post = core.cycle(after, tf);
  EXPECT_NE(reg.timeBase(), base);
  EXPECT_EQ(reg.rebases(), 2u);
  EXPECT_LE(std::fabs(reg.seconds(after)), 1.0);
  ASSERT_EQ(post.impacts.size(), 2u);
  EXPECT_NEAR(post.impacts[0].time_to_impact, 1.2, 1e-4);
  EXPECT_EQ(post.impacts[1].body_a + post.impacts[1].body_b, "wallc");
  EXPECT_NEAR(post.impacts[1].time_to_impact, pre_wall - 0.2, 1e-4);
  EXPECT_EQ(core.lastStats().elements_in_world, in_world);
  for (const auto& e : reg.elements()) {
    if (e.active) EXPECT_LE(std::fabs(e.motion.t_ref), 1.0) << e.id;
  }
  // Stale checks use the ROS stamps, not the seconds: 0.5 s after the last messages, stale.
  core.cycle(before + ros::Duration(0.45), tf);
  EXPECT_EQ(reg.bodies()[0].status.state, vadop_ros::BodyState::kOk);
  core.cycle(before + ros::Duration(0.6), tf);
  EXPECT_EQ(reg.bodies()[0].status.state, vadop_ros::BodyState::kStale);
  EXPECT_EQ(reg.bodies()[2].status.state, vadop_ros::BodyState::kStale);
}

TEST(MonitorCore, ElementOutOfRangeNeverBlindsTheOtherBodies) {
  // A body extrapolated beyond kMaxReach (last message 2000 s ago at 9 km/s, stale_timeout
  // 5000 s). Old code gave it to the world, whose predict threw: no impact for anybody.
  MonitorCore core = makeCore(R"(
stale_timeout: 5000
bodies:
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: sphere, radius: 0.5}}
  - {name: far, odom_topic: /f, shape: {type: sphere, radius: 0.5}}
)");
  FakeTf tf;
  ASSERT_EQ(core.registry().onOdometry(2, odom(100.0, 5e6, 0.0, 9e3), ros::Time(100.0)),
            vadop_ros::InputResult::kAccepted);
  headOn(core, ros::Time(2100.0));
  expectHeadOn(core.cycle(ros::Time(2100.0), tf), 1.5);
  EXPECT_TRUE(core.lastStats().error.empty()) << core.lastStats().error;
  EXPECT_EQ(core.lastStats().elements_in_world, 2u);
  EXPECT_EQ(core.registry().bodies()[2].status.last_invalid_receipt, ros::Time(2100.0));
}

TEST(MonitorCore, PredictFailureLeavesTheOffenderOutAndRetriesOnce) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  headOn(core, ros::Time(10.0));
  ASSERT_EQ(core.registry().onOdometry(2, odom(10.0, 0.0, 20.0, 0.0), ros::Time(10.0)),
            vadop_ros::InputResult::kAccepted);
  // The world refuses c at predict (as the library does for a body beyond its range).
  int calls_with_c = 0;
  core.predictorForTesting().before_predict_for_testing = [&](size_t, const std::string& id) {
    if (id == "c") {
      ++calls_with_c;
      throw vadop::InvalidArgument("predict: body \"c\": position[0] beyond 2e7 m (simulated)");
    }
  };
  // Old code: "prediction failed", nothing published for a and b.
  expectHeadOn(core.cycle(ros::Time(10.0), tf), 1.5);
  EXPECT_TRUE(core.lastStats().error.empty()) << core.lastStats().error;
  EXPECT_NE(core.lastStats().recovered.find("c"), std::string::npos);
  EXPECT_EQ(core.registry().bodies()[2].status.last_invalid_receipt, ros::Time(10.0));
  EXPECT_EQ(calls_with_c, 1);
  // Kept out while its motion stays the same (no second failure per cycle) ...
  expectHeadOn(core.cycle(ros::Time(10.1), tf), 1.4);
  EXPECT_EQ(calls_with_c, 1);
  EXPECT_EQ(core.lastStats().elements_in_world, 2u);
  // ... and tried again with a new one.
  core.predictorForTesting().before_predict_for_testing = nullptr;
  ASSERT_EQ(core.registry().onOdometry(2, odom(10.2, 0.0, 20.0, 0.0), ros::Time(10.2)),
            vadop_ros::InputResult::kAccepted);
  core.cycle(ros::Time(10.2), tf);
  EXPECT_EQ(core.lastStats().elements_in_world, 3u);
  // A failure naming no element and no element out of range: this cycle is lost (reported).
  core.predictorForTesting().before_predict_for_testing = [&](size_t, const std::string&) {
    throw vadop::InvalidArgument("predict: something else");
  };
  EXPECT_NO_THROW(core.cycle(ros::Time(10.3), tf));
  EXPECT_FALSE(core.lastStats().error.empty());
  EXPECT_TRUE(core.lastImpacts().impacts.empty());
}

TEST(MonitorCore, ReconfigureKeepsNaNAndOutOfRangeValuesOut) {
  MonitorCore core = makeCore(kFour);
  FakeTf tf;
  headOn(core, ros::Time(1.0));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> errors;
  // dynparam set horizon nan: NaN passes dynamic_reconfigure's clamp. Old code stored it and
  // every cycle failed until a valid horizon was set.
  vadop_ros::RuntimeSettings s = core.reconfigure({nan, nan, nan}, &errors);
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_NE(errors[0].find("horizon"), std::string::npos);
  EXPECT_NE(errors[1].find("rate"), std::string::npos);
  EXPECT_NE(errors[2].find("padding"), std::string::npos);
  EXPECT_EQ(s.horizon, 3.0);
  EXPECT_EQ(s.rate, 30.0);
  EXPECT_EQ(s.padding, 0.0);
  expectHeadOn(core.cycle(ros::Time(1.0), tf), 1.5);
  errors.clear();
  s = core.reconfigure({-1.0, 1e6, 11.0}, &errors);
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_EQ(s.horizon, 3.0);
  EXPECT_EQ(s.rate, 30.0);
  EXPECT_EQ(s.padding, 0.0);
  errors.clear();
  s = core.reconfigure({std::numeric_limits<double>::infinity(), 0.1, 0.1}, &errors);
  EXPECT_EQ(errors.size(), 1u);
  EXPECT_EQ(s.horizon, 3.0);
  EXPECT_EQ(s.rate, 0.1);
  EXPECT_EQ(s.padding, 0.1);
  EXPECT_EQ(core.params().rate, 0.1);
  EXPECT_FALSE(core.setHorizon(nan));
  EXPECT_TRUE(core.setHorizon(60.0));
  EXPECT_EQ(core.horizon(), 60.0);
  expectHeadOn(core.cycle(ros::Time(1.1), tf), 1.3);  // padding 0.1: gap 2.8 m at 1.1 s
}

// A pair the narrow phase cannot decide within its budget (a box spinning 1 cm from another,
// with a budget of one evaluation) is never a contact: predict returns nothing, and the pair
// is listed as undecided with a time inside the window.
TEST(Predictor, UndecidedPairsAreListedApartFromContacts) {
  vadop_ros::PredictorConfig config;
  config.max_iterations = 1;
  vadop_ros::Predictor predictor(config);
  std::string error;
  const vadop::Shape bar = vadop::makeBox(Eigen::Vector3d(2.0, 0.1, 0.1));
  const vadop::Shape post = vadop::makeBox(Eigen::Vector3d(0.1, 0.1, 0.1));
  ASSERT_TRUE(predictor.set(0, "bar", bar,
                            vadop::makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                              Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 20.0), 0.0),
                            error))
      << error;
  ASSERT_TRUE(predictor.set(1, "post", post,
                            vadop::makeMotion(Eigen::Vector3d(1.06, 0.0, 0.0), Eigen::Quaterniond::Identity(),
                                              Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0),
                            error))
      << error;
  const auto hits = predictor.predict(0.0, 10.0);
  EXPECT_TRUE(hits.empty());
  ASSERT_EQ(predictor.lastUndecided().size(), 1u);
  const vadop::Contact& u = predictor.lastUndecided()[0];
  EXPECT_EQ(u.a_user, 0u);
  EXPECT_EQ(u.b_user, 1u);
  EXPECT_GE(u.impact.time, 0.0);
  EXPECT_LE(u.impact.time, 10.0);
  // With the default budget the same pair is decided: clear.
  vadop_ros::Predictor decided{vadop_ros::PredictorConfig{}};
  ASSERT_TRUE(decided.set(0, "bar", bar, predictor.motion(0), error));
  ASSERT_TRUE(decided.set(1, "post", post, predictor.motion(1), error));
  EXPECT_TRUE(decided.predict(0.0, 10.0).empty());
  EXPECT_TRUE(decided.lastUndecided().empty());
}

// A robot whose odometry says "straight on" while its plan (path_topic) turns left: the
// prediction follows the plan, so the pillar on the curve is reported at the time the arc
// reaches it and the pillar ahead on the straight line is not; without the plan, the reverse.
TEST(MonitorCore, PredictsAlongThePlannedPath) {
  const char* yaml_text = R"(
horizon: 3.0
bodies:
  - {name: robot, odom_topic: /robot/odom, path_topic: /robot/plan, shape: {type: sphere, radius: 0.3}}
static_obstacles:
  - {name: on_curve, shape: {type: sphere, radius: 0.2}, pose: {position: [1.8640782, 1.2752885, 0.0]}}
  - {name: ahead, shape: {type: sphere, radius: 0.2}, pose: {position: [2.0, -0.3, 0.0]}}
)";
  // The arc: radius 2 m about (0, 2), 0.5 rad/s from the origin at t = 100 s; on_curve sits on
  // it at 1.2 rad. First contact (centres 0.5 m apart) at 1.2 - 2 asin(0.5 / 4) rad.
  const double expected = (1.2 - 2.0 * std::asin(0.125)) / 0.5;
  auto arc = [](double t, geometry_msgs::Pose& p) {
    const double th = 0.5 * (t - 100.0);
    p.position.x = 2.0 * std::sin(th);
    p.position.y = 2.0 - 2.0 * std::cos(th);
    p.orientation.z = std::sin(th / 2);
    p.orientation.w = std::cos(th / 2);
  };
  nav_msgs::Path plan;
  plan.header.stamp = ros::Time(100.0);
  plan.header.frame_id = "odom";
  for (int k = 0; k <= 30; ++k) {
    geometry_msgs::PoseStamped s;
    s.header.stamp = ros::Time(100.0 + 0.1 * k);
    arc(s.header.stamp.toSec(), s.pose);
    plan.poses.push_back(s);
  }
  for (const bool with_plan : {true, false}) {
    MonitorCore core = makeCore(yaml_text);
    FakeTf tf;
    core.registry().onOdometry(0, odom(100.0, 0.0, 0.0, 1.0), ros::Time(100.0));
    if (with_plan) {
      ASSERT_EQ(core.registry().onPath(0, plan, ros::Time(100.0), tf), vadop_ros::InputResult::kAccepted);
    }
    const auto& out = core.cycle(ros::Time(100.0), tf);
    ASSERT_EQ(out.impacts.size(), 1u) << "with_plan " << with_plan;
    const vadop::Impact& i = out.impacts[0];
    if (with_plan) {
      EXPECT_EQ(i.body_b, "on_curve");
      EXPECT_NEAR(i.time_to_impact, expected, 1e-4);
      // The point lies between the centres, the normal along them; closing speed from the arc's
      // velocity there (1 m/s along the tangent).
      const double th = 0.5 * i.time_to_impact;
      const Eigen::Vector3d c(2.0 * std::sin(th), 2.0 - 2.0 * std::cos(th), 0.0);
      const Eigen::Vector3d o(1.8640782, 1.2752885, 0.0);
      const Eigen::Vector3d n = (o - c).normalized();
      EXPECT_NEAR(i.normal.x, n.x(), 1e-3);
      EXPECT_NEAR(i.normal.y, n.y(), 1e-3);
      EXPECT_NEAR(i.closing_speed, Eigen::Vector3d(std::cos(th), std::sin(th), 0.0).dot(n), 1e-3);
      // Markers draw the curve: the line of the robot ends on the arc, not on the straight line.
      const auto markers = core.markers();
      bool found = false;
      for (const auto& m : markers.markers) {
        if (m.ns != "robot" || m.type != visualization_msgs::Marker::LINE_STRIP) continue;
        found = true;
        EXPECT_NEAR(m.points.back().x, 2.0 * std::sin(1.5), 1e-6);
        EXPECT_NEAR(m.points.back().y, 2.0 - 2.0 * std::cos(1.5), 1e-6);
      }
      EXPECT_TRUE(found);
    } else {
      EXPECT_EQ(i.body_b, "ahead");
    }
    // The diagnostics name the source the prediction follows.
    const std::string text = vadop_ros::describeBody(core.registry().bodies()[0], ros::Time(100.0), 0.5, nullptr);
    EXPECT_NE(text.find(with_plan ? "predicted along: path (1 path(s) accepted, 0 dropped, plan ends in 3.00 s)"
                                  : "predicted along: odometry (0 path(s)"),
              std::string::npos)
        << text;
  }
}

// A planar arm with both joints moving (joint_states_topic): the forearm's sphere meets a post
// at the time this test's own kinematics, stepped densely, finds (the first-order tf model was
// 89 ms off in the same situation).
TEST(MonitorCore, TwoJointArmFromJointStatesMeetsThePostOnTime) {
  auto centre = [](double t) {
    const double a = -0.5 + 0.3 * t, b = a + 0.4 - 0.2 * t;
    return Eigen::Vector3d(std::cos(a) + 0.8 * std::cos(b), std::sin(a) + 0.8 * std::sin(b), 0.0);
  };
  const Eigen::Vector3d post = centre(1.5) + Eigen::Vector3d(0.03, 0.05, 0.0);
  const double hi = firstContact(centre, post);
  ASSERT_GT(hi, 0.0);
  char yaml_text[1024];
  std::snprintf(yaml_text, sizeof yaml_text, R"(
horizon: 3.0
bodies:
  - {name: arm, odom_topic: /arm/odom, robot_description: /arm_description, joint_states_topic: /arm/joint_states}
static_obstacles:
  - {name: post, shape: {type: sphere, radius: 0.1}, pose: {position: [%.12f, %.12f, 0.0]}}
)",
                post.x(), post.y());
  MonitorCore core = makeCore(yaml_text, urdfParams(vadop_test::kPlanarArm));
  FakeTf tf;
  core.registry().onOdometry(0, baseOdom(100.0, 0.0, 0.0), ros::Time(100.0));
  ASSERT_EQ(core.registry().onJointState(0, planarArmJoints(), ros::Time(100.0)), vadop_ros::InputResult::kAccepted);
  const auto& out = core.cycle(ros::Time(100.0), tf);
  ASSERT_EQ(out.impacts.size(), 1u);
  EXPECT_EQ(out.impacts[0].link_a, "fore");
  EXPECT_EQ(out.impacts[0].body_b, "post");
  EXPECT_NEAR(out.impacts[0].time_to_impact, hi, 1e-3) << "truth " << hi;
  std::printf("two-joint arm: predicted %.6f s, truth %.6f s, error %.2e s\n", out.impacts[0].time_to_impact, hi,
              out.impacts[0].time_to_impact - hi);
}

// The same arm on a mobile base that drives its plan (path_topic: an arc of radius 2 m, left,
// 1 m/s) while the odometry says "straight on": the sphere's first contact with a post placed
// off its path at 1.5 s comes when the base's arc and the joints' motion together bring it
// there (dense truth of this file's own kinematics), on every broad phase. The twist's
// straight line or the plan without the joints would miss the post or meet it at another time.
TEST(MonitorCore, ArmOnAMobileBaseFollowingItsPlanMeetsThePostOnTime) {
  auto centre = [](double t, bool plan, bool joints) {
    const double yaw = plan ? 0.5 * t : 0.0;
    const Eigen::Vector3d base = plan ? Eigen::Vector3d(2.0 * std::sin(yaw), 2.0 * (1.0 - std::cos(yaw)), 0.0)
                                      : Eigen::Vector3d(t, 0.0, 0.0);
    const double a = yaw - 0.5 + (joints ? 0.3 * t : 0.0), b = a + 0.4 - (joints ? 0.2 * t : 0.0);
    return Eigen::Vector3d(base + Eigen::Vector3d(std::cos(a) + 0.8 * std::cos(b), std::sin(a) + 0.8 * std::sin(b), 0.0));
  };
  const Eigen::Vector3d post = centre(1.5, true, true) + Eigen::Vector3d(0.03, 0.05, 0.0);
  const auto contact = [&](bool plan, bool joints) {
    return firstContact([&](double t) { return centre(t, plan, joints); }, post);
  };
  const double truth = contact(true, true);
  ASSERT_GT(truth, 0.0);
  // Not vacuous: neither the twist nor the plan alone reaches the post when both do.
  for (const auto& [plan, joints] : {std::pair{false, true}, std::pair{true, false}, std::pair{false, false}}) {
    const double other = contact(plan, joints);
    EXPECT_TRUE(other < 0.0 || std::abs(other - truth) > 0.1) << plan << joints << " " << other;
  }
  // The plan: the arc sampled every 0.1 s for 4 s.
  nav_msgs::Path plan;
  plan.header.frame_id = "odom";
  plan.header.stamp = ros::Time(100.0);
  for (double t = 0.1; t <= 4.0 + 1e-9; t += 0.1) {
    geometry_msgs::PoseStamped ps;
    ps.header.stamp = ros::Time(100.0 + t);
    ps.pose.position.x = 2.0 * std::sin(0.5 * t);
    ps.pose.position.y = 2.0 * (1.0 - std::cos(0.5 * t));
    ps.pose.orientation.z = std::sin(0.25 * t);
    ps.pose.orientation.w = std::cos(0.25 * t);
    plan.poses.push_back(ps);
  }
  for (const char* broad_phase : {"grid", "vadop", "sap", "vadop_sap", "brute"}) {
    char yaml_text[1024];
    std::snprintf(yaml_text, sizeof yaml_text, R"(
horizon: 3.0
broad_phase: %s
bodies:
  - {name: arm, odom_topic: /arm/odom, robot_description: /arm_description, joint_states_topic: /arm/joint_states,
     path_topic: /arm/plan}
static_obstacles:
  - {name: post, shape: {type: sphere, radius: 0.1}, pose: {position: [%.12f, %.12f, 0.0]}}
)",
                  broad_phase, post.x(), post.y());
    MonitorCore core = makeCore(yaml_text, urdfParams(vadop_test::kPlanarArm));
    FakeTf tf;
    core.registry().onOdometry(0, baseOdom(100.0, 0.0, 1.0), ros::Time(100.0));
    ASSERT_EQ(core.registry().onPath(0, plan, ros::Time(100.0), tf), vadop_ros::InputResult::kAccepted);
    ASSERT_EQ(core.registry().onJointState(0, planarArmJoints(), ros::Time(100.0)),
              vadop_ros::InputResult::kAccepted);
    const auto& out = core.cycle(ros::Time(100.0), tf);
    ASSERT_EQ(out.impacts.size(), 1u) << broad_phase;
    EXPECT_EQ(out.impacts[0].link_a, "fore");
    EXPECT_EQ(out.impacts[0].body_b, "post");
    EXPECT_NEAR(out.impacts[0].time_to_impact, truth, 1e-3) << broad_phase << ": truth " << truth;
    std::printf("arm on a mobile base along its plan (%s): predicted %.6f s, truth %.6f s, error %.2e s\n", broad_phase,
                out.impacts[0].time_to_impact, truth, out.impacts[0].time_to_impact - truth);
    // The diagnostics name both sources, once.
    const std::string text = vadop_ros::describeBody(core.registry().bodies()[0], ros::Time(100.0), 0.5, nullptr);
    const std::string along = "predicted along: path + joint states (1 joint state(s) accepted, 0 dropped; 1 path(s) "
                              "accepted, 0 dropped, plan ends in 4.00 s)";
    EXPECT_NE(text.find(along), std::string::npos) << text;
    EXPECT_EQ(text.find("predicted along"), text.rfind("predicted along")) << text;
  }
}

// Two links of one body that overlap at their joint, no ~ignore_pairs and no self_collision:
// their pair is ruled out before the narrow phase (pairIgnored's same-body rules) even though
// no pair filter is configured, and the other body still meets the robot.
TEST(MonitorCore, LinksOfOneBodyAreNeverPairedWithoutIgnorePairs) {
  const std::string urdf = R"(<robot name="two_links">
  <link name="base_link"><collision><geometry><box size="0.6 0.6 0.2"/></geometry></collision></link>
  <link name="mast"><collision><origin xyz="0 0 0.2"/><geometry><cylinder radius="0.1" length="0.6"/></geometry></collision></link>
  <joint name="turn" type="continuous"><parent link="base_link"/><child link="mast"/><axis xyz="0 0 1"/></joint>
</robot>)";
  MonitorCore core = makeCore(R"(
horizon: 3.0
bodies:
  - {name: robot, odom_topic: /robot/odom, robot_description: /robot_description, joint_states_topic: /robot/joint_states}
  - {name: cart, odom_topic: /cart/odom, shape: {type: sphere, radius: 0.2}}
)",
                              urdfParams(urdf));
  FakeTf tf;
  core.registry().onOdometry(0, baseOdom(100.0, 0.0, 0.5), ros::Time(100.0));
  core.registry().onOdometry(1, odom(100.0, 1.5, 0.0, 0.0), ros::Time(100.0));
  sensor_msgs::JointState js;
  js.header.stamp = ros::Time(100.0);
  js.name = {"turn"};
  js.position = {0.0};
  js.velocity = {0.5};
  ASSERT_EQ(core.registry().onJointState(0, js, ros::Time(100.0)), vadop_ros::InputResult::kAccepted);
  const auto& out = core.cycle(ros::Time(100.0), tf);
  EXPECT_EQ(core.lastStats().elements_in_world, 3u);
  // The links overlap from the start and are never reported; the robot (front face at x = 0.3,
  // 0.5 m/s) meets the cart (back at x = 1.3) 2 s later.
  ASSERT_EQ(out.impacts.size(), 2u);  // each link with the cart, the base first
  for (const auto& i : out.impacts) {
    EXPECT_EQ(i.body_a, "robot");
    EXPECT_EQ(i.body_b, "cart") << i.link_a << " / " << i.link_b;
  }
  EXPECT_EQ(out.impacts[0].link_a, "base_link");
  EXPECT_NEAR(out.impacts[0].time_to_impact, 2.0, 1e-2);
  // Left out before the narrow phase, not filtered from its results.
  EXPECT_EQ(core.lastStats().ignored_tested, 0u);
  EXPECT_EQ(core.lastStats().raw_impacts, 2u);
}

// The ImpactArray's entries are overwritten in place from cycle to cycle: after every cycle of
// a scene whose bodies jump about (impacts come and go, in contact or not, with and without
// links), the array equals the one a new core computes from the same last messages.
TEST(MonitorCore, ImpactArrayKeptAcrossCyclesEqualsAFreshCore) {
  const std::string urdf = R"(<robot name="two_links">
  <link name="base_link"><collision><geometry><box size="0.6 0.6 0.2"/></geometry></collision></link>
  <link name="mast"><collision><origin xyz="0 0 0.2"/><geometry><cylinder radius="0.1" length="0.6"/></geometry></collision></link>
  <joint name="turn" type="fixed"><parent link="base_link"/><child link="mast"/></joint>
</robot>)";
  const char* config = R"(
horizon: 2.0
bodies:
  - {name: robot, odom_topic: /robot/odom, robot_description: /robot_description}
  - {name: a, odom_topic: /a, shape: {type: sphere, radius: 0.3}}
  - {name: bb, odom_topic: /b, shape: {type: box, size: [0.5, 0.4, 0.3]}}
  - {name: c, odom_topic: /c, shape: {type: cylinder, radius: 0.2, length: 0.4}}
  - {name: d, odom_topic: /d, shape: {type: sphere, radius: 0.4}}
)";
  MonitorCore kept = makeCore(config, urdfParams(urdf));
  FakeTf tf;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> pos(-2.0, 2.0), vel(-1.5, 1.5);
  size_t seen = 0, links = 0, shrank = 0, previous = 0;
  for (int cycle = 0; cycle < 60; ++cycle) {
    const double stamp = 100.0 + cycle / 30.0;
    std::vector<nav_msgs::Odometry> msgs;
    for (int i = 0; i < 5; ++i) {
      nav_msgs::Odometry m = odom(stamp, pos(rng), pos(rng), vel(rng), vel(rng));
      if (i == 0) m.child_frame_id = "base_link";
      if (cycle % 7 == 3) m.pose.pose.position.x += 40.0 * i;  // now and then nobody meets
      msgs.push_back(m);
    }
    MonitorCore fresh = makeCore(config, urdfParams(urdf));
    for (int i = 0; i < 5; ++i) {
      ASSERT_EQ(kept.registry().onOdometry(i, msgs[i], ros::Time(stamp)), vadop_ros::InputResult::kAccepted);
      ASSERT_EQ(fresh.registry().onOdometry(i, msgs[i], ros::Time(stamp)), vadop_ros::InputResult::kAccepted);
    }
    const auto& got = kept.cycle(ros::Time(stamp), tf).impacts;
    const auto& want = fresh.cycle(ros::Time(stamp), tf).impacts;
    ASSERT_EQ(got.size(), want.size()) << "cycle " << cycle;
    for (size_t k = 0; k < got.size(); ++k) {
      // Every field; the numbers within the narrow phase's contract (the two registries count
      // time from different bases, so the advancement takes other steps to the same contact).
      const vadop::Impact& g = got[k];
      const vadop::Impact& w = want[k];
      SCOPED_TRACE("cycle " + std::to_string(cycle) + " impact " + std::to_string(k));
      EXPECT_EQ(g.body_a, w.body_a);
      EXPECT_EQ(g.link_a, w.link_a);
      EXPECT_EQ(g.body_b, w.body_b);
      EXPECT_EQ(g.link_b, w.link_b);
      EXPECT_NEAR(g.time_to_impact, w.time_to_impact, 1e-5);
      EXPECT_NEAR((g.time_of_impact - w.time_of_impact).toSec(), 0.0, 1e-5);
      // Faces touching along a patch: the witness point is any of it, the same along the normal.
      EXPECT_NEAR((g.point.x - w.point.x) * w.normal.x + (g.point.y - w.point.y) * w.normal.y +
                      (g.point.z - w.point.z) * w.normal.z,
                  0.0, 1e-4);
      EXPECT_NEAR(g.normal.x, w.normal.x, 1e-3);
      EXPECT_NEAR(g.normal.y, w.normal.y, 1e-3);
      EXPECT_NEAR(g.normal.z, w.normal.z, 1e-3);
      EXPECT_NEAR(g.closing_speed, w.closing_speed, 1e-3);
      EXPECT_EQ(g.in_contact, w.in_contact);
      links += !g.link_a.empty() || !g.link_b.empty();
    }
    seen += got.size();
    shrank += got.size() < previous;
    previous = got.size();
  }
  // The scene exercised what the reuse could get wrong: links, and arrays growing and shrinking.
  EXPECT_GT(seen, 60u);
  EXPECT_GT(links, 10u);
  EXPECT_GT(shrank, 5u);
}

// ~broad_phase: every broad phase hands the narrow phase the pairs that can touch, so the
// impacts are those of brute force (every pair's swept boxes tested), cycle after cycle, in a
// turning fleet.
TEST(MonitorCore, EveryBroadPhaseReportsTheImpactsOfBruteForce) {
  std::string config = "horizon: 2.0\nbodies:\n";
  const char* shapes[] = {"{type: sphere, radius: 0.3}", "{type: box, size: [0.6, 0.4, 0.3]}",
                          "{type: cylinder, radius: 0.25, length: 0.5}", "{type: capsule, radius: 0.2, length: 0.4}"};
  constexpr int kBodies = 48;
  for (int i = 0; i < kBodies; ++i) {
    config += "  - {name: r" + std::to_string(i) + ", odom_topic: /r" + std::to_string(i) + ", shape: " + shapes[i % 4] + "}\n";
  }
  const std::vector<std::string> kinds = {"brute", "grid", "vadop", "sap", "vadop_sap"};
  std::vector<std::unique_ptr<MonitorCore>> cores;  // MonitorCore does not move
  for (const std::string& kind : kinds) {
    cores.push_back(std::make_unique<MonitorCore>(vadop_ros::parseParams(vadop_test::yaml("broad_phase: " + kind + "\n" + config)), noParams()));
  }
  FakeTf tf;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-6.0, 6.0), speed(0.3, 1.5), turn(-0.5, 0.5), angle(-M_PI, M_PI);
  size_t seen = 0;
  for (int cycle = 0; cycle < 20; ++cycle) {
    const double stamp = 100.0 + cycle / 30.0;
    for (int i = 0; i < kBodies; ++i) {
      const double heading = angle(rng), v = speed(rng);
      nav_msgs::Odometry m = odom(stamp, pos(rng), pos(rng), v * std::cos(heading), v * std::sin(heading));
      m.twist.twist.angular.z = turn(rng);
      for (auto& core : cores) {
        ASSERT_EQ(core->registry().onOdometry(i, m, ros::Time(stamp)), vadop_ros::InputResult::kAccepted);
      }
    }
    const vadop::ImpactArray want = cores[0]->cycle(ros::Time(stamp), tf);
    for (size_t c = 1; c < cores.size(); ++c) {
      const auto& got = cores[c]->cycle(ros::Time(stamp), tf).impacts;
      ASSERT_EQ(got.size(), want.impacts.size()) << kinds[c] << ", cycle " << cycle;
      for (size_t k = 0; k < got.size(); ++k) {
        EXPECT_EQ(MonitorCore::describe(got[k]), MonitorCore::describe(want.impacts[k])) << kinds[c] << ", cycle " << cycle;
      }
    }
    seen += want.impacts.size();
  }
  EXPECT_GT(seen, 100u);
}

// The ImpactArray's entries are written on the threads when a cycle has hundreds: the array and
// the bodies' soonest times are those of one thread, cycle after cycle (the array shrinking and
// growing).
TEST(MonitorCore, ImpactArrayOnTheThreadsEqualsOneThread) {
  std::string config = "horizon: 2.0\nbodies:\n";
  constexpr int kBodies = 160;
  for (int i = 0; i < kBodies; ++i) {
    config += "  - {name: r" + std::to_string(i) + ", odom_topic: /r" + std::to_string(i) + ", shape: " +
              (i % 2 ? "{type: sphere, radius: 0.3}" : "{type: box, size: [0.6, 0.4, 0.3]}") + "}\n";
  }
  MonitorCore one = makeCore("threads: 1\n" + config);
  MonitorCore four = makeCore("threads: 4\n" + config);
  FakeTf tf;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> speed(-1.5, 1.5), turn(-0.5, 0.5);
  size_t threaded_cycles = 0;
  for (int cycle = 0; cycle < 12; ++cycle) {
    const double stamp = 100.0 + cycle / 30.0;
    // Crowded (hundreds of impacts) or spread out (a few), in turn.
    const double side = cycle % 3 == 2 ? 60.0 : 8.0;
    std::uniform_real_distribution<double> pos(-side / 2, side / 2);
    for (int i = 0; i < kBodies; ++i) {
      nav_msgs::Odometry m = odom(stamp, pos(rng), pos(rng), speed(rng), speed(rng));
      m.twist.twist.angular.z = turn(rng);
      ASSERT_EQ(one.registry().onOdometry(i, m, ros::Time(stamp)), vadop_ros::InputResult::kAccepted);
      ASSERT_EQ(four.registry().onOdometry(i, m, ros::Time(stamp)), vadop_ros::InputResult::kAccepted);
    }
    const vadop::ImpactArray want = one.cycle(ros::Time(stamp), tf);
    const auto& got = four.cycle(ros::Time(stamp), tf).impacts;
    ASSERT_EQ(got.size(), want.impacts.size()) << "cycle " << cycle;
    for (size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(MonitorCore::describe(got[k]), MonitorCore::describe(want.impacts[k])) << "cycle " << cycle;
      EXPECT_EQ(got[k].time_of_impact, want.impacts[k].time_of_impact);
      EXPECT_EQ(got[k].in_contact, want.impacts[k].in_contact);
    }
    EXPECT_EQ(four.soonest(), one.soonest()) << "cycle " << cycle;
    threaded_cycles += got.size() >= 256;  // two threads' worth (128 impacts each)
  }
  EXPECT_GE(threaded_cycles, 4u);
}

// A site split among four monitors (~region: the quadrants of a 40 m square, ~region_margin
// covering two bodies' travel over the horizon): the union of their impacts is the impacts of
// one monitor over the whole fleet, pair for pair at the same time, none lost at a border,
// none reported that the single monitor does not have; each monitor predicts fewer bodies.
TEST(MonitorCore, FourRegionsReportTheImpactsOfOneMonitorOverTheWholeSite) {
  constexpr int kBodies = 160;
  std::string bodies = "bodies:\n";
  for (int i = 0; i < kBodies; ++i) {
    bodies += "  - {name: r" + std::to_string(i) + ", odom_topic: /r" + std::to_string(i) +
              "/odom, shape: {type: cylinder, radius: 0.3, length: 0.5}}\n";
  }
  const std::string base = "horizon: 2.0\n" + bodies;
  // Speeds up to 1 m/s each over a 2 s horizon: a partner of a body inside a region is within
  // 2 * 1 * 2 + 2 * 0.3 m of it, so a margin of 5 m leaves none out.
  auto quadrant = [&](double x0, double y0) {
    return base + "region: {min: [" + std::to_string(x0) + ", " + std::to_string(y0) + ", -10], max: [" +
           std::to_string(x0 + 20.0) + ", " + std::to_string(y0 + 20.0) + ", 10]}\nregion_margin: 5.0\n";
  };
  std::vector<std::unique_ptr<MonitorCore>> shards;
  MonitorCore whole = makeCore(base);
  for (double x0 : {-20.0, 0.0}) {
    for (double y0 : {-20.0, 0.0}) {
      shards.push_back(std::make_unique<MonitorCore>(vadop_ros::parseParams(vadop_test::yaml(quadrant(x0, y0))), noParams()));
    }
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-20.0, 20.0), vel(-0.7, 0.7);
  FakeTf tf;
  size_t compared = 0, across = 0;
  std::vector<int> quadrant_of(kBodies);
  for (int round = 0; round < 5; ++round) {
    const double stamp = 100.0 + round;
    for (int i = 0; i < kBodies; ++i) {
      // A fifth of the fleet near the borders x = 0 and y = 0, where the regions meet.
      double x = pos(rng), y = pos(rng);
      if (i % 5 == 0) x = 0.5 * vel(rng);
      if (i % 5 == 1) y = 0.5 * vel(rng);
      const double vx = vel(rng), vy = vel(rng);
      // Its quadrant at the cycle (0.01 s after the stamp): the region that must report it.
      quadrant_of[i] = (x + 0.01 * vx >= 0.0 ? 2 : 0) + (y + 0.01 * vy >= 0.0 ? 1 : 0);
      const nav_msgs::Odometry m = odom(stamp, x, y, vx, vy);
      whole.registry().onOdometry(i, m, ros::Time(stamp));
      for (auto& s : shards) s->registry().onOdometry(i, m, ros::Time(stamp));
    }
    const ros::Time now(stamp + 0.01);
    std::map<std::pair<std::string, std::string>, double> truth, united;
    // A pair by its names in order (which body is a depends on the order they entered a world).
    const auto pairOf = [](const vadop::Impact& i) { return std::minmax(i.body_a, i.body_b); };
    for (const vadop::Impact& i : whole.cycle(now, tf).impacts) truth[pairOf(i)] = i.time_to_impact;
    for (size_t k = 0; k < shards.size(); ++k) {
      auto& s = shards[k];
      for (const vadop::Impact& i : s->cycle(now, tf).impacts) {
        const std::pair<std::string, std::string> key = pairOf(i);
        // Only pairs with a body inside its own quadrant (shards in quadrant_of's order).
        EXPECT_TRUE(quadrant_of[std::stoi(i.body_a.substr(1))] == static_cast<int>(k) ||
                    quadrant_of[std::stoi(i.body_b.substr(1))] == static_cast<int>(k))
            << key.first << "-" << key.second << " reported by region " << k << ", where neither is";
        ASSERT_TRUE(truth.count(key)) << key.first << "-" << key.second << " reported by a region only";
        EXPECT_NEAR(i.time_to_impact, truth[key], 1e-3) << key.first << "-" << key.second;
        united[key] = i.time_to_impact;
      }
      EXPECT_LT(s->lastStats().elements_in_world, static_cast<size_t>(kBodies));
    }
    for (const auto& [pair, t] : truth) {
      EXPECT_TRUE(united.count(pair)) << pair.first << "-" << pair.second << " at " << t << " s lost at a border";
      ++compared;
    }
    // Pairs whose bodies lie in different quadrants: the borders are really crossed.
    for (const auto& [pair, t] : truth) {
      across += quadrant_of[std::stoi(pair.first.substr(1))] != quadrant_of[std::stoi(pair.second.substr(1))] ? 1 : 0;
    }
  }
  EXPECT_GT(compared, 20u);
  EXPECT_GT(across, 5u);
}
