// Property tests of the broad phases (VADOP on a grid, VADOP / k-DOP / AABB sweep and prune) against
// independent references, over random scenes with velocity changes, adds and removes:
//  1. the candidate set equals, pair for pair, the set a brute-force double loop computes
//     from the same per-body intervals (overlap on every shared axis; no shared axis ->
//     candidate), and no two bodies ever share no axis (the rho <= phi guarantee); the grid
//     engine's volume includes its swept AABB as three axes every body has;
//  2. each interval bounds the body's projection at densely sampled times (so a pair whose
//     swept volumes intersect overlaps on every axis and is a candidate);
//  3. end to end, with spheres (whose swept volumes are exactly capsules): every pair whose
//     swept capsules intersect is a candidate.
// VADOP_SOAK_FRAMES sets the total number of frames (default: a fast CI subset).
#include "vadop/broad_phase.h"
#include "vadop/error.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"
#include "broad_phase_access.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <set>

namespace vadop {
namespace {

constexpr double kPi = 3.14159265358979323846;

int soakFrames(int fallback) {
  const char* env = std::getenv("VADOP_SOAK_FRAMES");
  return env ? std::max(1, std::atoi(env)) : fallback;
}

struct SceneParams {
  int n = 60;
  double box = 10.0;
  double fast_speed = 30.0;      // m/s for the fast bodies (frames are 1/30 s)
  double fast_fraction = 0.3;
  double static_fraction = 0.2;
  double rotating_fraction = 0.3;
  bool spheres_only = false;
};

class RandomScene {
 public:
  RandomScene(uint64_t seed, SceneParams p) : rng_(seed), p_(p) {}

  Shape randomShape() {
    std::uniform_real_distribution<double> size(0.05, 0.8);
    const int type = p_.spheres_only ? 0 : std::uniform_int_distribution<int>(0, 4)(rng_);
    switch (type) {
      case 0: return makeSphere(size(rng_));
      case 1: return makeBox(Eigen::Vector3d(size(rng_), size(rng_), 0.01 + 0.1 * size(rng_)));
      case 2: return makeCapsule(0.5 * size(rng_), 2.0 * size(rng_));
      case 3: return makeCylinder(size(rng_), size(rng_));
      default: {
        std::vector<Eigen::Vector3d> pts;
        for (int i = 0; i < 8; ++i) pts.push_back(Eigen::Vector3d::Random() * size(rng_) + Eigen::Vector3d(0.1, 0, 0));
        return makeConvex(pts);
      }
    }
  }

  Eigen::Vector3d unit() {
    std::normal_distribution<double> g;
    Eigen::Vector3d v(g(rng_), g(rng_), g(rng_));
    return v.normalized();
  }

  Motion randomMotion(double t_ref, const Eigen::Vector3d* keep_position = nullptr) {
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::uniform_real_distribution<double> pos(-p_.box, p_.box);
    Eigen::Vector3d p = keep_position ? *keep_position : Eigen::Vector3d(pos(rng_), pos(rng_), pos(rng_));
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    const double r = u01(rng_);
    if (r < p_.static_fraction) {
      // Static, or drifting below the slow threshold.
      if (u01(rng_) < 0.5) v = unit() * 1e-3;
    } else if (r < p_.static_fraction + p_.fast_fraction) {
      v = unit() * p_.fast_speed * (0.5 + u01(rng_));
    } else {
      v = unit() * 2.0 * u01(rng_);
    }
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    if (!p_.spheres_only && u01(rng_) < p_.rotating_fraction) w = unit() * 10.0 * u01(rng_);
    Eigen::Quaterniond q(Eigen::AngleAxisd(2 * kPi * u01(rng_), unit()));
    Motion m = makeMotion(p, q, v, w, t_ref);
    // Some turn about a pivot off their origin (links of turning robots, vehicles on curves).
    if (w.squaredNorm() > 0.0 && u01(rng_) < 0.3) m.pivot_offset = unit() * 2.0 * u01(rng_);
    return m;
  }

  // A slight turn of the current velocity: exercises the hysteresis and in-place updates.
  Motion turned(const Motion& m, double t_ref) {
    Motion out = m;
    out.position = m.positionAt(t_ref);
    out.orientation = m.orientationAt(t_ref);
    out.t_ref = t_ref;
    const double angle = std::uniform_real_distribution<double>(0.0, 0.2)(rng_);
    out.linear_velocity = Eigen::AngleAxisd(angle, unit()) * m.linear_velocity;
    return out;
  }

  std::mt19937_64& rng() { return rng_; }

 private:
  std::mt19937_64 rng_;
  SceneParams p_;
};

// Reference 1: the candidate set from the same intervals, by a double loop.
template <class BP>
std::vector<Pair> oracle(const BP& bp, const std::vector<BodyId>& ids, size_t* unshared) {
  std::map<BodyId, std::vector<SweepPruneBroadPhase::AxisSpan>> vol;
  for (BodyId id : ids) vol[id] = BroadPhaseTestAccess::volume(bp, id);
  std::vector<Pair> out;
  *unshared = 0;
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      const auto& a = vol[ids[i]];
      const auto& b = vol[ids[j]];
      bool shared = false, separated = false;
      // Both lists are ascending in axis: a merge finds the shared axes.
      for (size_t x = 0, y = 0; x < a.size() && y < b.size();) {
        if (a[x].axis < b[y].axis) {
          ++x;
        } else if (b[y].axis < a[x].axis) {
          ++y;
        } else {
          shared = true;
          if (!overlaps(a[x].interval, b[y].interval)) separated = true;
          ++x;
          ++y;
        }
      }
      if (!shared) ++*unshared;
      if (!separated) out.push_back(makePair(ids[i], ids[j]));
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Reference 2: intervals bound the projection of the shape at sampled times.
Eigen::Vector3d axisOf(const SweepPruneBroadPhase& bp, uint32_t axis) { return bp.pool().axis(static_cast<int>(axis)); }
Eigen::Vector3d axisOf(const VadopGridBroadPhase& bp, uint32_t axis) { return BroadPhaseTestAccess::axisDirection(bp, axis); }

template <class BP>
void checkIntervalsBound(const BP& bp, BodyId id, double t0, double t1) {
  const Shape& s = bp.shape(id);
  const Motion& m = bp.motion(id);
  for (const auto& span : BroadPhaseTestAccess::volume(bp, id)) {
    const Eigen::Vector3d a = axisOf(bp, span.axis);
    for (int k = 0; k <= 16; ++k) {
      const double t = t0 + (t1 - t0) * k / 16.0;
      const Eigen::Matrix3d R = m.orientationAt(t).toRotationMatrix();
      const Eigen::Vector3d p = m.positionAt(t);
      const double up = a.dot(p) + support(s, R.transpose() * a);
      const double down = a.dot(p) - support(s, -(R.transpose() * a));
      ASSERT_LE(up, span.interval.hi) << "body " << id << " axis " << span.axis << " t " << t;
      ASSERT_GE(down, span.interval.lo) << "body " << id << " axis " << span.axis << " t " << t;
    }
  }
}

// The zone rule: a velocity-aligned body's axes include every axis within phi of
// orthogonality to its direction of motion (or of the slow direction).
template <class BP>
void checkZone(const BP& bp, BodyId id, double frame) {
  const Motion& m = bp.motion(id);
  const double speed = m.linear_velocity.norm();
  const bool slow = !(speed * frame >= 0.05 * bp.shape(id).bounding_radius) || speed == 0.0;
  const Eigen::Vector3d u = slow ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d(m.linear_velocity / speed);
  std::set<uint32_t> used;
  for (const auto& s : BroadPhaseTestAccess::volume(bp, id)) used.insert(s.axis);
  for (int k = 0; k < bp.pool().size(); ++k) {
    const double c = std::abs(u.dot(bp.pool().axis(k)));
    if (c <= std::sin(bp.phi()) - 1e-9) ASSERT_TRUE(used.count(k)) << "body " << id << " misses zone axis " << k;
  }
}

struct RunConfig {
  std::string label;
  std::function<std::unique_ptr<SweepPruneBroadPhase>()> make;  // one of the two
  std::function<std::unique_ptr<VadopGridBroadPhase>()> make_grid;
  SceneParams scene;
  double frame_share = 1.0;  // of the soak's frames per configuration (large scenes cost more)
};

struct RunTotals {
  size_t frames = 0, pairs = 0, reinserted = 0, incremental = 0;
};
size_t usedIncrementalMode(const SweepPruneBroadPhase&) { return 0; }
size_t usedIncrementalMode(const VadopGridBroadPhase& bp) { return bp.stats().incremental ? 1 : 0; }

template <class BP>
RunTotals runScenario(const RunConfig& rc, std::unique_ptr<BP> bp, uint64_t seed, int frames, bool check_bounds) {
  RandomScene scene(seed, rc.scene);
  BruteForceBroadPhase brute;  // mirrors the same calls: same ids
  std::vector<BodyId> ids;
  const double dt = 1.0 / 30.0;
  double t = 0.0;
  for (int i = 0; i < rc.scene.n; ++i) {
    const Shape s = scene.randomShape();
    const Motion m = scene.randomMotion(t);
    const BodyId id = bp->add(s, m);
    EXPECT_EQ(brute.add(s, m), id);
    ids.push_back(id);
  }
  RunTotals totals;
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (int f = 0; f < frames; ++f) {
    // Random events between frames.
    for (BodyId id : ids) {
      const double r = u01(scene.rng());
      if (r < 0.05) {
        const Eigen::Vector3d p = bp->motion(id).positionAt(t);
        const Motion m = scene.randomMotion(t, &p);
        bp->setMotion(id, m);
        brute.setMotion(id, m);
      } else if (r < 0.15) {
        const Motion m = scene.turned(bp->motion(id), t);
        bp->setMotion(id, m);
        brute.setMotion(id, m);
      }
    }
    if (u01(scene.rng()) < 0.2 && ids.size() > 2) {
      const size_t k = std::uniform_int_distribution<size_t>(0, ids.size() - 1)(scene.rng());
      bp->remove(ids[k]);
      brute.remove(ids[k]);
      ids.erase(ids.begin() + static_cast<long>(k));
    }
    if (u01(scene.rng()) < 0.2) {
      const Shape s = scene.randomShape();
      const Motion m = scene.randomMotion(t);
      const BodyId id = bp->add(s, m);
      EXPECT_EQ(brute.add(s, m), id);
      ids.push_back(id);
    }
    // Keep bodies near the box: bounce those that left it (a velocity change).
    for (BodyId id : ids) {
      const Motion& m = bp->motion(id);
      const Eigen::Vector3d p = m.positionAt(t);
      if (p.cwiseAbs().maxCoeff() > 2.0 * rc.scene.box && m.linear_velocity.dot(p) > 0) {
        Motion back = m;
        back.position = p;
        back.orientation = m.orientationAt(t);
        back.t_ref = t;
        back.linear_velocity = -m.linear_velocity;
        bp->setMotion(id, back);
        brute.setMotion(id, back);
      }
    }
    std::sort(ids.begin(), ids.end());
    bp->update(t, t + dt);
    size_t unshared = 0;
    const auto expected = oracle(*bp, ids, &unshared);
    EXPECT_EQ(unshared, 0u) << rc.label << " frame " << f << ": bodies sharing no axis";
    const auto& got = bp->pairs();
    if (got != expected) {
      std::vector<Pair> missing, extra;
      std::set_difference(expected.begin(), expected.end(), got.begin(), got.end(), std::back_inserter(missing));
      std::set_difference(got.begin(), got.end(), expected.begin(), expected.end(), std::back_inserter(extra));
      ADD_FAILURE() << rc.label << " seed " << seed << " frame " << f << ": " << missing.size()
                    << " pairs missing, " << extra.size() << " extra"
                    << (missing.empty() ? "" : ", first missing " + std::to_string(missing[0].a) + "-" +
                                                   std::to_string(missing[0].b));
      return totals;
    }
    if (check_bounds) {
      for (BodyId id : ids) {
        checkIntervalsBound(*bp, id, t, t + dt);
        if (bp->velocityAligned()) checkZone(*bp, id, dt);
        if (::testing::Test::HasFatalFailure()) return totals;
      }
    }
    if (rc.scene.spheres_only) {
      // Reference 3: exact swept volumes of non-rotating spheres.
      brute.update(t, t + dt);
      for (const Pair& p : brute.pairs()) {
        if (!std::binary_search(got.begin(), got.end(), p)) {
          ADD_FAILURE() << rc.label << " frame " << f << ": swept spheres " << p.a << "-" << p.b
                        << " intersect but are not a candidate";
          return totals;
        }
      }
    }
    totals.frames++;
    totals.pairs += got.size();
    totals.reinserted += bp->stats().reinserted;
    totals.incremental += usedIncrementalMode(*bp);
    t += dt;
  }
  return totals;
}

std::vector<RunConfig> configs() {
  std::vector<RunConfig> out;
  auto vadop = [](int m, double phi_deg, SlowAxisRule rule) {
    return [=] {
      VadopConfig c;
      c.axes = m;
      c.phi_deg = phi_deg;
      c.slow_rule = rule;
      return std::make_unique<SweepPruneBroadPhase>(c);
    };
  };
  SceneParams mixed;
  SceneParams spheres;
  spheres.spheres_only = true;
  spheres.n = 80;
  SceneParams crowded;
  crowded.n = 120;
  crowded.box = 4.0;
  auto grid = [](int m, double phi_deg, SlowAxisRule rule, double cell,
                 double incremental = VadopGridBroadPhase::kDefaultIncremental, int threads = 1) {
    return [=] {
      VadopConfig c;
      c.axes = m;
      c.phi_deg = phi_deg;
      c.slow_rule = rule;
      auto bp = std::make_unique<VadopGridBroadPhase>(c, cell, incremental);
      bp->setThreads(threads);
      return bp;
    };
  };
  // A slow scene (no fast bodies): the incremental mode keeps its fat boxes for many frames.
  SceneParams slow;
  slow.fast_fraction = 0.0;
  slow.n = 100;
  const auto none = nullptr;
  out.push_back({"vadop m=3", vadop(3, 0, SlowAxisRule::kFixedZone), none, mixed});
  out.push_back({"vadop m=7", vadop(7, 0, SlowAxisRule::kFixedZone), none, mixed});
  out.push_back({"vadop m=20 all-axes slow", vadop(20, 0, SlowAxisRule::kAllAxes), none, mixed});
  out.push_back({"vadop m=64", vadop(64, 0, SlowAxisRule::kFixedZone), none, crowded});
  out.push_back({"vadop m=64 phi=30", vadop(64, 30, SlowAxisRule::kFixedZone), none, mixed});
  out.push_back({"vadop m=200 spheres", vadop(200, 0, SlowAxisRule::kFixedZone), none, spheres});
  out.push_back({"vadop m=1000", vadop(1000, 0, SlowAxisRule::kAllAxes), none, mixed});
  out.push_back({"sap xyz", [] { return SweepPruneBroadPhase::makeEveryAxis(3); }, none, mixed});
  out.push_back({"kdop m=13 spheres", [] { return SweepPruneBroadPhase::makeEveryAxis(13); }, none, spheres});
  // The grid engine: automatic cells; cells so small that most bodies are too large for the
  // grid (tested against everyone); one cell holding everything; pools of several sizes.
  out.push_back({"grid m=32", nullptr, grid(32, 25, SlowAxisRule::kFixedZone, 0.0), mixed});
  out.push_back({"grid m=7 crowded", nullptr, grid(7, 0, SlowAxisRule::kFixedZone, 0.0), crowded});
  out.push_back({"grid m=100 spheres", nullptr, grid(100, 0, SlowAxisRule::kAllAxes, 0.0), spheres});
  out.push_back({"grid m=16 tiny cells", nullptr, grid(16, 25, SlowAxisRule::kFixedZone, 0.05), mixed});
  out.push_back({"grid m=32 one cell", nullptr, grid(32, 25, SlowAxisRule::kFixedZone, 1000.0), mixed});
  // Incremental mode: never off (every body that leaves its fat box is re-fattened, however
  // many), off, and on a slow scene where it stays on.
  out.push_back({"grid m=16 incremental always", nullptr, grid(16, 25, SlowAxisRule::kFixedZone, 0.0, 1.0), mixed});
  out.push_back({"grid m=16 incremental always spheres", nullptr,
                 grid(16, 0, SlowAxisRule::kFixedZone, 0.0, 1.0), spheres});
  out.push_back({"grid m=16 incremental off", nullptr, grid(16, 25, SlowAxisRule::kFixedZone, 0.0, 0.0), mixed});
  out.push_back({"grid m=16 slow scene", nullptr, grid(16, 25, SlowAxisRule::kFixedZone, 0.0), slow});
  // On threads (worlds large enough to split): bodies, cells or slots in blocks, intervals of
  // the slots that need them; each path as above.
  SceneParams large;
  large.n = 540;
  large.box = 20.0;
  SceneParams large_slow = large;
  large_slow.fast_fraction = 0.0;
  const double share = 0.3;
  out.push_back({"grid m=32 threads 2", nullptr, grid(32, 25, SlowAxisRule::kFixedZone, 0.0, 0.0, 2), large, share});
  out.push_back({"grid m=16 tiny cells threads 3", nullptr, grid(16, 25, SlowAxisRule::kFixedZone, 0.05, 0.0, 3), large,
                 share});
  out.push_back({"grid m=16 incremental always threads 2", nullptr,
                 grid(16, 25, SlowAxisRule::kFixedZone, 0.0, 1.0, 2), large, share});
  out.push_back({"grid m=16 slow scene threads 2", nullptr,
                 grid(16, 25, SlowAxisRule::kFixedZone, 0.0, VadopGridBroadPhase::kDefaultIncremental, 2), large_slow,
                 share});
  return out;
}

TEST(BroadPhaseProperty, CandidatesEqualOracleAndAreComplete) {
  const auto cs = configs();
  const int total = soakFrames(1800);
  double shares = 0.0;
  for (const RunConfig& c : cs) shares += c.frame_share;
  const double per_share = static_cast<double>(total) / shares;  // at least `total` in all
  size_t frames = 0;
  for (size_t c = 0; c < cs.size(); ++c) {
    // Several seeds, each a short life of its own scene.
    const int per_config = std::max(1, static_cast<int>(std::ceil(per_share * cs[c].frame_share)));
    int done = 0;
    size_t config_frames = 0, incremental_frames = 0;
    for (uint64_t seed = 1; done < per_config; ++seed) {
      const int len = std::min(100, per_config - done);
      const uint64_t s = seed * 7919 + c;
      const bool bounds = seed % 3 == 1;
      const RunTotals r = cs[c].make ? runScenario(cs[c], cs[c].make(), s, len, bounds)
                                     : runScenario(cs[c], cs[c].make_grid(), s, len, bounds);
      if (::testing::Test::HasFailure()) return;
      frames += r.frames;
      config_frames += r.frames;
      incremental_frames += r.incremental;
      done += len;
    }
    // The grid's two paths were both exercised where meant to be.
    const std::string& label = cs[c].label;
    if (label.find("incremental always") != std::string::npos) EXPECT_EQ(incremental_frames, config_frames) << label;
    if (label.find("incremental off") != std::string::npos) EXPECT_EQ(incremental_frames, 0u) << label;
    if (label.find("slow scene") != std::string::npos) EXPECT_GT(incremental_frames, config_frames / 2) << label;
  }
  RecordProperty("frames", static_cast<int>(frames));
  std::printf("checked %zu frames over %zu configurations\n", frames, cs.size());
}

TEST(BroadPhase, VelocityAlignmentKeepsProjectionsStill) {
  // A body moving along x at 30 m/s: on every one of its axes its interval moves by at most
  // |v| dt sin(phi + hysteresis) per frame; on a plain x axis it would move |v| dt.
  VadopConfig c;
  c.axes = 64;
  SweepPruneBroadPhase bp(c);
  const Eigen::Vector3d v(30, 0, 0);
  const BodyId id = bp.add(makeSphere(0.5), makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), v,
                                                       Eigen::Vector3d::Zero()));
  const double dt = 1.0 / 30.0;
  bp.update(0, dt);
  const auto first = BroadPhaseTestAccess::volume(bp, id);
  bp.update(dt, 2 * dt);
  const auto second = BroadPhaseTestAccess::volume(bp, id);
  ASSERT_EQ(first.size(), second.size());
  ASSERT_GT(first.size(), 0u);
  const double bound = 30.0 * dt * std::sin(bp.phi() + c.hysteresis_deg * kPi / 180.0) + 1e-9;
  for (size_t k = 0; k < first.size(); ++k) {
    EXPECT_LE(std::abs(second[k].interval.lo - first[k].interval.lo), bound);
    // And the interval is tight: sphere diameter plus the small projected sweep.
    EXPECT_LE(first[k].interval.hi - first[k].interval.lo, 1.0 + bound + 1e-9);
  }
}

TEST(BroadPhase, SeparatedPairIsPrunedAndTouchingPairIsKept) {
  for (auto make : {std::function<std::unique_ptr<SweepPruneBroadPhase>()>(
                        [] { return std::make_unique<SweepPruneBroadPhase>(VadopConfig{}); }),
                    std::function<std::unique_ptr<SweepPruneBroadPhase>()>(
                        [] { return SweepPruneBroadPhase::makeEveryAxis(3); })}) {
    auto bp = make();
    const auto still = [](double x, double vx) {
      return makeMotion(Eigen::Vector3d(x, 0, 0), Eigen::Quaterniond::Identity(), Eigen::Vector3d(vx, 0, 0),
                        Eigen::Vector3d::Zero());
    };
    // Head-on: gap 2 m, closing at 60 m/s, 1/30 s: they meet within the frame.
    const BodyId a = bp->add(makeSphere(0.5), still(-1.5, 30));
    const BodyId b = bp->add(makeSphere(0.5), still(1.5, -30));
    // Far away, not moving.
    const BodyId c = bp->add(makeSphere(0.5), still(100, 0));
    bp->update(0, 1.0 / 30.0);
    EXPECT_EQ(bp->pairs(), (std::vector<Pair>{makePair(a, b)})) << bp->name();
    // Exactly touching at rest counts (closed intervals).
    bp->setMotion(a, still(99, 0));
    bp->update(1.0 / 30.0, 2.0 / 30.0);
    EXPECT_TRUE(std::binary_search(bp->pairs().begin(), bp->pairs().end(), makePair(a, c))) << bp->name();
  }
}

TEST(BroadPhase, BadInputThrowsAndChangesNothing) {
  VadopConfig c;
  c.axes = 32;
  SweepPruneBroadPhase bp(c);
  const Motion ok = makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0),
                               Eigen::Vector3d::Zero());
  const BodyId a = bp.add(makeSphere(1), ok);
  Motion moved = ok;
  moved.position.x() = 1.5;
  const BodyId b = bp.add(makeBox(Eigen::Vector3d(1, 1, 1)), moved);
  bp.update(0, 0.1);
  const auto before = bp.pairs();
  ASSERT_EQ(before.size(), 1u);

  Motion nan = ok;
  nan.position.y() = std::nan("");
  EXPECT_THROW(bp.add(makeSphere(1), nan), InvalidArgument);
  Motion inf = ok;
  inf.linear_velocity.z() = INFINITY;
  EXPECT_THROW(bp.setMotion(a, inf), InvalidArgument);
  Motion zero_q = ok;
  zero_q.orientation = Eigen::Quaterniond(0, 0, 0, 0);
  EXPECT_THROW(bp.setMotion(b, zero_q), InvalidArgument);
  EXPECT_THROW(makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond(0, 0, 0, 0), Eigen::Vector3d::Zero(),
                          Eigen::Vector3d::Zero()),
               InvalidArgument);
  EXPECT_THROW(bp.remove(77), InvalidArgument);
  EXPECT_THROW(bp.setMotion(77, ok), InvalidArgument);
  EXPECT_THROW(bp.update(1.0, 0.5), InvalidArgument);
  EXPECT_THROW(bp.update(0, std::nan("")), InvalidArgument);
  Shape bad = makeSphere(1);
  bad.radius = -1;
  EXPECT_THROW(bp.add(bad, ok), InvalidArgument);
  EXPECT_THROW(makeSphere(0), InvalidArgument);
  EXPECT_THROW(makeBox(Eigen::Vector3d(1, -1, 1)), InvalidArgument);
  EXPECT_THROW(makeCapsule(std::nan(""), 1), InvalidArgument);
  EXPECT_THROW(makeConvex({}), InvalidArgument);

  EXPECT_EQ(bp.size(), 2u);
  bp.update(0, 0.1);
  EXPECT_EQ(bp.pairs(), before);
  try {
    bp.remove(12345);
    FAIL() << "no throw";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("12345"), std::string::npos) << e.what();
  }
}

TEST(BroadPhase, ConfigurationIsValidated) {
  VadopConfig c;
  c.axes = 64;
  c.phi_deg = 1.0;  // below rho of a 64-axis pool
  try {
    SweepPruneBroadPhase bp(c);
    FAIL() << "phi below rho accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("covering radius"), std::string::npos) << e.what();
  }
  c.phi_deg = 95;
  EXPECT_THROW(SweepPruneBroadPhase{c}, InvalidArgument);
  c.phi_deg = std::nan("");
  EXPECT_THROW(SweepPruneBroadPhase{c}, InvalidArgument);
  c.phi_deg = 0;
  c.axes = 2;
  EXPECT_THROW(SweepPruneBroadPhase{c}, InvalidArgument);
  c.axes = 64;
  c.slow_direction = Eigen::Vector3d::Zero();
  EXPECT_THROW(SweepPruneBroadPhase{c}, InvalidArgument);
  EXPECT_THROW(SweepPruneBroadPhase::makeEveryAxis(1), InvalidArgument);
}

TEST(BroadPhase, IdsAreReusedSmallestFirst) {
  SweepPruneBroadPhase bp(VadopConfig{});
  const Motion m = makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Zero());
  for (int i = 0; i < 5; ++i) EXPECT_EQ(bp.add(makeSphere(1), m), static_cast<BodyId>(i));
  bp.remove(3);
  bp.remove(1);
  EXPECT_EQ(bp.add(makeSphere(1), m), 1u);
  EXPECT_EQ(bp.add(makeSphere(1), m), 3u);
  EXPECT_EQ(bp.add(makeSphere(1), m), 5u);
  bp.update(0, 0.1);
  // All six spheres sit at the origin: every pair is a candidate.
  EXPECT_EQ(bp.pairs().size(), 15u);
}

}  // namespace
}  // namespace vadop

namespace vadop {
namespace {

Motion linear(const Eigen::Vector3d& p, const Eigen::Vector3d& v) {
  return makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero());
}

TEST(VadopGrid, SeparatedPairIsPrunedAndTouchingPairIsKept) {
  VadopGridBroadPhase bp(VadopConfig{});
  // Head-on: gap 2 m, closing at 60 m/s over 1/30 s: they meet within the frame.
  const BodyId a = bp.add(makeSphere(0.5), linear({-1.5, 0, 0}, {30, 0, 0}));
  const BodyId b = bp.add(makeSphere(0.5), linear({1.5, 0, 0}, {-30, 0, 0}));
  const BodyId c = bp.add(makeSphere(0.5), linear({100, 0, 0}, {0, 0, 0}));
  bp.update(0, 1.0 / 30.0);
  EXPECT_EQ(bp.pairs(), (std::vector<Pair>{makePair(a, b)}));
  // Exactly touching at rest counts (closed intervals), also across a cell boundary.
  bp.setMotion(a, linear({99, 0, 0}, {0, 0, 0}));
  bp.update(1.0 / 30.0, 2.0 / 30.0);
  EXPECT_TRUE(std::binary_search(bp.pairs().begin(), bp.pairs().end(), makePair(a, c)));
  // Parallel and 1.01 m apart sideways: the boxes overlap along the motion, the volumes do not.
  VadopGridBroadPhase side(VadopConfig{});
  side.add(makeSphere(0.5), linear({0, 0, 0}, {30, 0, 0}));
  side.add(makeSphere(0.5), linear({0, 1.01, 0}, {30, 0, 0}));
  side.update(0, 1.0 / 30.0);
  EXPECT_TRUE(side.pairs().empty());
}

TEST(VadopGrid, LazyIntervalsReportTheUpdatesVolumeAfterSetMotion) {
  // In the incremental mode a frame computes a body's pool-axis intervals only when a kept pair
  // needs them. volume() must still report those of the last update, also for a body whose
  // motion changed since: compare with the same calls on an engine that computes them all.
  VadopGridBroadPhase lazy(VadopConfig{}, 0.0, 1.0), eager(VadopConfig{}, 0.0, 0.0);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-40.0, 40.0), w(-3.0, 3.0);
  std::vector<BodyId> ids;
  for (int i = 0; i < 200; ++i) {
    const Motion m = linear({u(rng), u(rng), u(rng)}, {w(rng), w(rng), w(rng)});
    ids.push_back(lazy.add(makeSphere(0.5), m));
    ASSERT_EQ(eager.add(makeSphere(0.5), m), ids.back());
  }
  const double dt = 1.0 / 30.0;
  for (int f = 0; f < 4; ++f) {
    lazy.update(f * dt, (f + 1) * dt);
    eager.update(f * dt, (f + 1) * dt);
    ASSERT_TRUE(lazy.stats().incremental);
    ASSERT_FALSE(eager.stats().incremental);
    ASSERT_EQ(lazy.pairs(), eager.pairs());
    std::vector<Motion> at_update;  // each body's motion during the update
    for (BodyId id : ids) at_update.push_back(lazy.motion(id));
    for (int k = 0; k < 25; ++k) {  // new motions after the update (five bodies twice), before volume()
      const BodyId id = ids[(f * 37 + (k % 20) * 11) % ids.size()];
      const Motion m = linear(lazy.motion(id).positionAt((f + 1) * dt), {w(rng), w(rng), w(rng)});
      lazy.setMotion(id, m);
      eager.setMotion(id, m);
    }
    for (BodyId id : ids) {
      const auto a = BroadPhaseTestAccess::volume(lazy, id), b = BroadPhaseTestAccess::volume(eager, id);
      ASSERT_EQ(a.size(), b.size()) << "body " << id << " frame " << f;
      // The swept sphere over the update's frame with the update's motion, projected anew.
      const SweptBody swept(makeSphere(0.5), at_update[id], f * dt, (f + 1) * dt);
      size_t pool_spans = 0;
      for (size_t k = 0; k < a.size(); ++k) {
        ASSERT_EQ(a[k].axis, b[k].axis);
        ASSERT_EQ(a[k].interval.lo, b[k].interval.lo) << "body " << id << " axis " << a[k].axis << " frame " << f;
        ASSERT_EQ(a[k].interval.hi, b[k].interval.hi);
        if (a[k].axis >= static_cast<uint32_t>(VadopConfig{}.axes)) continue;  // x, y, z of the box
        const Interval want = swept.project(BroadPhaseTestAccess::axisDirection(lazy, a[k].axis));
        ASSERT_EQ(a[k].interval.lo, want.lo) << "body " << id << " axis " << a[k].axis << " frame " << f;
        ASSERT_EQ(a[k].interval.hi, want.hi);
        ++pool_spans;
      }
      EXPECT_GT(pool_spans, 0u);
    }
  }
}

TEST(VadopGrid, LargeBodiesAndFarCoordinatesAreStillExact) {
  // A 1 km wall among 1 m cells is too large for the grid: it must still meet its neighbours.
  VadopGridBroadPhase bp(VadopConfig{}, 1.0);
  const BodyId wall = bp.add(makeBox(Eigen::Vector3d(1000, 0.1, 10)), linear({0, 0, 0}, {0, 0, 0}));
  const BodyId near = bp.add(makeSphere(0.3), linear({400, 0.3, 0}, {0, 0, 0}));
  const BodyId far = bp.add(makeSphere(0.3), linear({400, 5, 0}, {0, 0, 0}));
  bp.update(0, 0.1);
  EXPECT_EQ(bp.pairs(), (std::vector<Pair>{makePair(wall, near)}));
  EXPECT_EQ(bp.stats().large_bodies, 1u);
  (void)far;
  // Bodies far out force coarser cells, so that cell coordinates cannot overflow. (This used
  // bodies at 1e12 m with 1 m cells; positions are now limited to kMaxCoordinate = 1e7 m
  // (error.h), so 1 cm cells at +-1e7 m, 1e9 cells out, beyond the grid's 2^29.)
  VadopGridBroadPhase fine(VadopConfig{}, 0.01);
  const BodyId x1 = fine.add(makeSphere(0.001), linear({kMaxCoordinate, 0, 0}, {0, 0, 0}));
  const BodyId x2 = fine.add(makeSphere(0.001), linear({kMaxCoordinate - 0.0015, 0, 0}, {0, 0, 0}));
  const BodyId x3 = fine.add(makeSphere(0.001), linear({-kMaxCoordinate, 0, 0}, {0, 0, 0}));
  const BodyId x4 = fine.add(makeSphere(0.001), linear({kMaxCoordinate - 0.005, 0, 0}, {0, 0, 0}));
  fine.update(0.1, 0.2);
  EXPECT_EQ(fine.pairs(), (std::vector<Pair>{makePair(x1, x2)}));
  EXPECT_GT(fine.stats().cell_size, 0.01);
  (void)x3;
  (void)x4;
}

TEST(VadopGrid, BadInputThrowsAndChangesNothing) {
  VadopGridBroadPhase bp(VadopConfig{});
  const BodyId a = bp.add(makeSphere(1), linear({0, 0, 0}, {1, 0, 0}));
  const BodyId b = bp.add(makeBox(Eigen::Vector3d(1, 1, 1)), linear({1.5, 0, 0}, {1, 0, 0}));
  bp.update(0, 0.1);
  const auto before = bp.pairs();
  ASSERT_EQ(before.size(), 1u);
  Motion nan = linear({0, 0, 0}, {1, 0, 0});
  nan.position.y() = std::nan("");
  EXPECT_THROW(bp.add(makeSphere(1), nan), InvalidArgument);
  EXPECT_THROW(bp.setMotion(a, nan), InvalidArgument);
  EXPECT_THROW(bp.remove(77), InvalidArgument);
  EXPECT_THROW(BroadPhaseTestAccess::volume(bp, 77), InvalidArgument);
  EXPECT_THROW(bp.update(1.0, 0.5), InvalidArgument);
  EXPECT_THROW(BroadPhaseTestAccess::axisDirection(bp, 32 + 3), InvalidArgument);
  EXPECT_EQ(bp.size(), 2u);
  bp.update(0, 0.1);
  EXPECT_EQ(bp.pairs(), before);
  (void)b;

  VadopConfig c;
  c.axes = 64;
  c.phi_deg = 1.0;  // below the covering radius
  EXPECT_THROW(VadopGridBroadPhase{c}, InvalidArgument);
  EXPECT_THROW(VadopGridBroadPhase(VadopConfig{}, -1.0), InvalidArgument);
  try {
    VadopGridBroadPhase bad(VadopConfig{}, std::nan(""));
    FAIL() << "NaN cell size accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("cell_size"), std::string::npos) << e.what();
  }
}

TEST(VadopGrid, ThreadsGiveTheSamePairsAndCounts) {
  // The same calls on engines that split their update over 1, 2 and 4 threads: the same pairs
  // and the same statistics every frame, for the velocity-aligned grid (incremental mode on
  // and off) and the box-only grid. The world is large enough to be split.
  SceneParams p;
  p.n = 900;
  p.box = 9.0;
  p.fast_fraction = 0.05;
  using Make = std::function<std::unique_ptr<VadopGridBroadPhase>()>;
  const std::vector<std::pair<std::string, Make>> engines = {
      {"vadop", [] { return std::make_unique<VadopGridBroadPhase>(VadopConfig{}); }},
      {"vadop incremental off", [] { return std::make_unique<VadopGridBroadPhase>(VadopConfig{}, 0.0, 0.0); }},
      {"grid", [] { return VadopGridBroadPhase::makeBoxOnly(); }},
  };
  for (const auto& [label, make] : engines) {
    std::vector<std::unique_ptr<VadopGridBroadPhase>> bps;
    for (int threads : {1, 2, 4}) {
      bps.push_back(make());
      bps.back()->setThreads(threads);
    }
    RandomScene scene(11, p);
    for (int i = 0; i < p.n; ++i) {
      const Shape shape = scene.randomShape();
      const Motion m = scene.randomMotion(0.0);
      for (auto& bp : bps) bp->add(shape, m);
    }
    const double dt = 1.0 / 30.0;
    size_t incremental = 0;
    for (int f = 0; f < 24; ++f) {
      const double t = f * dt;
      for (BodyId id = 0; id < static_cast<BodyId>(p.n); ++id) {
        if (std::uniform_real_distribution<double>(0.0, 1.0)(scene.rng()) >= 0.1) continue;
        const Motion m = scene.turned(bps[0]->motion(id), t);
        for (auto& bp : bps) bp->setMotion(id, m);
      }
      for (auto& bp : bps) bp->update(t, t + dt);
      const VadopGridBroadPhase::Stats& one = bps[0]->stats();
      incremental += one.incremental ? 1 : 0;
      for (size_t k = 1; k < bps.size(); ++k) {
        const VadopGridBroadPhase::Stats& many = bps[k]->stats();
        ASSERT_EQ(bps[k]->pairs(), bps[0]->pairs()) << label << " frame " << f << ", threads " << bps[k]->threads();
        EXPECT_EQ(many.box_tests, one.box_tests) << label << " frame " << f;
        EXPECT_EQ(many.overlap_tests, one.overlap_tests) << label << " frame " << f;
        EXPECT_EQ(many.reinserted, one.reinserted) << label << " frame " << f;
        EXPECT_EQ(many.incremental, one.incremental) << label << " frame " << f;
      }
    }
    EXPECT_GT(bps[0]->pairs().size(), 100u) << label;
    if (label == "vadop") EXPECT_GT(incremental, 0u) << "the incremental path was not exercised";
  }
  VadopGridBroadPhase bp(VadopConfig{});
  EXPECT_THROW(bp.setThreads(0), InvalidArgument);
  EXPECT_EQ(bp.threads(), 1);
}

TEST(VadopGrid, TurningRobotsInOverlappingWindowsKeepTheIncrementalMode) {
  // The monitor's fleet: robots turning about their instantaneous centres (pivots at rest,
  // 0.3-1.5 m/s, up to 0.5 rad/s), windows of 2 s advancing by 1/30 s, every motion set anew
  // each frame along the same arc. A fat box is the swept box over the window extended by the
  // lead, so it follows the arc, and lifetimes are counted in the 1/30 s steps, not in 2 s
  // frames: the incremental mode is built once and kept. (With the lead along the pivot's
  // velocity, zero here, the fat boxes were left within 4 frames: 6 builds, 24 incremental
  // frames of 150.) The candidates stay those of the full path.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const int n = 2000;
  const double side = std::sqrt(6.0 * n), dt = 1.0 / 30.0, horizon = 2.0;
  VadopGridBroadPhase bp(VadopConfig{}), full(VadopConfig{}, 0.0, 0.0);
  struct Robot {
    Eigen::Vector3d centre;  // of the turn
    double radius, phase, rate;
  };
  std::vector<Robot> robots;
  auto motionAt = [](const Robot& r, double t) {
    const double a = r.phase + r.rate * t;
    const Eigen::Vector3d p = r.centre + r.radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
    Motion m = makeMotion(p, Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ())), Eigen::Vector3d::Zero(),
                          Eigen::Vector3d(0, 0, r.rate), t);
    m.pivot_offset = r.centre - p;
    return m;
  };
  for (int i = 0; i < n; ++i) {
    const double speed = 0.3 + 1.2 * u01(rng);
    const double rate = (u01(rng) < 0.5 ? -1.0 : 1.0) * (0.05 + 0.45 * u01(rng));
    robots.push_back({Eigen::Vector3d(side * u01(rng), side * u01(rng), 0.0), speed / std::abs(rate), 6.3 * u01(rng), rate});
    const Shape shape = makeBox(Eigen::Vector3d(0.3, 0.2, 0.2));
    bp.add(shape, motionAt(robots.back(), 0.0));
    full.add(shape, motionAt(robots.back(), 0.0));
  }
  int builds = 0, incremental = 0;
  const int frames = 150;
  for (int f = 0; f < frames; ++f) {
    const double t = f * dt;
    for (BodyId id = 0; id < static_cast<BodyId>(n); ++id) {
      bp.setMotion(id, motionAt(robots[id], t));
      full.setMotion(id, motionAt(robots[id], t));
    }
    bp.update(t, t + horizon);
    full.update(t, t + horizon);
    ASSERT_EQ(bp.pairs(), full.pairs()) << "frame " << f;
    builds += bp.stats().fat_rebuilt ? 1 : 0;
    incremental += bp.stats().incremental ? 1 : 0;
  }
  std::printf("%d builds, %d incremental frames of %d\n", builds, incremental, frames);
  EXPECT_LE(builds, 2);
  EXPECT_GE(incremental, frames * 8 / 10);
}

TEST(VadopGrid, IdsAreReusedAndRemovedBodiesVanish) {
  VadopGridBroadPhase bp(VadopConfig{});
  const Motion still = linear({0, 0, 0}, {0, 0, 0});
  for (int i = 0; i < 5; ++i) EXPECT_EQ(bp.add(makeSphere(1), still), static_cast<BodyId>(i));
  bp.update(0, 0.1);
  EXPECT_EQ(bp.pairs().size(), 10u);
  bp.remove(3);
  bp.remove(1);
  EXPECT_TRUE(BroadPhaseTestAccess::volume(bp, 0).size() > 3u);
  EXPECT_EQ(bp.add(makeSphere(1), still), 1u);
  EXPECT_TRUE(BroadPhaseTestAccess::volume(bp, 1).empty());  // added since the last update
  bp.update(0.1, 0.2);
  EXPECT_EQ(bp.pairs().size(), 6u);  // 4 bodies at the origin
  for (const Pair& p : bp.pairs()) EXPECT_TRUE(p.a != 3 && p.b != 3);
}

}  // namespace
}  // namespace vadop
