// Single-body queries (BroadPhase::query) and World::predict(t0, h, only), which answers from
// them. References, each independent of the engine under test:
//  - predict(only) against a World built from scratch with the same bodies and motions, whose
//    full predict is filtered to the pairs involving `only` (identical output, every kind);
//  - query completeness against the narrow phase: every body that timeOfImpact finds touching
//    the query's shape over [t0, t1] is in the answer (zero misses);
//  - the grid engines' answer, for a window inside the last update's frame, against an O(n)
//    scan of swept AABBs (sweptInterval on x, y, z): the frame's box of each unchanged body,
//    the window's box of each body changed or added since; equal, as vadop_grid.h states;
//  - the other answers (every engine but the grids inside their frame) within the boxes of the
//    swept bounding-sphere capsules: no engine may answer "everything".
#include "broad_phase_access.h"
#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/broad_phase.h"
#include "vadop/error.h"
#include "vadop/scene_io.h"
#include "vadop/sweep_prune.h"
#include "vadop/time_of_impact.h"
#include "vadop/vadop_grid.h"
#include "vadop/world.h"
#include "world_scene_gen.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace vadop {
namespace {

constexpr double kTol = 1e-6;  // ToiOptions' default tolerance: the padding of the broad phase

const BroadPhaseKind kKinds[] = {BroadPhaseKind::kVadop, BroadPhaseKind::kVadopSap, BroadPhaseKind::kSap,
                                 BroadPhaseKind::kGrid, BroadPhaseKind::kBrute};

Motion randomMotion(std::mt19937_64& rng, double box, double speed, bool rotating) {
  std::uniform_real_distribution<double> pos(-box, box), u(-1.0, 1.0);
  const Eigen::Vector3d p(pos(rng), pos(rng), pos(rng));
  const Eigen::Vector3d v = speed * Eigen::Vector3d(u(rng), u(rng), u(rng));
  const Eigen::Vector3d w = rotating ? Eigen::Vector3d(2 * u(rng), 2 * u(rng), 2 * u(rng)) : Eigen::Vector3d::Zero();
  const Eigen::Quaterniond q(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng) + 2.0).normalized());
  return makeMotion(p, q, v, w, 0.0);
}

Shape randomShape(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> s(0.2, 1.0);
  switch (rng() % 4) {
    case 0: return makeSphere(s(rng));
    case 1: return makeBox(Eigen::Vector3d(s(rng), s(rng), 2 * s(rng)));
    case 2: return makeCapsule(0.5 * s(rng), 2 * s(rng));
    default: return makeCylinder(s(rng), s(rng));
  }
}

// The same bodies, in the same insertion order, with the same motions, in a fresh world.
std::string freshFilteredPredict(World& w, BroadPhaseKind kind, double t0, double h,
                                 const std::set<std::string>& only) {
  WorldConfig c;
  c.broad_phase = kind;
  World fresh(c);
  for (const std::string& id : w.ids()) fresh.add(id, w.shape(id), w.motion(id));
  std::vector<Contact> all = fresh.predict(t0, h), kept;
  for (auto& i : all) {
    if (only.count(i.a) || only.count(i.b)) kept.push_back(i);
  }
  return impactsToJsonLines(kept);
}

TEST(WorldQuery, PredictOnlyEqualsTheFilteredFullPredictOfAFreshWorld) {
  size_t compared = 0, nonempty = 0;
  for (const BroadPhaseKind kind : kKinds) {
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      testing_scene::GenParams gp;
      gp.n = 400;
      gp.box = 8.0;
      const Scene scene = parseScene(testing_scene::randomSceneJson(seed, gp));
      WorldConfig c;
      c.broad_phase = kind;
      World w(c);
      addToWorld(scene, w);
      w.predict(0.0, 1.0);  // the structures of the frame [0, 1]
      std::mt19937_64 rng(seed * 77 + static_cast<uint64_t>(kind));
      std::vector<std::string> ids = w.ids();
      std::shuffle(ids.begin(), ids.end(), rng);
      // Since that predict: 20 new motions, 5 bodies removed, 5 added.
      for (int i = 0; i < 20; ++i) w.setMotion(ids[i], randomMotion(rng, 8.0, 4.0, i % 3 == 0));
      for (int i = 20; i < 25; ++i) w.remove(ids[i]);
      for (int i = 0; i < 5; ++i) w.add("new" + std::to_string(i), randomShape(rng), randomMotion(rng, 8.0, 3.0, i % 2 == 0));
      // `only`: changed, unchanged and new bodies, two of them neighbours of each other.
      std::vector<std::string> only = {ids[0], ids[1], ids[30], ids[31], ids[32], "new0", "new3"};
      const std::set<std::string> only_set(only.begin(), only.end());
      // Windows inside the last frame (grid engines: answered from its cells) and outside.
      for (const auto& [t0, h] : {std::pair<double, double>{0.0, 1.0}, {0.25, 0.5}, {0.9, 0.1}, {0.5, 2.0}, {3.0, 1.0}}) {
        const std::string got = impactsToJsonLines(w.predict(t0, h, only));
        const std::string want = freshFilteredPredict(w, kind, t0, h, only_set);
        EXPECT_EQ(got, want) << toString(kind) << " seed " << seed << " window [" << t0 << ", " << t0 + h << "]";
        ++compared;
        if (!want.empty()) ++nonempty;
      }
      // The queries left the incremental state alone: a full predict still equals a fresh one.
      const std::vector<std::string> now = w.ids();
      EXPECT_EQ(impactsToJsonLines(w.predict(0.5, 1.0)),
                freshFilteredPredict(w, kind, 0.5, 1.0, std::set<std::string>(now.begin(), now.end())))
          << toString(kind) << " seed " << seed;
    }
  }
  // Not vacuous: most comparisons have impacts.
  EXPECT_GT(nonempty, compared / 2);
  std::printf("%zu comparisons, %zu with impacts\n", compared, nonempty);
}

// A broad phase of each engine with random bodies, the frame [0, 1] updated, then changed.
struct Engines {
  std::vector<std::unique_ptr<BroadPhase>> list;
  Engines() {
    VadopConfig vc;
    list.push_back(std::make_unique<BruteForceBroadPhase>());
    list.push_back(SweepPruneBroadPhase::makeEveryAxis(3));
    list.push_back(std::make_unique<SweepPruneBroadPhase>(vc));
    list.push_back(std::make_unique<VadopGridBroadPhase>(vc, 0.0, 0.0));  // full path every frame
    list.push_back(std::make_unique<VadopGridBroadPhase>(vc, 0.0, 1.0));  // incremental mode
    list.push_back(VadopGridBroadPhase::makeBoxOnly(0.0, 0.0));
    list.push_back(VadopGridBroadPhase::makeBoxOnly(0.0, 1.0));
  }
};

bool isGrid(const BroadPhase& bp) { return dynamic_cast<const VadopGridBroadPhase*>(&bp) != nullptr; }

double sweptBox(const Shape& s, const Motion& m, double t0, double t1, double* box) {
  for (int k = 0; k < 3; ++k) {
    const Interval iv = sweptInterval(s, m, t0, t1, Eigen::Vector3d::Unit(k));
    box[k] = iv.lo;
    box[3 + k] = iv.hi;
  }
  return 0.0;
}
bool boxesOverlap(const double* a, const double* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}
// The box of the capsule swept by the ball about the pivot that holds the shape (the bound).
void capsuleBox(const Shape& s, const Motion& m, double t0, double t1, double* box) {
  const double r = s.bounding_radius + (m.hasPivot() ? m.pivot_offset.norm() : 0.0) + 1e-9;
  const Eigen::Vector3d a = m.pivotAt(t0), b = m.pivotAt(t1);
  for (int k = 0; k < 3; ++k) {
    box[k] = std::min(a[k], b[k]) - r;
    box[3 + k] = std::max(a[k], b[k]) + r;
  }
}

// Few changes since the update (BroadPhase tests them directly: the grids' answers equal the
// box scan) and many (held in its hash grid over the frame's remainder: the answer lies
// between the box scan and the boxes of the changed bodies over the whole frame).
TEST(WorldQuery, QueriesAreCompleteBoundedAndExactForTheGrids) {
  size_t queries = 0, hits_checked = 0, grid_compared = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    const bool many = seed > 4;
    std::mt19937_64 rng(seed);
    const int n = 250;
    const double box = 7.0;
    std::vector<Shape> shapes;
    std::vector<Motion> motions;
    for (int i = 0; i < n; ++i) {
      shapes.push_back(randomShape(rng));
      motions.push_back(randomMotion(rng, box, i % 5 == 0 ? 0.0 : 3.0, i % 3 == 0));
    }
    // A huge body (past the frame grid's per-body cell limit), a huger one (also past that of
    // the fat boxes' grid) and one far away.
    shapes.push_back(makeBox(Eigen::Vector3d(40.0, 0.5, 0.5)));
    motions.push_back(randomMotion(rng, 1.0, 0.5, false));
    shapes.push_back(makeSphere(0.5));
    motions.push_back(makeMotion(Eigen::Vector3d(500, 500, 500), Eigen::Quaterniond::Identity(),
                                 Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d::Zero()));
    shapes.push_back(makeBox(Eigen::Vector3d(0.5, 600.0, 0.5)));
    motions.push_back(randomMotion(rng, 1.0, 0.5, false));
    const int total = n + 3;
    // Changes after the update: new motions, removals, additions.
    std::vector<std::pair<int, Motion>> changes;
    for (int i = 0; i < (many ? 120 : 15); ++i) {
      changes.push_back({static_cast<int>(rng() % n), randomMotion(rng, box, 5.0, i % 2 == 0)});
    }
    std::vector<int> removed = {3, 17, 101};
    std::vector<Shape> added_shapes;
    std::vector<Motion> added_motions;
    for (int i = 0; i < 4; ++i) {
      added_shapes.push_back(randomShape(rng));
      added_motions.push_back(randomMotion(rng, box, 3.0, i % 2 == 1));
    }
    Engines engines;
    for (auto& bp : engines.list) {
      std::vector<char> changed(total + 8, 0);
      std::vector<Shape> cur_shapes = shapes;
      std::vector<Motion> cur = motions;
      std::vector<char> alive(total, 1);
      for (int i = 0; i < total; ++i) ASSERT_EQ(bp->add(inflate(shapes[i], kTol), motions[i]), static_cast<BodyId>(i));
      bp->update(0.0, 1.0);
      // Sweep and prune answers in-frame queries from its volumes of the update.
      const auto* sp = dynamic_cast<const SweepPruneBroadPhase*>(bp.get());
      std::vector<std::vector<SweepPruneBroadPhase::AxisSpan>> volumes;
      for (int i = 0; sp && i < total; ++i) volumes.push_back(BroadPhaseTestAccess::volume(*sp, i));
      for (const auto& [i, m] : changes) {
        bp->setMotion(i, m);
        cur[i] = m;
        changed[i] = 1;
      }
      for (int i : removed) {
        bp->remove(i);
        alive[i] = 0;
      }
      for (size_t k = 0; k < added_shapes.size(); ++k) {
        const BodyId id = bp->add(inflate(added_shapes[k], kTol), added_motions[k]);
        if (id >= cur.size()) {
          cur_shapes.resize(id + 1, makeSphere(1.0));
          cur.resize(id + 1, motions[0]);
          alive.resize(id + 1, 0);
        }
        cur_shapes[id] = added_shapes[k];
        cur[id] = added_motions[k];
        changed[id] = 1;
        alive[id] = 1;
      }
      std::vector<PreparedShape> prepared;
      for (const Shape& s : cur_shapes) prepared.emplace_back(s);
      // Queries: bodies (changed, unchanged, added, the huge one), and shapes not in it.
      struct Q {
        int id;  // -1: a foreign shape
        Shape shape;
        Motion motion;
      };
      std::vector<Q> qs;
      for (int id : {changes[0].first, 5, 6, 7, n, n + 2, static_cast<int>(cur.size()) - 1}) {
        if (alive[id]) qs.push_back({id, cur_shapes[id], cur[id]});
      }
      for (int k = 0; k < 3; ++k) qs.push_back({-1, randomShape(rng), randomMotion(rng, box, 4.0, k == 1)});
      // In-frame windows in the order a response loop asks (t0 growing), then one starting
      // earlier (the changed bodies' grid must be rebuilt), then outside the frame.
      for (const auto& [t0, t1] : {std::pair<double, double>{0.3, 0.6}, {0.45, 0.9}, {0.0, 1.0}, {0.5, 1.7}, {2.0, 2.5}}) {
        for (const Q& q : qs) {
          std::vector<BodyId> got;
          if (q.id >= 0) {
            bp->query(static_cast<BodyId>(q.id), t0, t1, got);
          } else {
            bp->query(inflate(q.shape, kTol), q.motion, t0, t1, got);
          }
          ++queries;
          ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
          ASSERT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end());
          const std::set<BodyId> answer(got.begin(), got.end());
          const Shape q_padded = inflate(q.shape, kTol);
          double qbox[6], qcap[6];
          sweptBox(q_padded, q.motion, t0, t1, qbox);
          capsuleBox(q_padded, q.motion, t0, t1, qcap);
          const PreparedShape qp(q.shape);
          const bool in_frame = t0 >= 0.0 && t1 <= 1.0;
          std::set<BodyId> scan, loose;
          for (BodyId j = 0; j < cur.size(); ++j) {
            if (!alive[j] || static_cast<int>(j) == q.id) {
              EXPECT_FALSE(answer.count(j)) << bp->name() << ": dead body or self " << j;
              continue;
            }
            const Shape j_padded = inflate(cur_shapes[j], kTol);
            double jcap[6];
            double fbox[6];
            if (changed[j]) {
              sweptBox(j_padded, cur[j], t0, t1, fbox);
            } else {
              sweptBox(j_padded, motions[j], 0.0, 1.0, fbox);  // unchanged: its frame's box
            }
            if (boxesOverlap(qbox, fbox)) scan.insert(j);
            double whole[6];  // a changed body's box over the whole frame: the grid's bound
            sweptBox(j_padded, changed[j] ? cur[j] : motions[j], 0.0, 1.0, whole);
            if (boxesOverlap(qbox, changed[j] ? whole : fbox)) loose.insert(j);
            // The bound of the engines that answer by capsules (brute force, and every engine
            // outside the last frame). Inside it the grids are held to the box scan below.
            capsuleBox(j_padded, cur[j], t0, t1, jcap);
            const bool frame_answer = in_frame && (isGrid(*bp) || sp);
            if (!frame_answer && !boxesOverlap(qcap, jcap)) EXPECT_FALSE(answer.count(j)) << bp->name() << " body " << j << " query " << q.id << " [" << t0 << ", " << t1 << "] changed " << int(changed[j]);
            if (sp && in_frame && !changed[j]) {
              // An unchanged body is listed iff its update intervals overlap the query box's
              // projection on each of its axes (up to rounding).
              bool surely = true, maybe = true;
              for (const auto& span : volumes[j]) {
                const Eigen::Vector3d& a = sp->pool().axis(static_cast<int>(span.axis));
                double lo = 0.0, hi = 0.0;
                for (int k = 0; k < 3; ++k) {
                  lo += std::min(a[k] * qbox[k], a[k] * qbox[3 + k]);
                  hi += std::max(a[k] * qbox[k], a[k] * qbox[3 + k]);
                }
                surely = surely && span.interval.lo <= hi - 1e-9 && lo + 1e-9 <= span.interval.hi;
                maybe = maybe && span.interval.lo <= hi + 1e-9 && lo - 1e-9 <= span.interval.hi;
              }
              if (surely) EXPECT_TRUE(answer.count(j)) << bp->name() << " misses " << j << " query " << q.id;
              if (!maybe) EXPECT_FALSE(answer.count(j)) << bp->name() << " beyond its volumes: " << j << " query " << q.id;
            }
            // Completeness: a contact found by the narrow phase is a candidate.
            const TimeOfImpact hit = timeOfImpact(qp, q.motion, prepared[j], cur[j], t0, t1);
            if (hit.hit) {
              ++hits_checked;
              EXPECT_TRUE(answer.count(j)) << bp->name() << ": missed body " << j << " (query " << q.id << ", ["
                                           << t0 << ", " << t1 << "], contact at " << hit.time << ")";
            }
          }
          if (sp && in_frame) {  // the changed bodies: as for the grids
            for (BodyId j : scan) {
              if (changed[j]) EXPECT_TRUE(answer.count(j)) << bp->name() << " misses changed " << j << " query " << q.id;
            }
            for (BodyId j : answer) {
              if (changed[j]) EXPECT_TRUE(loose.count(j)) << bp->name() << " beyond the bound: " << j << " query " << q.id;
            }
          }
          if (isGrid(*bp) && in_frame) {
            ++grid_compared;
            if (!many) {
              EXPECT_EQ(answer, scan) << bp->name() << " query " << q.id << " [" << t0 << ", " << t1 << "]";
            } else {
              for (BodyId j : scan) {
                EXPECT_TRUE(answer.count(j)) << bp->name() << " misses " << j << " query " << q.id << " [" << t0 << ", " << t1 << "]";
              }
              for (BodyId j : answer) {
                EXPECT_TRUE(loose.count(j)) << bp->name() << " beyond the bound: " << j << " query " << q.id << " [" << t0 << ", " << t1 << "]";
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GT(hits_checked, 200u);  // not vacuous
  std::printf("%zu queries, %zu contacts checked, %zu grid answers compared with the scan\n", queries,
              hits_checked, grid_compared);
}

TEST(WorldQuery, BadQueriesThrowAndChangeNothing) {
  BruteForceBroadPhase brute;
  auto grid = VadopGridBroadPhase::makeBoxOnly();
  for (BroadPhase* bp : {static_cast<BroadPhase*>(&brute), static_cast<BroadPhase*>(grid.get())}) {
    bp->add(makeSphere(1.0), makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                        Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()));
    bp->update(0.0, 1.0);
    std::vector<BodyId> out = {42};
    EXPECT_THROW(bp->query(7, 0.0, 1.0, out), InvalidArgument);
    EXPECT_THROW(bp->query(0, 1.0, 0.5, out), InvalidArgument);
    EXPECT_THROW(bp->query(0, std::nan(""), 0.5, out), InvalidArgument);
    Shape bad = makeSphere(1.0);
    bad.bounding_radius = std::nan("");
    EXPECT_THROW(bp->query(bad, bp->motion(0), 0.0, 1.0, out), InvalidArgument);
    Motion nan_motion = bp->motion(0);
    nan_motion.linear_velocity.x() = std::nan("");
    EXPECT_THROW(bp->query(makeSphere(1.0), nan_motion, 0.0, 1.0, out), InvalidArgument);
    EXPECT_EQ(out, std::vector<BodyId>{42});
  }
  World w;
  w.add("a", makeSphere(1.0), makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                         Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()));
  w.add("b", makeSphere(1.0), makeMotion(Eigen::Vector3d(3, 0, 0), Eigen::Quaterniond::Identity(),
                                         Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
  EXPECT_EQ(w.predict(0.0, 2.0, {"a"}).size(), 1u);
  const size_t calls = w.lastCandidateCount();
  try {
    w.predict(0.0, 2.0, {"a", "nobody"});
    ADD_FAILURE() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("nobody"), std::string::npos) << e.what();
  }
  EXPECT_THROW(w.predict(0.0, -1.0, {"a"}), InvalidArgument);
  EXPECT_EQ(w.lastCandidateCount(), calls);
  EXPECT_EQ(w.predict(0.0, 2.0, {"a", "a", "b"}).size(), 1u);  // repeats and both ends: one pair
  EXPECT_EQ(w.lastCandidateCount(), 1u);
}

}  // namespace
}  // namespace vadop
