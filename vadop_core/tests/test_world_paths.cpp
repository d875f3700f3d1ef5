// Bodies on timed paths in World (setPath): the pipeline's answer against an independent
// reference, every pair of the scene tested by the narrow phase along the paths
// (timeOfImpact on TimedPath, timed_path.h, itself checked against a certified truth in
// test_timed_path). 300 bodies with constant twists and 15 on paths of 2 to 5 keyframes that
// cross the crowd and turn, for every broad phase and several windows (from the start, in the
// middle of the paths, past their end):
//  - predict(t0, h) equals the reference (identical output);
//  - predict(t0, h, only) equals the reference filtered to the pairs involving `only`;
//  - firstContactIf of a mover (alone, and among the bodies reachable() lists) finds the
//    reference's earliest contact among all bodies;
//  - setMotion ends a path; bad input throws and changes nothing.
#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/error.h"
#include "vadop/scene_io.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"
#include "world_scene_gen.h"

#include "impact_compare.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace vadop {
namespace {

const BroadPhaseKind kKinds[] = {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap,
                                 BroadPhaseKind::kGrid, BroadPhaseKind::kBrute};

struct PathBody {
  std::string id;
  Shape shape;
  TimedPath path;
};

std::vector<PathBody> randomPathBodies(uint64_t seed, int count, double box) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), s(0.2, 0.8);
  std::vector<PathBody> out;
  for (int i = 0; i < count; ++i) {
    const int keys = 2 + static_cast<int>(rng() % 4);
    std::vector<Keyframe> k;
    Eigen::Vector3d p(box * u(rng), box * u(rng), box * u(rng));
    Eigen::Quaterniond q(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng) + 2.0).normalized());
    double t = -0.3 + 0.5 * u(rng);
    for (int j = 0; j < keys; ++j) {
      Keyframe f;
      f.time = t;
      f.position = p;
      f.orientation = q;
      k.push_back(f);
      t += 0.3 + 0.4 * (1.0 + u(rng));                         // 0.3 to 1.1 s per piece
      p += 3.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));        // up to ~5 m per piece: turns
      q = Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng) + 1.5).normalized())) * q;
    }
    const Shape shape = rng() % 2 ? makeBox(Eigen::Vector3d(s(rng), s(rng), 2 * s(rng))) : makeSphere(s(rng));
    out.push_back({"path" + std::to_string(i), shape, TimedPath(k, rng() % 2 ? AfterPath::kHold : AfterPath::kContinue)});
  }
  return out;
}

// Every pair, in insertion order, by the narrow phase along the paths.
std::vector<Contact> reference(const World& w, double t0, double t1, const std::set<std::string>* only = nullptr) {
  const std::vector<std::string> ids = w.ids();
  std::vector<TimedPath> paths;
  std::vector<PreparedShape> shapes;
  for (const std::string& id : ids) {
    paths.push_back(w.path(id) ? *w.path(id) : TimedPath(w.motion(id)));
    shapes.emplace_back(w.shape(id));
  }
  std::vector<Contact> out;
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      if (only && !only->count(ids[i]) && !only->count(ids[j])) continue;
      const TimeOfImpact hit = timeOfImpact(shapes[i], paths[i], shapes[j], paths[j], t0, t1);
      if (!hit.hit) continue;
      Contact x;
      x.a = ids[i];
      x.b = ids[j];
      x.a_key = w.key(ids[i]);
      x.b_key = w.key(ids[j]);
      x.impact = hit;
      out.push_back(x);
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const Contact& x, const Contact& y) { return x.impact.time < y.impact.time; });
  return out;
}

void fill(World& w, uint64_t seed) {
  testing_scene::GenParams gp;
  gp.n = 300;
  gp.box = 8.0;
  addToWorld(parseScene(testing_scene::randomSceneJson(seed, gp)), w);
  for (const PathBody& b : randomPathBodies(seed, 15, 6.0)) {
    w.add(b.id, b.shape, b.path.motion(0));
    w.setPath(b.id, b.path);
  }
}

TEST(WorldPaths, PredictEqualsEveryPairAlongThePaths) {
  const std::pair<double, double> windows[] = {{0.0, 2.0}, {0.6, 1.0}, {2.5, 2.0}};
  size_t path_impacts = 0, vadop_calls = 0;
  for (uint64_t seed = 1; seed <= 2; ++seed) {
    std::vector<std::string> want;
    {
      World w;
      fill(w, seed);
      for (const auto& [t0, h] : windows) {
        const std::vector<Contact> ref = reference(w, t0, t0 + h);
        for (const Contact& x : ref) path_impacts += x.a.rfind("path", 0) == 0 || x.b.rfind("path", 0) == 0;
        want.push_back(impactsToJsonLines(ref));
      }
    }
    for (const BroadPhaseKind kind : kKinds) {
      WorldConfig c;
      c.broad_phase = kind;
      World w(c);
      fill(w, seed);
      for (size_t i = 0; i < 3; ++i) {
        EXPECT_TRUE(testing_compare::sameImpactLines(impactsToJsonLines(w.predict(windows[i].first, windows[i].second)), want[i]))
            << toString(kind) << " seed " << seed << " window " << i;
        if (kind == BroadPhaseKind::kVadop) vadop_calls += w.lastCandidateCount();
      }
    }
  }
  EXPECT_GT(path_impacts, 20u);  // not vacuous: the paths meet the crowd
  std::printf("impacts involving a path body: %zu; narrow-phase calls (vadop, 6 predicts): %zu\n", path_impacts,
              vadop_calls);
}

TEST(WorldPaths, PredictOnlyEqualsTheFilteredReference) {
  for (const BroadPhaseKind kind : kKinds) {
    WorldConfig c;
    c.broad_phase = kind;
    World w(c);
    fill(w, 3);
    w.predict(0.0, 2.0);  // the frame the queries answer from
    const std::vector<std::string> ids = w.ids();
    const std::vector<std::string> only = {ids[3], ids[40], "path2", "path7"};
    const std::set<std::string> only_set(only.begin(), only.end());
    for (const auto& [t0, h] : {std::pair<double, double>{0.0, 2.0}, {0.7, 0.9}, {1.0, 3.0}}) {
      const std::string want = impactsToJsonLines(reference(w, t0, t0 + h, &only_set));
      EXPECT_TRUE(testing_compare::sameImpactLines(impactsToJsonLines(w.predict(t0, h, only)), want)) << toString(kind) << " [" << t0 << ", " << t0 + h << "]";
    }
  }
}

TEST(WorldPaths, FirstContactIfMeetsBodiesOnPaths) {
  for (const BroadPhaseKind kind : {BroadPhaseKind::kVadop, BroadPhaseKind::kGrid, BroadPhaseKind::kBrute}) {
    WorldConfig c;
    c.broad_phase = kind;
    World w(c);
    fill(w, 4);
    w.predict(0.0, 2.0);
    const std::vector<std::string> ids = w.ids();
    int contacts = 0;
    for (int trial = 0; trial < 40; ++trial) {
      // A mover sent towards a path body's position at t = 1.
      const std::string mover = ids[static_cast<size_t>(trial) * 7 % 300];
      const TimedPath& target = *w.path("path" + std::to_string(trial % 15));
      Motion m = w.motion(mover);
      m.t_ref = 0.0;
      m.angular_velocity.setZero();
      m.pivot_offset.setZero();
      m.linear_velocity = target.poseAt(1.0).translation() - m.position;
      if (m.linear_velocity.norm() > 9e3) continue;
      const auto got = w.firstContactIf({mover}, {m}, 0.0, 2.0);
      // The same among the bodies reachable() lists (the gate's way).
      const World::Reachable among = w.reachable({mover}, {m.position}, {2.0 * m.linear_velocity.norm()}, 0.0, 2.0);
      const auto via = w.firstContactIf({mover}, {m}, 0.0, 2.0, {}, &among);
      // The reference: the mover against every other body along its path.
      const PreparedShape ps(w.shape(mover));
      double best = 1e9;
      for (const std::string& other : ids) {
        if (other == mover) continue;
        const TimedPath po = w.path(other) ? *w.path(other) : TimedPath(w.motion(other));
        const TimeOfImpact hit = timeOfImpact(ps, TimedPath(m), PreparedShape(w.shape(other)), po, 0.0, 2.0);
        if (!hit.hit) continue;
        if (hit.initially_touching) {
          const Motion& mo = po.motion(po.pieceAt(0.0));
          if ((m.velocityOfPoint(hit.point, 0.0) - mo.velocityOfPoint(hit.point, 0.0)).dot(hit.normal) <= 0.0) continue;
        }
        best = std::min(best, hit.time);
      }
      ASSERT_EQ(got.has_value(), best < 1e9) << toString(kind) << " trial " << trial;
      ASSERT_EQ(via.has_value(), best < 1e9) << toString(kind) << " trial " << trial << " (reachable)";
      if (got) {
        // Its later windows end at the best time so far: the same contact, to the tolerance.
        EXPECT_NEAR(got->impact.time, best, 1e-6) << toString(kind) << " trial " << trial;
        EXPECT_NEAR(via->impact.time, best, 1e-6) << toString(kind) << " trial " << trial << " (reachable)";
        ++contacts;
      }
    }
    EXPECT_GT(contacts, 10) << toString(kind);
  }
}

TEST(WorldPaths, SetMotionEndsAPathAndBadInputChangesNothing) {
  World w;
  fill(w, 5);
  ASSERT_NE(w.path("path0"), nullptr);
  const Motion still = makeMotion(Eigen::Vector3d(100, 100, 100), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                                  Eigen::Vector3d::Zero());
  w.setMotion("path0", still);
  EXPECT_EQ(w.path("path0"), nullptr);
  EXPECT_TRUE(testing_compare::sameImpactLines(impactsToJsonLines(w.predict(0.0, 2.0)), impactsToJsonLines(reference(w, 0.0, 2.0))));
  const TimedPath p({Keyframe{}});
  const std::string before = impactsToJsonLines(w.predict(0.0, 2.0));
  EXPECT_THROW(w.setPath("nobody", p), InvalidArgument);
  EXPECT_THROW(w.path("nobody"), InvalidArgument);
  EXPECT_EQ(impactsToJsonLines(w.predict(0.0, 2.0)), before);
  w.remove("path1");
  EXPECT_TRUE(testing_compare::sameImpactLines(impactsToJsonLines(w.predict(0.0, 2.0)), impactsToJsonLines(reference(w, 0.0, 2.0))));
}

}  // namespace
}  // namespace vadop
