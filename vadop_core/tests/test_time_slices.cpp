// World's time-slice cull (WorldConfig::time_slices): a candidate pair of the broad phase goes to
// the narrow phase only if the two bodies' swept boxes over one part of the window overlap.
// The cull must never change a result: property tests against the world without it (brute
// force broad phase), analytic corners at the parts' boundaries, and the configuration's range.
#include "vadop/error.h"
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include "world_scene_gen.h"

#include "impact_compare.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace vadop {
namespace {

using Eigen::Vector3d;

Motion moving(const Vector3d& p, const Vector3d& v) {
  return makeMotion(p, Eigen::Quaterniond::Identity(), v, Vector3d::Zero());
}

// A random dense scene over a 2 s window (the monitor's horizon, where paths cross at
// different times), half of the rotating bodies turning about a pivot off their origin.
struct SlicedScene {
  std::vector<std::string> ids;
  std::vector<Shape> shapes;
  std::vector<Motion> motions;
};

SlicedScene randomScene(uint64_t seed, int n = 400) {
  testing_scene::GenParams g;
  g.n = n;
  g.box = 7.0 * std::cbrt(n / 400.0);  // the same density
  g.max_speed = 2.0;
  g.rotating_fraction = 0.5;
  g.static_fraction = 0.1;
  g.horizon = 2.0;
  const Scene scene = parseScene(testing_scene::randomSceneJson(seed, g));
  std::mt19937_64 rng(seed * 7 + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  SlicedScene s;
  for (const SceneBody& b : scene.bodies) {
    Motion m = b.motion;
    if (m.isRotating() && rng() % 2 == 0) m.pivot_offset = Vector3d(u(rng), u(rng), u(rng));
    s.ids.push_back(b.id);
    s.shapes.push_back(b.shape);
    s.motions.push_back(m);
  }
  return s;
}

struct Outcome {
  std::string lines;  // impacts, then the undecided pairs
  size_t calls = 0, culled = 0;
};

// The scene in a world of that broad phase (some pairs undecided: they must match too).
std::unique_ptr<World> sceneWorld(const SlicedScene& s, BroadPhaseKind kind, int slices = 8, int threads = 1) {
  WorldConfig c;
  c.broad_phase = kind;
  c.time_slices = slices;
  c.threads = threads;
  c.toi.max_iterations = 300;
  auto w = std::make_unique<World>(c);
  for (size_t i = 0; i < s.ids.size(); ++i) w->add(s.ids[i], s.shapes[i], s.motions[i]);
  return w;
}

// A full predict's impacts, then its undecided pairs, as lines.
std::string resultLines(World& w, double t0, double horizon) {
  return impactsToJsonLines(w.predict(t0, horizon)) + "undecided:\n" + impactsToJsonLines(w.lastUndecided());
}

Outcome predictWith(const SlicedScene& s, BroadPhaseKind kind, int slices, double t0, double horizon,
                    const std::vector<std::string>* only = nullptr) {
  const std::unique_ptr<World> world = sceneWorld(s, kind, slices);
  World& w = *world;
  Outcome o;
  o.lines = only ? impactsToJsonLines(w.predict(t0, horizon, *only)) + "undecided:\n" +
                       impactsToJsonLines(w.lastUndecided())
                 : resultLines(w, t0, horizon);
  o.calls = w.lastCandidateCount();
  o.culled = w.lastSliceCulledCount();
  return o;
}

TEST(TimeSlices, TheCullChangesNoResult) {
  size_t impacts = 0, calls_without = 0, calls_with = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const SlicedScene s = randomScene(seed);
    // Windows starting at 0 and later (the parts are cut from t0, not from the motions' t_ref).
    for (const double t0 : {0.0, 0.7}) {
      const Outcome truth = predictWith(s, BroadPhaseKind::kBrute, 1, t0, 2.0);
      EXPECT_EQ(truth.culled, 0u);
      impacts += static_cast<size_t>(std::count(truth.lines.begin(), truth.lines.end(), '\n'));
      const std::pair<BroadPhaseKind, int> runs[] = {{BroadPhaseKind::kVadop, 2},
                                                     {BroadPhaseKind::kVadop, 8},
                                                     {BroadPhaseKind::kVadop, kMaxTimeSlices},
                                                     {BroadPhaseKind::kGrid, 8},
                                                     {BroadPhaseKind::kBrute, 8}};
      for (const auto& [kind, slices] : runs) {
        const Outcome got = predictWith(s, kind, slices, t0, 2.0);
        ASSERT_TRUE(testing_compare::sameImpactLines(got.lines, truth.lines)) << "seed " << seed << " t0 " << t0 << " " << toString(kind) << " slices "
                                          << slices;
        EXPECT_GT(got.culled, 0u) << "seed " << seed << " " << toString(kind) << " slices " << slices;
        if (kind == BroadPhaseKind::kBrute && slices == 8) {
          EXPECT_EQ(got.calls + got.culled, truth.calls);  // the same broad phase, some pairs culled
          calls_without += truth.calls;
          calls_with += got.calls;
        }
      }
    }
    // predict(only) culls its queried pairs the same way.
    std::vector<std::string> only;
    for (size_t i = 0; i < s.ids.size(); i += 3) only.push_back(s.ids[i]);
    const Outcome truth = predictWith(s, BroadPhaseKind::kBrute, 1, 0.3, 2.0, &only);
    const Outcome got = predictWith(s, BroadPhaseKind::kVadop, 8, 0.3, 2.0, &only);
    ASSERT_TRUE(testing_compare::sameImpactLines(got.lines, truth.lines)) << "seed " << seed << " only";
    EXPECT_GT(got.culled, 0u);
  }
  std::printf("time slices: %zu result lines; narrow-phase calls (brute force) %zu without the cull, %zu with 8 parts\n",
              impacts, calls_without, calls_with);
  EXPECT_GT(impacts, 300u);  // not a vacuous comparison
  EXPECT_LT(calls_with, calls_without * 4 / 5);
}

// A crowded world's full predicts after the first (as many candidate pairs as bodies) compute
// every body's part boxes first and give the broad phase their union as its boxes: the results
// stay those of brute force, and the broad phase, on these tighter boxes, finds fewer pairs for
// the same window (which shows the boxes were taken).
TEST(TimeSlices, TheBroadPhaseOnTheUnionOfThePartsChangesNoResult) {
  for (uint64_t seed = 1; seed <= 2; ++seed) {
    const SlicedScene s = randomScene(seed);
    for (const BroadPhaseKind kind : {BroadPhaseKind::kGrid, BroadPhaseKind::kVadop}) {
      const std::unique_ptr<World> world = sceneWorld(s, kind);
      World& w = *world;
      size_t first_found = 0;
      for (const double t0 : {0.0, 0.0, 0.7, 0.0}) {
        const std::string got = resultLines(w, t0, 2.0);
        const Outcome truth = predictWith(s, BroadPhaseKind::kBrute, 1, t0, 2.0);
        ASSERT_TRUE(testing_compare::sameImpactLines(got, truth.lines))
            << "seed " << seed << " " << toString(kind) << " t0 " << t0;
        const size_t found = w.lastCandidateCount() + w.lastSliceCulledCount();
        if (first_found == 0) {
          first_found = found;
          ASSERT_GE(found, s.ids.size()) << "not crowded enough to take the parts' boxes";
        } else if (t0 == 0.0) {
          EXPECT_LT(found, first_found) << "seed " << seed << " " << toString(kind) << ": the same pairs as the swept boxes";
        }
      }
    }
  }
}

// The same, with the part boxes of every body filled on several threads: the same results, to
// the last bit, as one thread's, predict after predict.
TEST(TimeSlices, ThePartsOfEveryBodyOnThreadsEqualOneThread) {
  const SlicedScene s = randomScene(3, 1500);
  std::vector<std::string> reference;
  for (const int threads : {1, 2, 4}) {
    const std::unique_ptr<World> world = sceneWorld(s, BroadPhaseKind::kGrid, 8, threads);
    World& w = *world;
    size_t k = 0;
    for (const double t0 : {0.0, 0.0, 0.4, 0.9}) {
      const std::string got = resultLines(w, t0, 2.0);
      if (k == 0) {
        ASSERT_GE(w.lastCandidateCount() + w.lastSliceCulledCount(), s.ids.size()) << "not crowded enough";
      }
      if (threads == 1) {
        reference.push_back(got);
      } else {
        EXPECT_EQ(got, reference[k]) << threads << " threads, t0 " << t0;
      }
      ++k;
    }
  }
  EXPECT_GT(std::count(reference[1].begin(), reference[1].end(), '\n'), 300);
}

// Two bodies crossing the same point a second apart: their swept boxes over the window overlap,
// those over any quarter second do not.
TEST(TimeSlices, BodiesCrossingTheSameGroundAtDifferentTimesAreCulled) {
  for (const int slices : {1, 8}) {
    WorldConfig c;
    c.time_slices = slices;
    World w(c);
    w.add("a", makeSphere(0.2), moving(Vector3d(-0.5, 0, 0), Vector3d(1, 0, 0)));  // at the origin at 0.5 s
    w.add("b", makeSphere(0.2), moving(Vector3d(0, -1.5, 0), Vector3d(0, 1, 0)));  // at 1.5 s
    EXPECT_TRUE(w.predict(0.0, 2.0).empty());
    EXPECT_EQ(w.lastCandidateCount(), slices == 1 ? 1u : 0u);
    EXPECT_EQ(w.lastSliceCulledCount(), slices == 1 ? 0u : 1u);
  }
}

// Contacts at a boundary between parts, inside the last part, at the very end of the window,
// with the window starting after the motions' reference time, and under rotation about a pivot:
// the same impact with and without the cull.
TEST(TimeSlices, ContactsAtPartBoundariesAndInTheLastPartAreFound) {
  struct Case {
    const char* what;
    double t0, contact;  // the spheres meet at `contact` (absolute time)
  };
  const Case cases[] = {{"boundary 1.0", 0.0, 1.0},       {"boundary 0.25", 0.0, 0.25}, {"last part", 0.0, 1.9},
                        {"end of window", 0.0, 2.0 - 1e-9}, {"late window", 1.3, 3.05}, {"first instant", 0.0, 0.0}};
  for (const Case& k : cases) {
    std::string expected;
    for (const int slices : {1, 8, 3}) {
      WorldConfig c;
      c.time_slices = slices;
      World w(c);
      // Radii 0.3 + 0.2: centres 0.5 apart at `contact`, closing at 2 m/s along x.
      w.add("a", makeSphere(0.3), moving(Vector3d(-0.25 - 1.0 * k.contact, 0, 0), Vector3d(1, 0, 0)));
      w.add("b", makeSphere(0.2), moving(Vector3d(0.25 + 1.0 * k.contact, 0, 0), Vector3d(-1, 0, 0)));
      // A box turning about a pivot 1 m away (its origin on the unit circle about (5, 0, 0), from
      // 90 degrees on), meeting the sphere e, at 140 degrees, on its arc.
      Motion turning = moving(Vector3d(5, 1, 0), Vector3d::Zero());
      turning.angular_velocity = Vector3d(0, 0, 0.5);
      turning.pivot_offset = Vector3d(0, -1, 0);
      w.add("d", makeBox(Vector3d(0.4, 0.2, 0.2)), turning);
      w.add("e", makeSphere(0.1), moving(Vector3d(5.0 - 0.766, 0.643, 0), Vector3d::Zero()));
      const std::string got = impactsToJsonLines(w.predict(k.t0, 2.0));
      if (slices == 1) {
        expected = got;
        EXPECT_NE(got.find("\"a\""), std::string::npos) << k.what << ": no impact of a and b";
        if (k.t0 == 0.0) EXPECT_NE(got.find("\"d\""), std::string::npos) << k.what << ": no impact of d and e";
      } else {
        EXPECT_TRUE(testing_compare::sameImpactLines(got, expected)) << k.what << ", " << slices << " slices";
      }
    }
  }
}

TEST(TimeSlices, OutOfRangeCountsAreRejectedNamingTheField) {
  for (const int bad : {0, -1, kMaxTimeSlices + 1}) {
    WorldConfig c;
    c.time_slices = bad;
    try {
      World w(c);
      ADD_FAILURE() << "time_slices " << bad << " accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("time_slices"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(std::to_string(bad)), std::string::npos) << e.what();
    }
  }
  WorldConfig c;
  c.time_slices = kMaxTimeSlices;
  EXPECT_NO_THROW(World w(c));
}

}  // namespace
}  // namespace vadop
