// World: the pipeline (broad phase + narrow phase) behind vadop_predict.
//  - analytic scenes (head-on spheres, touching at t0, a = the body added first);
//  - add/remove/setMotion errors name the body and leave the world unchanged;
//  - the broad phases vadop, vadop_sap, sap and brute give identical results on random 1,000-body scenes;
//  - the incremental broad phase, fed many predicts with setMotion/add/remove in between,
//    agrees with a world built from scratch each time;
#include "vadop/error.h"
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include "world_scene_gen.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <algorithm>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace vadop {
namespace {

Motion moving(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t_ref = 0.0) {
  return makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero(), t_ref);
}
Motion still(const Eigen::Vector3d& p) { return moving(p, Eigen::Vector3d::Zero()); }

// The tolerance of the narrow phase: an impact is reported when the gap reaches tol/2, so
// head-on bodies closing at speed s are reported tol / (2 s) before they touch.
const double kTol = ToiOptions{}.tolerance;

TEST(World, HeadOnSpheres) {
  World w;
  w.add("left", makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  w.add("right", makeSphere(0.25), moving({4, 0, 0}, {-2, 0, 0}));
  w.add("far", makeSphere(0.5), still({0, 50, 0}));
  const auto out = w.predict(0.0, 2.0);
  ASSERT_EQ(out.size(), 1u);
  // Gap 4 - 0.75 = 3.25 closing at 3 m/s: touch at 13/12 s.
  const double t = 13.0 / 12.0 - kTol / (2 * 3.0);
  EXPECT_EQ(out[0].a, "left");
  EXPECT_EQ(out[0].b, "right");
  EXPECT_NEAR(out[0].impact.time, t, 1e-12);
  // Contact point: between the surfaces, at x = t + 0.5 (left) and 4 - 2t - 0.25 (right).
  EXPECT_NEAR(out[0].impact.point.x(), 0.5 * ((t + 0.5) + (4 - 2 * t - 0.25)), 1e-12);
  EXPECT_NEAR(out[0].impact.point.y(), 0.0, 1e-15);
  EXPECT_NEAR((out[0].impact.normal - Eigen::Vector3d::UnitX()).norm(), 0.0, 1e-15);
  EXPECT_LT(out[0].a_key, out[0].b_key);
  EXPECT_EQ(w.lastCandidateCount(), 1u);

  // A window that ends before the contact finds nothing; one that starts after t0 = 0 does.
  EXPECT_TRUE(w.predict(0.0, 1.0).empty());
  const auto later = w.predict(1.0, 0.5);
  ASSERT_EQ(later.size(), 1u);
  EXPECT_NEAR(later[0].impact.time, t, 1e-12);
}

// A shape prepared once (prepareShape, or another World's prepared()) enters several Worlds
// without being prepared again: they share its data, and predict as with the shape itself.
TEST(World, APreparedShapeIsSharedAndPredictsAsTheShape) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 500; ++i) points.emplace_back(3.0, -2.5 + 0.01 * i, 0.0);
  const Shape wall = makePointSet(points, 0.02);
  World plain, first, second;
  plain.add("wall", wall, still({0, 0, 0}));
  first.add("wall", prepareShape(wall), still({0, 0, 0}));
  second.add("wall", first.prepared("wall"), still({0, 0, 0}));
  EXPECT_EQ(&first.shape("wall"), &second.shape("wall"));  // one prepared shape, not a copy
  EXPECT_NE(&plain.shape("wall"), &first.shape("wall"));
  for (World* w : {&plain, &first, &second}) w->add("ball", makeSphere(0.2), moving({0, 0.013, 0}, {1, 0, 0}));
  const auto expected = plain.predict(0.0, 4.0);
  ASSERT_EQ(expected.size(), 1u);
  for (World* w : {&first, &second}) {
    const auto got = w->predict(0.0, 4.0);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].impact.time, expected[0].impact.time);
    EXPECT_EQ(got[0].impact.point, expected[0].impact.point);
  }
  // Refused as any add: no shape, a used id, a bad motion; the world unchanged.
  EXPECT_THROW(first.add("none", std::shared_ptr<const vadop::PreparedShape>(), still({0, 0, 0})), InvalidArgument);
  EXPECT_THROW(first.add("wall", first.prepared("wall"), still({0, 0, 0})), InvalidArgument);
  Motion bad = still({0, 0, 0});
  bad.linear_velocity.x() = NAN;
  EXPECT_THROW(first.add("w2", first.prepared("wall"), bad), InvalidArgument);
  EXPECT_THROW(first.prepared("unknown"), InvalidArgument);
  EXPECT_EQ(first.size(), 2u);
}

// A contact's closing speed, (v_a - v_b) . normal at its point and time, follows each body's
// own motion, path or chain: the head-on pair closes at 1 + 2 m/s whether the two move with
// one motion each or along paths; a body turning about its origin closes at w x r there.
TEST(World, ContactsCarryTheClosingSpeedOfTheirBodies) {
  World w;
  w.add("left", makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  w.add("right", makeSphere(0.25), moving({4, 0, 0}, {-2, 0, 0}));
  auto out = w.predict(0.0, 2.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].closing_speed, 3.0, 1e-12);
  // The same bodies on paths: at rest as set, moving along their paths (the paths' velocities).
  w.setMotion("left", still({0, 0, 0}));
  w.setMotion("right", still({4, 0, 0}));
  w.setPath("left", TimedPath(moving({0, 0, 0}, {1, 0, 0})));
  w.setPath("right", TimedPath(moving({4, 0, 0}, {-2, 0, 0})));
  out = w.predict(0.0, 2.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].closing_speed, 3.0, 1e-9);
  // A bar turning at 1 rad/s about the z axis through its centre sweeps into a block at rest
  // 1.5 m along +x from y < 0: the bar's point at the contact moves at w x r (r from the axis).
  World turn;
  turn.add("bar", makeBox(Eigen::Vector3d(4, 0.1, 0.1)),
           makeMotion({0, 0, 0}, Eigen::Quaterniond(Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitZ())), {0, 0, 0},
                      {0, 0, 1}));
  turn.add("block", makeBox(Eigen::Vector3d(0.2, 0.2, 0.2)), still({1.5, 0.2, 0}));
  const auto swept = turn.predict(0.0, 1.0);
  ASSERT_EQ(swept.size(), 1u);
  const Contact& c = swept[0];
  const Eigen::Vector3d v_bar = Eigen::Vector3d::UnitZ().cross(c.impact.point);  // the block stands
  EXPECT_NEAR(c.closing_speed, v_bar.dot(c.impact.normal), 1e-12);
  EXPECT_GT(c.closing_speed, 0.5);  // pressing together, not sliding
}

// A world emptied after a predict, then holding path bodies only (whose predicts leave the
// broad phase alone), then a body of one motion again: each predict answers for the bodies it
// holds now, never for pairs of an earlier one (an emptied world once read the broad phase's
// pairs of the last update: "unknown body id 0").
TEST(World, EmptiedWorldsAndWorldsOfPathBodiesPredictWhatTheyHold) {
  for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap,
                                    BroadPhaseKind::kGrid, BroadPhaseKind::kBrute}) {
    WorldConfig c;
    c.broad_phase = kind;
    World w(c);
    w.add("left", makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
    w.add("right", makeSphere(0.25), moving({4, 0, 0}, {-2, 0, 0}));
    ASSERT_EQ(w.predict(0.0, 2.0).size(), 1u) << toString(kind);
    w.remove("left");
    w.remove("right");
    EXPECT_TRUE(w.predict(0.0, 2.0).empty()) << toString(kind);
    EXPECT_TRUE(w.predict(0.0, 0.0).empty()) << toString(kind);
    // Two bodies on paths meeting head on (as above), alone in the world.
    w.add("a", makeSphere(0.5), still({0, 0, 0}));
    w.add("b", makeSphere(0.25), still({4, 0, 0}));
    w.setPath("a", TimedPath(moving({0, 0, 0}, {1, 0, 0})));
    w.setPath("b", TimedPath(moving({4, 0, 0}, {-2, 0, 0})));
    const auto paths = w.predict(0.0, 2.0);
    ASSERT_EQ(paths.size(), 1u) << toString(kind);
    EXPECT_NEAR(paths[0].impact.time, 13.0 / 12.0 - kTol / 6.0, 1e-9) << toString(kind);
    // A body of one motion joins, catching up with "a" from behind (gap 1 m closing at 1 m/s:
    // before "b" meets it).
    w.add("c", makeSphere(0.5), moving({-2, 0, 0}, {2, 0, 0}));
    const auto mixed = w.predict(0.0, 2.0);
    ASSERT_FALSE(mixed.empty()) << toString(kind);
    EXPECT_EQ(mixed[0].a, "a") << toString(kind);
    EXPECT_EQ(mixed[0].b, "c") << toString(kind);
    EXPECT_NEAR(mixed[0].impact.time, 1.0 - kTol / 2.0, 1e-9) << toString(kind);
  }
}

// A motion that does not turn moves its origin whatever its pivot_offset (Motion::centreAt):
// every broad phase, with and without the time-slice cull, bounds the body where it is, not
// about the unused pivot (the swept boxes once were centred on position + pivot_offset and
// this contact was culled).
TEST(World, AMotionThatDoesNotTurnIgnoresItsPivotOffset) {
  for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap,
                                    BroadPhaseKind::kGrid, BroadPhaseKind::kBrute}) {
    for (const int slices : {1, 8}) {
      WorldConfig c;
      c.broad_phase = kind;
      c.time_slices = slices;
      World w(c);
      Motion left = moving({0, 0, 0}, {1, 0, 0});
      left.pivot_offset = Eigen::Vector3d(0, 30, 0);  // ignored: no angular velocity
      w.add("left", makeBox({1, 1, 1}), left);
      w.add("right", makeSphere(0.25), moving({4, 0, 0}, {-2, 0, 0}));
      const auto out = w.predict(0.0, 2.0);
      ASSERT_EQ(out.size(), 1u) << toString(kind) << " slices " << slices;
      // Gap 4 - 0.5 - 0.25 = 3.25 closing at 3 m/s, as HeadOnSpheres.
      EXPECT_NEAR(out[0].impact.time, 13.0 / 12.0 - kTol / 6.0, 1e-9) << toString(kind) << " slices " << slices;
    }
  }
}

TEST(World, PairsTouchingAtTheStartHaveTimeT0) {
  World w;
  w.add("a", makeBox({1, 1, 1}), still({0, 0, 0}));
  w.add("b", makeSphere(0.5), still({0.9, 0, 0}));  // overlapping the box
  w.add("c", makeSphere(0.5), moving({0.9, 0, 0}, {0, 1, 0}));  // overlapping both, leaving along y
  w.add("d", makeCapsule(0.2, 1.0), moving({5, 0, 0}, {0, 0, 1}));
  const auto now = w.predict(0.0, 1.0);
  ASSERT_EQ(now.size(), 3u);
  for (const auto& x : now) {
    EXPECT_EQ(x.impact.time, 0.0);
    EXPECT_TRUE(x.impact.initially_touching);
  }
  EXPECT_EQ(now[0].a + now[0].b, "ab");
  EXPECT_EQ(now[1].a + now[1].b, "ac");
  EXPECT_EQ(now[2].a + now[2].b, "bc");
  EXPECT_GT(now[0].impact.normal.x(), 0.5);  // from a (the box) towards b
  // Later windows: t0 is the time of the pairs touching at their start, whatever t0 is; the
  // sphere c has left (1 m/s along y) by t0 = 2.
  const auto later = w.predict(2.0, 1.0);
  ASSERT_EQ(later.size(), 1u);
  EXPECT_EQ(later[0].a + later[0].b, "ab");
  EXPECT_EQ(later[0].impact.time, 2.0);
}

TEST(World, AIsTheBodyAddedFirstEvenWhenIdsAreReused) {
  World w;
  w.add("x", makeSphere(0.5), still({100, 0, 0}));
  w.add("y", makeSphere(0.5), still({0, 0, 0}));
  w.remove("x");  // frees the broad phase's slot 0, which "z" then takes
  w.add("z", makeSphere(0.5), moving({3, 0, 0}, {-1, 0, 0}));
  EXPECT_LT(w.key("y"), w.key("z"));
  EXPECT_EQ(w.ids(), (std::vector<std::string>{"y", "z"}));
  const auto out = w.predict(0.0, 5.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].a, "y");
  EXPECT_EQ(out[0].b, "z");
  EXPECT_GT(out[0].impact.normal.x(), 0.99);  // from y (at 0) to z (coming from +x)
  // Removed and added again: a new key, after every other body.
  w.remove("y");
  w.add("y", makeSphere(0.5), still({0, 0, 0}));
  const auto again = w.predict(0.0, 5.0);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].a, "z");
  EXPECT_LT(again[0].impact.normal.x(), -0.99);
}

TEST(World, SortsByTimeThenInsertionOrder) {
  World w;
  // Three pairs touching at t0 (ties) and two later contacts, added in a scrambled order.
  w.add("p", makeSphere(1.0), still({0, 0, 0}));
  w.add("q", makeSphere(1.0), still({20, 0, 0}));
  w.add("r", makeSphere(1.0), still({1.5, 0, 0}));   // touches p
  w.add("s", makeSphere(1.0), still({21, 0, 0}));    // touches q
  w.add("t", makeSphere(1.0), moving({0, 10, 0}, {0, -4, 0}));  // reaches p at ~2 s
  w.add("u", makeSphere(1.0), moving({20, 5, 0}, {0, -4, 0}));  // reaches q at ~0.75 s
  w.add("v", makeSphere(1.0), still({0.5, 1.5, 0}));  // touches p and r
  const auto out = w.predict(0.0, 3.0);
  std::vector<std::string> got;
  for (const auto& x : out) got.push_back(x.a + "-" + x.b);
  // Keys p0 q1 r2 s3 t4 u5 v6. At t0 four pairs touch: ties in key order (p,r) (p,v) (q,s)
  // (r,v). Then u comes down on q (gap 3 at 4 m/s: 0.75 s) and s (|(1, 5 - 4t)| = 2: 0.817 s);
  // t comes down on v (|(0.5, 8.5 - 4t)| = 2: 1.641 s), p (2 s) and r (|(1.5, 10 - 4t)| = 2: 2.169 s).
  EXPECT_EQ(got, (std::vector<std::string>{"p-r", "p-v", "q-s", "r-v", "q-u", "s-u", "t-v", "p-t", "r-t"}));
  ASSERT_EQ(out.size(), 9u);
  EXPECT_NEAR(out[4].impact.time, 0.75, 1e-6);
  EXPECT_NEAR(out[5].impact.time, (5 - std::sqrt(3.0)) / 4, 1e-6);
  EXPECT_NEAR(out[6].impact.time, (8.5 - std::sqrt(3.75)) / 4, 1e-6);
  EXPECT_NEAR(out[7].impact.time, 2.0, 1e-6);
  EXPECT_NEAR(out[8].impact.time, (10 - std::sqrt(1.75)) / 4, 1e-6);
  for (size_t i = 1; i < out.size(); ++i) EXPECT_LE(out[i - 1].impact.time, out[i].impact.time);
}

TEST(World, BadInputNamesTheBodyAndLeavesTheWorldUnchanged) {
  World w;
  w.add("a", makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  w.add("b", makeSphere(0.5), still({3, 0, 0}));
  const auto before = impactsToJsonLines(w.predict(0.0, 5.0));
  ASSERT_FALSE(before.empty());
  const double nan = std::numeric_limits<double>::quiet_NaN();

  auto expectError = [&](auto&& call, const std::string& needle1, const std::string& needle2) {
    try {
      call();
      ADD_FAILURE() << "no exception; expected one mentioning " << needle1;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(needle1), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle2), std::string::npos) << e.what();
    }
    EXPECT_EQ(w.size(), 2u);
    EXPECT_EQ(w.ids(), (std::vector<std::string>{"a", "b"}));
    EXPECT_EQ(impactsToJsonLines(w.predict(0.0, 5.0)), before);
  };
  Shape bad_sphere = makeSphere(1.0);
  bad_sphere.radius = -1.0;
  Motion nan_motion = still({0, 0, 0});
  nan_motion.linear_velocity.y() = nan;
  expectError([&] { w.add("a", makeSphere(1.0), still({9, 9, 9})); }, "\"a\"", "already exists");
  expectError([&] { w.add("", makeSphere(1.0), still({9, 9, 9})); }, "id", "empty");
  expectError([&] { w.add("c", bad_sphere, still({9, 9, 9})); }, "\"c\"", "radius");
  expectError([&] { w.add("c", makeSphere(1.0), nan_motion); }, "\"c\"", "linear_velocity");
  expectError([&] { w.remove("nope"); }, "\"nope\"", "unknown");
  expectError([&] { w.setMotion("nope", still({0, 0, 0})); }, "\"nope\"", "unknown");
  expectError([&] { w.setMotion("b", nan_motion); }, "\"b\"", "linear_velocity");
  expectError([&] { w.motion("nope"); }, "\"nope\"", "unknown");
  expectError([&] { w.predict(nan, 1.0); }, "t0", "finite");
  expectError([&] { w.predict(0.0, -1.0); }, "horizon", ">= 0");
  expectError([&] { w.predict(0.0, 1.0, {"a", "nope"}); }, "\"nope\"", "unknown");
  // A motion that leaves the range (error.h, kMaxReach) within the window: rejected by
  // predict, naming the body. (A velocity of 1e300 m/s is now rejected by add itself.)
  w.add("fast", makeSphere(1.0), moving({0, 0, 0}, {kMaxLinearSpeed, 0, 0}));
  try {
    w.predict(0.0, 1e4);
    ADD_FAILURE() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("\"fast\""), std::string::npos) << e.what();
  }
  w.remove("fast");
  EXPECT_EQ(impactsToJsonLines(w.predict(0.0, 5.0)), before);
  // Bad configurations.
  WorldConfig c;
  c.vadop.axes = 2;
  EXPECT_THROW(World{c}, InvalidArgument);
  c = WorldConfig{};
  c.vadop.phi_deg = 1.0;  // below the covering radius of 32 axes
  EXPECT_THROW(World{c}, InvalidArgument);
  c = WorldConfig{};
  c.toi.tolerance = 0.0;
  EXPECT_THROW(World{c}, InvalidArgument);
  // The VADOP settings matter (and are checked) for the VADOP broad phase only.
  c = WorldConfig{};
  c.broad_phase = BroadPhaseKind::kSap;
  c.vadop.axes = 2;
  EXPECT_NO_THROW(World{c});
}

// Issue 13, defect 5: a bar spinning 1 cm clear of another body. Conservative advancement
// used to run out of its budget and report a contact (at t = 42.8 s and 0.856 s for the block,
// 1.19 s for the ball at 1,000 rad/s), and only for the broad phases that list the pair: brute
// force (swept bounding spheres) drops the ball, so the output depended on the broad phase.
// Now: no contact and nothing undecided, whatever the broad phase.
TEST(World, FastSpinnersGiveNoContactForEveryBroadPhase) {
  const double reach = std::hypot(1.0, 0.05);  // the bar's corners in the xy plane
  struct SpinCase {
    double w, horizon;
    bool ball;  // the other body: a ball of radius 0.1, or a 0.2 m block
  };
  for (const SpinCase& c : {SpinCase{20.0, 60.0, false}, SpinCase{1000.0, 10.0, false}, SpinCase{20.0, 60.0, true},
                            SpinCase{1000.0, 10.0, true}}) {
    for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap, BroadPhaseKind::kGrid,
                                      BroadPhaseKind::kBrute}) {
      WorldConfig config;
      config.broad_phase = kind;
      World w(config);
      w.add("bar", makeBox(Eigen::Vector3d(2, 0.1, 0.1)),
            makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, c.w}));
      w.add("other", c.ball ? makeSphere(0.1) : makeBox(Eigen::Vector3d(0.2, 0.2, 0.2)),
            still({0, reach + 0.01 + 0.1, 0}));
      const auto start = std::chrono::steady_clock::now();
      const auto out = w.predict(0.0, c.horizon);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      EXPECT_EQ(impactsToJsonLines(out), "") << toString(kind) << " w = " << c.w << (c.ball ? " ball" : " block");
      EXPECT_TRUE(w.lastUndecided().empty()) << toString(kind) << " w = " << c.w;
      std::printf("%-9s w = %4g rad/s, %s: %zu candidate(s), %.3f ms\n", toString(kind), c.w, c.ball ? "ball " : "block",
                  w.lastCandidateCount(), ms);
    }
  }
}

// Undecided pairs are neither contacts nor misses: predict leaves them out, lastUndecided
// lists them (same order as predict's result), the same for every broad phase.
TEST(World, UndecidedPairsAreListedApartFromContacts) {
  std::vector<std::string> first;
  for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap, BroadPhaseKind::kGrid,
                                    BroadPhaseKind::kBrute}) {
    WorldConfig config;
    config.broad_phase = kind;
    config.toi.max_iterations = 1;  // too small for a turning pair
    World w(config);
    // A spinning bar with a block 5 mm inside its reach (a contact after about 0.07 s, which
    // one step cannot find), a second such pair later in the window, and two spheres that
    // meet head-on at t = 1 (closed form: one evaluation, decided).
    const double reach = std::hypot(1.0, 0.05);
    const Motion spin = makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 20});
    w.add("bar", makeBox(Eigen::Vector3d(2, 0.1, 0.1)), spin);
    w.add("block", makeBox(Eigen::Vector3d(0.2, 0.2, 0.2)), still({0, reach - 0.005 + 0.1, 0}));
    w.add("left", makeSphere(0.5), moving({0, 10, 0}, {1, 0, 0}));
    w.add("right", makeSphere(0.5), moving({3, 10, 0}, {-1, 0, 0}));
    Motion spin2 = spin;
    spin2.position = {0, -10, 0};
    w.add("bar2", makeBox(Eigen::Vector3d(2, 0.1, 0.1)), spin2);
    w.add("block2", makeBox(Eigen::Vector3d(0.2, 0.2, 0.2)), still({0, -10 - reach + 0.005 - 0.1, 0}));
    const auto out = w.predict(0.0, 2.0);
    ASSERT_EQ(out.size(), 1u) << toString(kind);
    EXPECT_EQ(out[0].a + "-" + out[0].b, "left-right");
    EXPECT_NEAR(out[0].impact.time, 1.0, 1e-6);
    EXPECT_NEAR(out[0].closing_speed, 2.0, 1e-12);
    const auto& und = w.lastUndecided();
    ASSERT_EQ(und.size(), 2u) << toString(kind);
    std::vector<std::string> names;
    for (size_t i = 0; i < und.size(); ++i) {
      EXPECT_FALSE(und[i].impact.hit);
      EXPECT_TRUE(und[i].impact.undecided);
      EXPECT_GT(und[i].impact.time, 0.0);
      EXPECT_LT(und[i].impact.time, 0.08);  // certified clear only up to there, before the contact
      EXPECT_EQ(und[i].closing_speed, 0.0);   // not a contact: no closing speed
      if (i > 0) {
        EXPECT_TRUE(und[i - 1].impact.time < und[i].impact.time ||
                    (und[i - 1].impact.time == und[i].impact.time && und[i - 1].a_key < und[i].a_key));
      }
      names.push_back(und[i].a + "-" + und[i].b + "@" + formatNumber(und[i].impact.time));
    }
    if (first.empty()) {
      first = names;
    } else {
      EXPECT_EQ(names, first) << toString(kind);
    }
    // The next predict replaces the list.
    w.remove("bar");
    w.remove("bar2");
    EXPECT_EQ(w.predict(0.0, 2.0).size(), 1u);
    EXPECT_TRUE(w.lastUndecided().empty());
  }
}

// Issue 14, item 5: pair filters before the narrow phase (group/mask bits and a predicate by
// keys). Six spheres in one cluster (every pair touches at t0): filtered pairs cost no
// narrow-phase call, are not returned, and the result is the same for every broad phase.
TEST(World, PairFiltersApplyBeforeTheNarrowPhase) {
  std::vector<std::string> first;
  for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap, BroadPhaseKind::kGrid,
                                    BroadPhaseKind::kBrute}) {
    WorldConfig config;
    config.broad_phase = kind;
    World w(config);
    // The caller's keys (add's `user`) in insertion order: si has user i.
    for (int i = 0; i < 6; ++i) w.add("s" + std::to_string(i), makeSphere(1.0), still({0.1 * i, 0.05 * i, 0}), i);
    EXPECT_EQ(w.predict(0.0, 1.0).size(), 15u) << toString(kind);
    EXPECT_EQ(w.lastCandidateCount(), 15u) << toString(kind);
    // s0..s2: a group that does not collide with itself (as static obstacles).
    for (int i = 0; i < 3; ++i) w.setFilter("s" + std::to_string(i), 2u, ~2u);
    EXPECT_EQ(w.predict(0.0, 1.0).size(), 12u) << toString(kind);
    EXPECT_EQ(w.lastCandidateCount(), 12u) << toString(kind);
    // s5: a mask of 0 collides with nothing, whatever the others' masks.
    w.setFilter("s5", World::kDefaultGroup, 0u);
    EXPECT_EQ(w.predict(0.0, 1.0).size(), 7u) << toString(kind);
    EXPECT_EQ(w.lastCandidateCount(), 7u) << toString(kind);
    // The predicate sees the pairs that pass the masks, once each, the caller's keys in the
    // bodies' insertion order; s3-s4 out.
    const uint64_t k3 = 3, k4 = 4;
    size_t seen = 0;
    w.setPairFilter([&](uint64_t a, uint64_t b) {
      ++seen;
      EXPECT_LT(a, b);
      return !(a == k3 && b == k4);
    });
    const auto out = w.predict(0.0, 1.0);
    EXPECT_EQ(seen, 7u) << toString(kind);
    ASSERT_EQ(out.size(), 6u) << toString(kind);
    EXPECT_EQ(w.lastCandidateCount(), 6u) << toString(kind);
    std::vector<std::string> names;
    for (const auto& x : out) names.push_back(x.a + "-" + x.b);
    EXPECT_EQ(names, (std::vector<std::string>{"s0-s3", "s0-s4", "s1-s3", "s1-s4", "s2-s3", "s2-s4"}))
        << toString(kind);
    if (first.empty()) first = names;
    EXPECT_EQ(names, first) << toString(kind);
    // An empty predicate tests every pair again; a body added again gets the default bits.
    w.setPairFilter(nullptr);
    w.remove("s5");
    w.add("s5", makeSphere(1.0), still({0.5, 0.25, 0}));
    EXPECT_EQ(w.predict(0.0, 1.0).size(), 12u) << toString(kind);
  }
}

// The pair predicate and a gate query's skip see the caller's keys (add's `user`), the pair's
// in the bodies' insertion order whatever the keys' values; bodies may share a key.
TEST(World, PairPredicateAndSkipSeeTheCallersKeys) {
  World w;
  w.add("first", makeSphere(1.0), still({0, 0, 0}), 9);
  w.add("second", makeSphere(1.0), still({0.5, 0, 0}), 2);
  w.add("third", makeSphere(1.0), still({0, 0.5, 0}), 2);
  std::vector<std::pair<uint64_t, uint64_t>> seen;
  w.setPairFilter([&](uint64_t a, uint64_t b) {
    seen.emplace_back(a, b);
    return b != 2 || a != 9;  // only second-third tested
  });
  const auto out = w.predict(0.0, 1.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].a + "-" + out[0].b, "second-third");
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<std::pair<uint64_t, uint64_t>>{{2, 2}, {9, 2}, {9, 2}}));
  // The gate query: the predicate applies, then skip by the others' keys.
  seen.clear();
  w.setPairFilter([&](uint64_t a, uint64_t b) {
    seen.emplace_back(a, b);
    return true;
  });
  // Touching at t0, a pair blocks only where the motions press it together: each mover heads
  // into the others.
  const Motion towards_third = moving({0.5, 0, 0}, {-1, 1, 0});
  const auto hit = w.firstContactIf({"second"}, {towards_third}, 0.0, 1.0, [](uint64_t user) { return user == 9; });
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->other, "third");
  EXPECT_EQ(hit->other_user, 2u);
  EXPECT_EQ(std::count(seen.begin(), seen.end(), std::make_pair(uint64_t{2}, uint64_t{2})), 1);
  EXPECT_EQ(std::count(seen.begin(), seen.end(), std::make_pair(uint64_t{2}, uint64_t{9})), 0);  // a added first
  const Motion towards_both = moving({0, 0, 0}, {1, 1, 0});
  EXPECT_TRUE(w.firstContactIf({"first"}, {towards_both}, 0.0, 1.0).has_value());
  EXPECT_FALSE(w.firstContactIf({"first"}, {towards_both}, 0.0, 1.0, [](uint64_t user) { return user == 2; }));
}

TEST(World, FilteredPairsAreNeverUndecided) {
  WorldConfig config;
  config.toi.max_iterations = 1;  // too small for a turning pair (UndecidedPairsAreListedApartFromContacts)
  World w(config);
  const double reach = std::hypot(1.0, 0.05);
  w.add("bar", makeBox(Eigen::Vector3d(2, 0.1, 0.1)),
        makeMotion({0, 0, 0}, Eigen::Quaterniond::Identity(), {0, 0, 0}, {0, 0, 20}));
  w.add("block", makeBox(Eigen::Vector3d(0.2, 0.2, 0.2)), still({0, reach - 0.005 + 0.1, 0}));
  w.predict(0.0, 2.0);
  ASSERT_EQ(w.lastUndecided().size(), 1u);
  w.setPairFilter([](uint64_t, uint64_t) { return false; });
  EXPECT_TRUE(w.predict(0.0, 2.0).empty());
  EXPECT_TRUE(w.lastUndecided().empty());
  EXPECT_EQ(w.lastCandidateCount(), 0u);
  w.setPairFilter(nullptr);
  w.setFilter("block", 4u, ~4u);
  w.setFilter("bar", 4u, ~4u);
  EXPECT_TRUE(w.predict(0.0, 2.0).empty());
  EXPECT_TRUE(w.lastUndecided().empty());
  EXPECT_EQ(w.lastCandidateCount(), 0u);
}

TEST(World, SetFilterOnAnUnknownBodyThrowsNamingItAndChangesNothing) {
  World w;
  w.add("a", makeSphere(1.0), still({0, 0, 0}));
  w.add("b", makeSphere(1.0), still({0.5, 0, 0}));
  try {
    w.setFilter("ghost\n", 0u, 0u);
    FAIL() << "no throw";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("setFilter"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ghost"), std::string::npos) << e.what();
  }
  EXPECT_EQ(w.predict(0.0, 1.0).size(), 1u);
  // Both directions are checked: a (added first) with mask 0 is tested against nothing.
  w.setFilter("a", World::kDefaultGroup, 0u);
  EXPECT_TRUE(w.predict(0.0, 1.0).empty());
  EXPECT_EQ(w.lastCandidateCount(), 0u);
  w.setFilter("a", World::kDefaultGroup, World::kDefaultMask);
  w.remove("b");
  EXPECT_THROW(w.setFilter("b", 0u, 0u), InvalidArgument);
  EXPECT_EQ(w.size(), 1u);
}

// Issue 13, defect 10: the range of error.h, inside and just beyond, in the library's own
// checks (add/setMotion through validateMotion, predict for the window and the reach).
TEST(World, RangeLimitsInsideAndJustBeyond) {
  const double up = 1.0 + 1e-12;
  World w;
  w.add("a", makeSphere(0.5), still({0, 0, 0}));
  auto expectRangeError = [&](const std::function<void()>& f, const std::string& needle) {
    try {
      f();
      ADD_FAILURE() << "no exception, expected one naming " << needle;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("beyond"), std::string::npos) << e.what();
    }
  };
  // The issue's 0.5 m boxes at x = 1e12 (reported touching at t = 0 before): refused.
  expectRangeError([&] { w.add("far", makeBox(Eigen::Vector3d(0.5, 0.5, 0.5)), still({1e12, 0, 0})); },
                   "position[0] = 1000000000000");
  expectRangeError([&] { w.add("far", makeSphere(1e149), still({0, 0, 0})); }, "sphere radius");
  // Position and pivot offset: kMaxCoordinate per coordinate.
  EXPECT_NO_THROW(w.add("edge", makeSphere(0.5), still({0, -kMaxCoordinate, 0})));
  expectRangeError([&] { w.add("out", makeSphere(0.5), still({0, kMaxCoordinate * up, 0})); }, "position[1]");
  Motion pivot = still({0, 0, 0});
  pivot.angular_velocity = {0, 0, 1};
  pivot.pivot_offset = {0, 0, kMaxCoordinate};
  EXPECT_NO_THROW(w.setMotion("edge", pivot));
  pivot.pivot_offset.z() *= up;
  expectRangeError([&] { w.setMotion("edge", pivot); }, "pivot_offset[2]");
  w.remove("edge");
  // Speeds.
  Motion m = moving({0, 0, 5}, {0, kMaxLinearSpeed, 0});
  EXPECT_NO_THROW(w.add("v", makeSphere(0.5), m));
  m.linear_velocity.y() *= up;
  expectRangeError([&] { w.setMotion("v", m); }, "|linear_velocity|");
  m = moving({0, 0, 5}, {0, 0, 0});
  m.angular_velocity = {kMaxAngularSpeed, 0, 0};
  EXPECT_NO_THROW(w.setMotion("v", m));
  m.angular_velocity.x() *= up;
  expectRangeError([&] { w.setMotion("v", m); }, "|angular_velocity|");
  m = moving({0, 0, 5}, {0, 0, 0}, -kMaxTime);
  EXPECT_NO_THROW(w.setMotion("v", m));
  m.t_ref *= up;
  expectRangeError([&] { w.setMotion("v", m); }, "t_ref");
  w.setMotion("v", still({0, 0, 5}));
  // The window: t0 and t0 + horizon within kMaxTime.
  EXPECT_NO_THROW(w.predict(kMaxTime - 1.0, 1.0));
  expectRangeError([&] { w.predict(kMaxTime * up, 0.0); }, "predict: t0");
  expectRangeError([&] { w.predict(kMaxTime - 1.0, 2.0); }, "predict: t0 + horizon");
  expectRangeError([&] { w.predict(-kMaxTime * up, 1.0); }, "predict: t0");
  // The reach: a body at kMaxCoordinate moving at 1e4 m/s reaches kMaxReach after 1,000 s.
  w.add("runner", makeSphere(0.5), moving({kMaxCoordinate, 0, 0}, {kMaxLinearSpeed, 0, 0}));
  EXPECT_NO_THROW(w.predict(0.0, 1000.0));
  expectRangeError([&] { w.predict(0.0, 1000.001); }, "\"runner\"");
  // ... and a turning body's origin, up to |pivot_offset| from its pivot.
  Motion arm = moving({kMaxCoordinate, 0, 0}, {kMaxLinearSpeed, 0, 0});
  arm.angular_velocity = {0, 0, 1};
  arm.pivot_offset = {0, 1.0, 0};
  w.setMotion("runner", arm);
  EXPECT_NO_THROW(w.predict(0.0, 999.9));
  expectRangeError([&] { w.predict(0.0, 1000.0); }, "position[0]");
  // Nothing changed by the refused calls.
  EXPECT_EQ(w.ids(), (std::vector<std::string>{"a", "v", "runner"}));
}

TEST(World, BroadPhaseKindNames) {
  EXPECT_EQ(parseBroadPhaseKind("vadop"), BroadPhaseKind::kVadop);
  EXPECT_EQ(parseBroadPhaseKind("vadop_sap"), BroadPhaseKind::kVadopSap);
  EXPECT_EQ(parseBroadPhaseKind("sap"), BroadPhaseKind::kSap);
  EXPECT_EQ(parseBroadPhaseKind("brute"), BroadPhaseKind::kBrute);
  EXPECT_EQ(parseBroadPhaseKind("grid"), BroadPhaseKind::kGrid);
  EXPECT_THROW(parseBroadPhaseKind("kdop"), InvalidArgument);
  for (auto k : {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap, BroadPhaseKind::kGrid,
                 BroadPhaseKind::kBrute}) {
    EXPECT_EQ(parseBroadPhaseKind(toString(k)), k);
  }
}

std::string predictLines(const Scene& scene, BroadPhaseKind kind, size_t* candidates = nullptr) {
  WorldConfig c;
  c.broad_phase = kind;
  World w(c);
  addToWorld(scene, w);
  const std::string out = impactsToJsonLines(w.predict(0.0, scene.horizon));
  if (candidates) *candidates = w.lastCandidateCount();
  return out;
}

TEST(World, BroadPhasesGiveIdenticalResultsOnRandomScenes) {
  size_t total_impacts = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const Scene scene = parseScene(testing_scene::randomSceneJson(seed));
    ASSERT_EQ(scene.bodies.size(), 1000u);
    size_t cand_vadop = 0, cand_vadop_sap = 0, cand_sap = 0, cand_grid = 0, cand_brute = 0;
    const std::string vadop = predictLines(scene, BroadPhaseKind::kVadop, &cand_vadop);
    const std::string vadop_sap = predictLines(scene, BroadPhaseKind::kVadopSap, &cand_vadop_sap);
    const std::string sap = predictLines(scene, BroadPhaseKind::kSap, &cand_sap);
    const std::string grid = predictLines(scene, BroadPhaseKind::kGrid, &cand_grid);
    const std::string brute = predictLines(scene, BroadPhaseKind::kBrute, &cand_brute);
    const size_t lines = static_cast<size_t>(std::count(vadop.begin(), vadop.end(), '\n'));
    EXPECT_GT(lines, 200u) << "seed " << seed << ": too few contacts to compare";
    EXPECT_EQ(vadop, vadop_sap) << "seed " << seed;
    EXPECT_EQ(vadop, sap) << "seed " << seed;
    EXPECT_EQ(vadop, grid) << "seed " << seed;
    EXPECT_EQ(vadop, brute) << "seed " << seed;
    // The plain grid and sweep and prune test the same swept AABBs: the same candidates.
    EXPECT_EQ(cand_grid, cand_sap) << "seed " << seed;
    // The broad phases differ (else the comparison would be vacuous).
    EXPECT_TRUE(cand_vadop != cand_sap || cand_sap != cand_brute);
    std::printf("seed %llu: 1000 bodies, %zu impacts; candidates vadop %zu, vadop_sap %zu, sap %zu, grid %zu, brute %zu\n",
                static_cast<unsigned long long>(seed), lines, cand_vadop, cand_vadop_sap, cand_sap, cand_grid, cand_brute);
    total_impacts += lines;
  }
  RecordProperty("impacts", static_cast<int>(total_impacts));
}

// The narrow phase on several threads: the same impacts (to the last bit), the same undecided
// pairs and candidate counts as on one, whatever the count; with `only` too.
TEST(World, ThreadsGiveIdenticalResults) {
  testing_scene::GenParams g;
  g.path_fraction = 0.05;
  for (uint64_t seed = 1; seed <= 1; ++seed) {
    const Scene scene = parseScene(testing_scene::randomSceneJson(seed, g));
    std::string reference, reference_only;
    size_t reference_candidates = 0, reference_undecided = 0;
    for (const int threads : {1, 2, 8, 0}) {
      WorldConfig c;
      c.threads = threads;
      c.toi.max_iterations = 3;  // some pairs undecided: they must match too
      World w(c);
      addToWorld(scene, w);
      const std::string lines = impactsToJsonLines(w.predict(0.0, scene.horizon));
      const std::string undecided = impactsToJsonLines(w.lastUndecided());
      const std::string only = impactsToJsonLines(w.predict(0.0, scene.horizon, w.ids()));
      if (threads == 1) {
        reference = lines + undecided;
        reference_only = only;
        reference_candidates = w.lastCandidateCount();
        reference_undecided = w.lastUndecided().size();
        EXPECT_GT(std::count(lines.begin(), lines.end(), '\n'), 100) << "seed " << seed;
        EXPECT_GT(reference_undecided, 0u) << "seed " << seed;
        continue;
      }
      EXPECT_EQ(lines + undecided, reference) << "seed " << seed << ", " << threads << " threads";
      EXPECT_EQ(only, reference_only) << "seed " << seed << ", " << threads << " threads";
      EXPECT_EQ(w.lastCandidateCount(), reference_candidates);
    }
  }
  WorldConfig bad;
  bad.threads = -1;
  EXPECT_THROW(World{bad}, InvalidArgument);
  bad.threads = kMaxThreads + 1;
  EXPECT_THROW(World{bad}, InvalidArgument);
}

TEST(World, IncrementalUpdatesMatchAWorldBuiltFromScratch) {
  // Frames of a random scene with velocity changes, removes and re-adds between predicts.
  testing_scene::GenParams p;
  p.n = 200;
  p.box = 6.0;
  const Scene scene = parseScene(testing_scene::randomSceneJson(11, p));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (auto kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kSap, BroadPhaseKind::kGrid, BroadPhaseKind::kBrute}) {
    WorldConfig c;
    c.broad_phase = kind;
    World inc(c);
    addToWorld(scene, inc);
    std::vector<SceneBody> current(scene.bodies.begin(), scene.bodies.end());  // in key order
    size_t compared = 0;
    for (int frame = 0; frame < 12; ++frame) {
      const double t0 = 0.1 * frame;
      // New velocities for a few bodies, from their pose at t0.
      for (int k = 0; k < 10; ++k) {
        SceneBody& b = current[rng() % current.size()];
        const Motion& m = b.motion;
        b.motion = makeMotion(m.positionAt(t0), m.orientationAt(t0), Eigen::Vector3d(u(rng), u(rng), u(rng)),
                              m.angular_velocity, t0);
        inc.setMotion(b.id, b.motion);
      }
      // Remove one body and add it back (it moves to the end of the insertion order).
      const size_t r = rng() % current.size();
      SceneBody moved = current[r];
      current.erase(current.begin() + static_cast<long>(r));
      inc.remove(moved.id);
      inc.add(moved.id, moved.shape, moved.motion);
      current.push_back(moved);

      World fresh(c);
      for (const auto& b : current) fresh.add(b.id, b.shape, b.motion);
      const auto got = inc.predict(t0, 0.1);
      const auto want = fresh.predict(t0, 0.1);
      ASSERT_EQ(impactsToJsonLines(got), impactsToJsonLines(want)) << toString(kind) << " frame " << frame;
      compared += got.size();
    }
    EXPECT_GT(compared, 50u) << toString(kind);
  }
}

// setMotion by handle is setMotion by name; a handle names only the body it was taken for:
// removed (and added again under its id), or of another World built the same way (same index
// and key), it is refused, and so is a bad motion, each changing nothing.
TEST(World, SetMotionByHandleIsByNameAndRefusesStaleHandles) {
  testing_scene::GenParams p;
  p.n = 200;
  p.box = 6.0;
  const Scene scene = parseScene(testing_scene::randomSceneJson(12, p));
  World by_name, by_handle, twin;
  addToWorld(scene, by_name);
  addToWorld(scene, by_handle);
  addToWorld(scene, twin);
  std::vector<World::Handle> handles;
  for (const auto& b : scene.bodies) handles.push_back(by_handle.handle(b.id));
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  size_t compared = 0;
  for (int frame = 0; frame < 10; ++frame) {
    const double t0 = 0.1 * frame;
    for (int k = 0; k < 20; ++k) {
      const size_t i = rng() % scene.bodies.size();
      const Motion& m = by_name.motion(scene.bodies[i].id);
      const Motion next = makeMotion(m.positionAt(t0), m.orientationAt(t0), Eigen::Vector3d(u(rng), u(rng), u(rng)),
                                     m.angular_velocity, t0);
      by_name.setMotion(scene.bodies[i].id, next);
      by_handle.setMotion(handles[i], next);
    }
    const auto want = by_name.predict(t0, 0.1);
    ASSERT_EQ(impactsToJsonLines(by_handle.predict(t0, 0.1)), impactsToJsonLines(want)) << "frame " << frame;
    compared += want.size();
  }
  EXPECT_GT(compared, 20u);

  const std::string id = scene.bodies[7].id;
  const Motion before = by_handle.motion(id);
  const Motion other = makeMotion(Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0),
                                  Eigen::Vector3d::Zero(), 0.0);
  // Another World's handle with the same index and key.
  const World::Handle twins = twin.handle(id);
  EXPECT_EQ(twins.index, handles[7].index);
  EXPECT_EQ(twins.key, handles[7].key);
  EXPECT_THROW(by_handle.setMotion(twins, other), InvalidArgument);
  // A bad motion: refused naming the body.
  Motion bad = other;
  bad.linear_velocity.x() = std::numeric_limits<double>::quiet_NaN();
  try {
    by_handle.setMotion(handles[7], bad);
    ADD_FAILURE() << "a NaN velocity was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("\"" + id + "\""), std::string::npos) << e.what();
  }
  EXPECT_EQ(by_handle.motion(id).position, before.position);
  EXPECT_EQ(by_handle.motion(id).linear_velocity, before.linear_velocity);
  // Removed, then added again under its id (it may take the same index): the old handle is stale.
  by_handle.remove(id);
  EXPECT_THROW(by_handle.setMotion(handles[7], other), InvalidArgument);
  by_handle.add(id, scene.bodies[7].shape, before);
  EXPECT_THROW(by_handle.setMotion(handles[7], other), InvalidArgument);
  EXPECT_EQ(by_handle.motion(id).position, before.position);
  by_handle.setMotion(by_handle.handle(id), other);
  EXPECT_EQ(by_handle.motion(id).position, other.position);
  EXPECT_THROW(by_handle.handle("no such body"), InvalidArgument);
  // A moved-from World knows no handle.
  World moved(std::move(by_handle));
  EXPECT_THROW(by_handle.setMotion(handles[3], other), InvalidArgument);  // NOLINT(bugprone-use-after-move)
  moved.setMotion(handles[3], other);
  EXPECT_EQ(moved.motion(scene.bodies[3].id).position, other.position);
}

TEST(World, PredictRestrictedToSomeBodiesIsTheFilteredFullPrediction) {
  const Scene scene = parseScene(testing_scene::randomSceneJson(4));
  World w;
  addToWorld(scene, w);
  const auto all = w.predict(0.0, scene.horizon);
  const std::vector<std::string> only{scene.bodies[3].id, scene.bodies[500].id, scene.bodies[999].id};
  std::vector<Contact> want;
  for (const auto& x : all) {
    for (const auto& id : only) {
      if (x.a == id || x.b == id) {
        want.push_back(x);
        break;
      }
    }
  }
  const auto got = w.predict(0.0, scene.horizon, only);
  EXPECT_EQ(impactsToJsonLines(got), impactsToJsonLines(want));
  EXPECT_LT(w.lastCandidateCount(), 100u);
  EXPECT_TRUE(w.predict(0.0, scene.horizon, {}).empty());
}

// A moved-from World answers as an empty one when asked by name, and refuses work it has no
// broad phase for with a clear error (no null dereference); assigned a World, it works again.
TEST(World, AMovedFromWorldHoldsNoBodies) {
  World w;
  w.add("a", makeSphere(0.5), Motion());
  World to(std::move(w));
  EXPECT_TRUE(to.contains("a"));
  EXPECT_EQ(to.size(), 1u);
  // NOLINTBEGIN(bugprone-use-after-move): the state after a move is the point
  EXPECT_EQ(w.size(), 0u);
  EXPECT_FALSE(w.contains("a"));
  EXPECT_TRUE(w.ids().empty());
  EXPECT_THROW(w.motion("a"), InvalidArgument);
  EXPECT_THROW(w.shape("a"), InvalidArgument);
  EXPECT_THROW(w.setMotion("a", Motion()), InvalidArgument);
  EXPECT_THROW(w.remove("a"), InvalidArgument);
  EXPECT_THROW(w.add("b", makeSphere(0.5), Motion()), InvalidArgument);
  EXPECT_THROW(w.predict(0.0, 1.0), InvalidArgument);
  EXPECT_THROW(w.predict(0.0, 1.0, {"a"}), InvalidArgument);
  w = std::move(to);
  EXPECT_TRUE(w.contains("a"));
  w.add("b", makeSphere(0.5), makeMotion(Eigen::Vector3d(3, 0, 0), Eigen::Quaterniond::Identity(),
                                         Eigen::Vector3d(-2, 0, 0), Eigen::Vector3d::Zero(), 0.0));
  EXPECT_EQ(w.predict(0.0, 2.0).size(), 1u);
  // NOLINTEND(bugprone-use-after-move)
}

}  // namespace
}  // namespace vadop
