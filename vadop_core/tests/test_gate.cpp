// The velocity gate's pieces in the library: World::firstContactIf (a body's links under a
// candidate motion against the world, the world unchanged) and searchGateScale (the largest
// clear scale of a command). Analytic cases pin the search's rules; random scenes compare both
// with brute force: a second world (brute-force broad phase) in which the links are given the
// scaled motions and predicted, over every grid point and a fine grid of scales.
#include "vadop/error.h"
#include "vadop/world.h"
#include "vadop/world.h"

#include "impact_compare.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace vadop {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(GateScale, LargestClearGridPointFirst) {
  // Clear at and below 0.5: 1, 0.98, ..., 0.5 tried (26 calls), 0.5 returned.
  const GateScale g = searchGateScale([](double s) { return s <= 0.5 + 1e-12 ? kInf : 1.0; });
  EXPECT_TRUE(g.clear);
  EXPECT_NEAR(g.scale, 0.5, 1e-12);
  EXPECT_EQ(g.evaluations, 26u);
  // Clear at full speed: one call.
  EXPECT_EQ(searchGateScale([](double) { return kInf; }).evaluations, 1u);
  // Clear only in a band above a blocked one (passing before a crossing agent): the band's top.
  const GateScale band = searchGateScale([](double s) { return s > 0.7 ? 0.4 : (s > 0.3 ? kInf : 0.9); });
  EXPECT_TRUE(band.clear);
  EXPECT_NEAR(band.scale, 0.7, 1e-12);
}

TEST(GateScale, WithoutAClearScaleTheLatestContactWins) {
  // Something drives into the body: the latest first contact, here at full speed away.
  GateScale g = searchGateScale([](double s) { return 1.0 + s; });
  EXPECT_FALSE(g.clear);
  EXPECT_EQ(g.scale, 1.0);
  EXPECT_EQ(g.contact_time, 2.0);
  EXPECT_EQ(g.evaluations, 51u);
  g = searchGateScale([](double s) { return 2.0 - s; });
  EXPECT_EQ(g.scale, 0.0);
  // Ties (every scale meets the same contact): the smaller scale, stopping.
  g = searchGateScale([](double) { return 0.3; });
  EXPECT_EQ(g.scale, 0.0);
  g = searchGateScale([](double s) { return s < 0.5 ? 0.3 : 0.2; });
  EXPECT_EQ(g.scale, 0.0);
  g = searchGateScale([](double s) { return s > 0.5 ? 0.3 : 0.2; });
  EXPECT_NEAR(g.scale, 0.52, 1e-12);
  // A step that does not divide 1 still ends at 0.
  std::vector<double> tried;
  searchGateScale([&](double s) { tried.push_back(s); return 1.0; }, 0.3);
  EXPECT_EQ(tried.size(), 5u);  // 1, 0.7, 0.4, 0.1, 0
  EXPECT_EQ(tried.back(), 0.0);
}

TEST(GateScale, BadInputThrows) {
  EXPECT_THROW(searchGateScale([](double) { return kInf; }, 0.0), InvalidArgument);
  EXPECT_THROW(searchGateScale([](double) { return kInf; }, NAN), InvalidArgument);
  EXPECT_THROW(searchGateScale([](double) { return kInf; }, 1.5), InvalidArgument);
  EXPECT_THROW(searchGateScale({}), InvalidArgument);
  EXPECT_THROW(searchGateScale([](double) { return NAN; }), InvalidArgument);
}

// A robot: two boxes rigid with a base at `base` (position, yaw), driven by the body-frame
// twist (v, w) scaled by s, from t0: each link turns about the robot's screw axis.
struct Robot {
  Eigen::Vector3d position;
  double yaw = 0.0;
  Eigen::Vector3d v, w;  // body frame
  std::vector<Eigen::Vector3d> offsets{{0.0, 0.0, 0.0}, {0.6, 0.0, 0.0}};
  std::vector<Shape> shapes{makeBox({0.6, 0.5, 0.4}), makeBox({0.4, 0.3, 0.3})};
  std::vector<Motion> motions(double s, double t0) const {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d vw = r * v * s, ww = r * w * s;
    std::vector<Motion> out;
    for (const Eigen::Vector3d& o : offsets) {
      const Eigen::Vector3d arm = r * o;
      const Eigen::Vector3d ve = vw + ww.cross(arm);
      Motion m = makeMotion(position + arm, Eigen::Quaterniond(r), screwPivotVelocity(ve, ww), ww, t0);
      m.pivot_offset = screwPivotOffset(ve, ww);
      out.push_back(m);
    }
    return out;
  }
};

void addScene(World& w, const Robot& robot, const std::vector<Shape>& shapes, const std::vector<Motion>& motions) {
  const std::vector<Motion> own = robot.motions(1.0, 0.0);
  for (size_t i = 0; i < robot.shapes.size(); ++i) w.add("robot/" + std::to_string(i), robot.shapes[i], own[i]);
  for (size_t i = 0; i < shapes.size(); ++i) w.add("obstacle/" + std::to_string(i), shapes[i], motions[i]);
}

TEST(GateScale, MatchesBruteForceOnRandomScenes) {
  const double t0 = 0.0, window = 1.0;
  size_t scenes = 0, clear_scenes = 0, blocked_scenes = 0, partial = 0, thin = 0, contacts = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Robot robot;
    robot.position = Eigen::Vector3d(0, 0, 0.2);
    robot.yaw = 3.0 * u(rng);
    robot.v = Eigen::Vector3d(1.5 + u(rng), 0.3 * u(rng), 0.0);
    robot.w = Eigen::Vector3d(0, 0, 1.5 * u(rng));
    std::vector<Shape> shapes;
    std::vector<Motion> motions;
    for (int i = 0; i < 12; ++i) {
      Eigen::Vector3d p(3.0 * u(rng), 3.0 * u(rng), 0.2);
      if (p.head<2>().norm() < 1.0) p.head<2>() *= 1.0 / p.head<2>().norm();  // not on the robot
      const Eigen::Vector3d v(1.2 * u(rng), 1.2 * u(rng), 0.0);
      shapes.push_back(i % 2 ? makeSphere(0.25 + 0.1 * u(rng)) : makeBox({0.5, 0.4, 0.4}));
      motions.push_back(makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d(0, 0, 0.5 * u(rng)), t0));
    }
    WorldConfig fast_config;  // the default VADOP grid answers the gate's queries
    World gate_world(fast_config);
    addScene(gate_world, robot, shapes, motions);
    gate_world.predict(t0, 2.0);  // the node's cycle: a frame to answer queries from
    WorldConfig brute_config;
    brute_config.broad_phase = BroadPhaseKind::kBrute;
    World brute(brute_config);
    addScene(brute, robot, shapes, motions);
    const std::vector<std::string> links = {"robot/0", "robot/1"};

    // Brute force: the links given the scaled motions, predicted with everything else.
    auto bruteContact = [&](double s) {
      const std::vector<Motion> m = robot.motions(s, t0);
      for (size_t i = 0; i < links.size(); ++i) brute.setMotion(links[i], m[i]);
      double first = kInf;
      for (const Contact& hit : brute.predict(t0, window, links)) {
        const bool own = hit.a.rfind("robot/", 0) == 0 && hit.b.rfind("robot/", 0) == 0;
        if (own) continue;
        // A pair touching at t0 blocks only when pressed together (World::firstContactIf).
        if (hit.impact.initially_touching) {
          const Eigen::Vector3d p = hit.impact.point;
          const Eigen::Vector3d closing =
              brute.motion(hit.a).velocityOfPoint(p, t0) - brute.motion(hit.b).velocityOfPoint(p, t0);
          if (closing.dot(hit.impact.normal) <= 0.0) continue;
        }
        first = std::min(first, hit.impact.time);
      }
      return first;
    };
    auto gateContact = [&](double s) {
      const auto hit = gate_world.firstContactIf(links, robot.motions(s, t0), t0, window);
      return hit ? hit->impact.time : kInf;
    };
    // The same from one reachable set for every scale: each link's origin travels at most
    // window * max(|v(0)|, |v(1)|) (a constant twist keeps its origin's speed).
    std::vector<Eigen::Vector3d> origins;
    std::vector<double> reach;
    const std::vector<Motion> at0 = robot.motions(0.0, t0), at1 = robot.motions(1.0, t0);
    for (size_t i = 0; i < links.size(); ++i) {
      origins.push_back(at1[i].positionAt(t0));
      reach.push_back(window * std::max(at0[i].velocityOfPoint(origins[i], t0).norm(),
                                        at1[i].velocityOfPoint(origins[i], t0).norm()));
    }
    const World::Reachable among = gate_world.reachable(links, origins, reach, t0, window);
    auto reachContact = [&](double s) {
      const auto hit = gate_world.firstContactIf(links, robot.motions(s, t0), t0, window, {}, &among);
      return hit ? hit->impact.time : kInf;
    };
    for (double s : {0.0, 0.25, 0.5, 0.75, 1.0}) {
      const double a = gateContact(s), b = reachContact(s);
      if (std::isinf(a)) {
        EXPECT_TRUE(std::isinf(b)) << "seed " << seed << " s " << s;
      } else {
        EXPECT_NEAR(a, b, 1e-12) << "seed " << seed << " s " << s;
      }
    }
    const GateScale g = searchGateScale(gateContact);
    // The same search over the brute-force contacts must give the same answer, and every
    // contact time on the way must agree.
    const GateScale want = searchGateScale(bruteContact);
    ++scenes;
    EXPECT_EQ(g.clear, want.clear) << "seed " << seed;
    EXPECT_NEAR(g.scale, want.scale, 1e-12) << "seed " << seed;
    EXPECT_EQ(g.evaluations, want.evaluations) << "seed " << seed;
    if (!g.clear) EXPECT_NEAR(g.contact_time, want.contact_time, testing_compare::kContactTime) << "seed " << seed;
    for (double s : {0.0, 0.37, 1.0}) {
      const double a = gateContact(s), b = bruteContact(s);
      if (std::isinf(b)) {
        EXPECT_TRUE(std::isinf(a)) << "seed " << seed << " s " << s;
      } else {
        ++contacts;
        EXPECT_NEAR(a, b, testing_compare::kContactTime) << "seed " << seed << " s " << s;
      }
    }
    // The fine grid (step 0.001): the largest clear scale lies within one step of the answer
    // unless the clear scales above it form a band thinner than the step.
    if (g.clear) {
      ++clear_scenes;
      if (g.scale < 1.0) ++partial;
      double top = g.scale;
      for (int k = 1000; k >= 0; --k) {
        const double s = k / 1000.0;
        if (s <= g.scale) break;
        if (std::isinf(bruteContact(s))) {
          top = s;
          break;
        }
      }
      if (top - g.scale > 0.02 + 1e-9) {
        ++thin;
        // Then the clear band above must be thin: its grid neighbours are blocked.
        EXPECT_FALSE(std::isinf(bruteContact(std::ceil(top / 0.02) * 0.02))) << "seed " << seed;
      }
    } else {
      ++blocked_scenes;
    }
  }
  // Not vacuous: full-speed, slowed and blocked commands all occur.
  EXPECT_GT(partial, 3u);
  EXPECT_GT(clear_scenes - partial, 3u);
  std::printf("%zu scenes: %zu clear (%zu slowed, %zu thin bands), %zu blocked, %zu contacts compared\n", scenes,
              clear_scenes, partial, thin, blocked_scenes, contacts);
}

TEST(WorldFirstContactIf, BadInputThrowsAndChangesNothing) {
  World w;
  w.add("a", makeSphere(0.5), makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}));
  w.add("b", makeSphere(0.5), makeMotion({3, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}), 7);
  const Motion go = makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {2, 0, 0}, {0, 0, 0});
  EXPECT_THROW(w.firstContactIf({"zz"}, {go}, 0.0, 1.0), InvalidArgument);
  EXPECT_THROW(w.firstContactIf({"a"}, {}, 0.0, 1.0), InvalidArgument);
  EXPECT_THROW(w.firstContactIf({"a", "a"}, {go, go}, 0.0, 1.0), InvalidArgument);
  EXPECT_THROW(w.firstContactIf({"a"}, {go}, NAN, 1.0), InvalidArgument);
  EXPECT_THROW(w.firstContactIf({"a"}, {go}, 0.0, -1.0), InvalidArgument);
  Motion bad = go;
  bad.linear_velocity.x() = NAN;
  EXPECT_THROW(w.firstContactIf({"a"}, {bad}, 0.0, 1.0), InvalidArgument);
  // The candidate motion reaches b at t = 1; the world's own motions are untouched.
  const auto hit = w.firstContactIf({"a"}, {go}, 0.0, 2.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->other, "b");
  EXPECT_NEAR(hit->impact.time, 1.0, 1e-6);
  EXPECT_EQ(w.motion("a").linear_velocity, Eigen::Vector3d::Zero());
  EXPECT_TRUE(w.predict(0.0, 2.0).empty());
  // A skipped body (by its caller's key, add's `user`) is not considered.
  EXPECT_FALSE(w.firstContactIf({"a"}, {go}, 0.0, 2.0, [&](uint64_t user) { return user == 7; }).has_value());
}

// A body touching a wall: moving away or sliding along it is not a contact for the gate;
// pressing into it is, at once.
TEST(WorldFirstContactIf, TouchingBlocksOnlyWhenPressedTogether) {
  World w;
  const Motion still = makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}, 0.0);
  w.add("wall", makeBox({1.0, 4.0, 1.0}), still);                      // faces at x = +-0.5
  w.add("robot", makeSphere(0.5), makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}, 0.0));
  w.predict(0.0, 2.0);
  auto moving = [](const Eigen::Vector3d& v) {
    return makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), v, {0, 0, 0}, 0.0);
  };
  EXPECT_FALSE(w.firstContactIf({"robot"}, {moving({1, 0, 0})}, 0.0, 1.0));   // away
  EXPECT_FALSE(w.firstContactIf({"robot"}, {moving({0, 1, 0})}, 0.0, 1.0));   // along
  const auto into = w.firstContactIf({"robot"}, {moving({-1, 0, 0})}, 0.0, 1.0);
  ASSERT_TRUE(into);
  EXPECT_EQ(into->other, "wall");
  EXPECT_NEAR(into->impact.time, 0.0, 1e-9);
  // Standing still against it: not pressed, not blocked.
  EXPECT_FALSE(w.firstContactIf({"robot"}, {moving({0, 0, 0})}, 0.0, 1.0));
  // A box flush against the wall turning in place digs a corner in, whichever way it turns and
  // wherever the witness of the face contact lies (its closing speed may be <= 0 there); a
  // cylinder turning in place does not.
  w.remove("robot");
  w.add("robot", makeBox({1.0, 1.0, 1.0}), makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}, 0.0));
  for (double turn : {1.0, -1.0}) {
    const Motion turning = makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, turn}, 0.0);
    const auto dig = w.firstContactIf({"robot"}, {turning}, 0.0, 1.0);
    ASSERT_TRUE(dig) << "turning at " << turn << " rad/s";
    EXPECT_NEAR(dig->impact.time, 0.0, 1e-9);
  }
  w.remove("robot");
  w.add("robot", makeCylinder(0.5, 1.0), makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 0}, 0.0));
  EXPECT_FALSE(w.firstContactIf(
      {"robot"}, {makeMotion({1.0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 1.0}, 0.0)}, 0.0, 1.0));
}

}  // namespace
}  // namespace vadop
