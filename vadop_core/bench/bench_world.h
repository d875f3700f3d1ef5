// The world of vadop_bench: n spheres in a cubic box (the VADOP paper's experiment), elastic
// responses between spheres (equal masses: the normal velocity components are exchanged) and
// with the walls (reflection), impacts processed in time order inside each frame.
//
// ContinuousWorld is a thin user of vadop::ResponseLoop (response_loop.h, the bench's event
// loop beside the library), so every method runs the same pipeline around its broad phase:
//   1. broad phase:  bp.update(t0, t1) over the swept spheres of the frame       (c_u + c_s)
//   2. narrow phase: vadop::timeOfImpact on every candidate pair                  (c_t)
//   3. responses in time order: the loop's callback exchanges the normal velocity components
//      (spheres) or reflects (walls, the loop's boundary); the bodies whose motion changed
//      are re-predicted over the rest of the frame from the broad phase's own single-body
//      queries (BroadPhase::query: each engine's structure of the frame plus the bodies
//      changed since)                                                             (c_r; the
//      narrow-phase calls of the re-prediction count in c_t)
// The ground-truth run is brute force, whose queries scan every body with the exact
// swept-capsule test; the per-frame impact lists of every method must match it (vadop_bench
// checks this and exits non-zero on a miss).
#pragma once

#include "response_loop.h"
#include "vadop/broad_phase.h"
#include "vadop/distance.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace vadop_bench {

struct SceneParams {
  int n = 1000;
  double density = 0.01;  // total sphere volume / box volume, in (0, 0.5]
  double speed = 1.0;     // radii per frame
  uint64_t seed = 1;
  double radius = 1.0;
  double fps = 30.0;
};

struct Scene {
  SceneParams params;
  double half = 0.0;  // the box is [-half, half]^3
  std::vector<Eigen::Vector3d> position, velocity;
};

// Non-overlapping random positions (random sequential addition; a jittered lattice above
// density 0.2), random directions, |v| = speed * radius * fps. Deterministic from the seed.
// Throws std::runtime_error when n spheres cannot be placed at that density.
Scene makeScene(const SceneParams& params);

// Narrow-phase tolerance (vadop::ToiOptions default) and the padding of every broad-phase box.
constexpr double kToiTolerance = 1e-6;

// Axis-aligned box of a sphere of radius `r` moving with `m` over [ta, tb], widened by a tiny
// absolute amount so that it is conservative under rounding.
struct Box {
  Eigen::Vector3d lo, hi;
};
Box sweptBox(const vadop::Motion& m, double r, double ta, double tb);
// The same for a sphere of radius `r` whose centre moves from a to b in a straight line.
Box segmentBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r);
inline bool overlaps(const Box& a, const Box& b) {
  return (a.lo.array() <= b.hi.array()).all() && (b.lo.array() <= a.hi.array()).all();
}

struct FrameStats {
  double update_s = 0, sort_s = 0, test_s = 0, response_s = 0;
  double requery_s = 0;       // of response_s: the broad phase's single-body queries
  size_t candidates = 0;      // the broad phase's pairs for the frame
  size_t requeried = 0;       // bodies re-queried after a velocity change
  size_t requery_pairs = 0;   // narrow-phase calls those re-queries caused
  size_t impacts = 0;         // sphere-sphere responses
  size_t wall_hits = 0;
  double cpu_s = 0;           // CPU time of the thread over the frame (robust to other load)
  // SweepPruneBroadPhase::stats() of the frame's update (zero for the other broad phases).
  size_t sp_endpoints = 0, sp_swaps = 0, sp_overlap_tests = 0, sp_reinserted = 0;
  double total() const { return update_s + sort_s + test_s + response_s; }
};

struct LoggedImpact {
  uint32_t a, b;  // a < b
  double time;
  friend bool operator==(const LoggedImpact& x, const LoggedImpact& y) {
    return x.a == y.a && x.b == y.b && x.time == y.time;
  }
};

// CPU time of the calling thread, in seconds.
double threadCpuSeconds();

// c_u of the last update() of a broad phase: SweepPruneBroadPhase::stats().update_seconds or
// TimedBroadPhase::lastUpdateSeconds(); 0 for a broad phase without the split (brute force).
double broadPhaseUpdateSeconds(const vadop::BroadPhase& bp);

class ContinuousWorld {
 public:
  // The broad phase must be empty; the world adds the bodies (ids 0..n-1).
  ContinuousWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp);
  // The same from given motions (an oracle run from another method's state).
  ContinuousWorld(const Scene& scene, const std::vector<vadop::Motion>& motions, std::unique_ptr<vadop::BroadPhase> bp);

  double frameLength() const { return dt_; }
  // Runs frame f, [f dt, (f + 1) dt]. Appends the sphere-sphere impacts in processing order.
  void runFrame(int f, FrameStats& stats, std::vector<LoggedImpact>* log);
  std::vector<vadop::Motion> motions() const;
  const vadop::BroadPhase& broadPhase() const { return loop_.broadPhase(); }
  size_t memoryBytes() const { return loop_.memoryBytes(); }  // the loop's own structures

 private:
  vadop::TimeOfImpact wallContact(vadop::BodyId id, const vadop::Motion& m, double from, double t1) const;

  uint32_t n_;
  double dt_, wall_;  // wall_ = half - radius: the range of the centres
  vadop::ResponseLoop loop_;
};

// Pseudo-dynamic detection (freeSOLID style): bodies jump from frame pose to frame pose; at
// each frame pose the broad phase (discrete boxes) and an exact sphere overlap test find the
// colliding pairs, which get the same elastic response if they approach; walls reflect
// bodies found beyond them. Collisions that happen between frame poses are missed.
class DiscreteWorld {
 public:
  DiscreteWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp);
  double frameLength() const { return dt_; }
  // Advances to the pose of (f + 1) dt, detects and responds. `detected`: every pair that
  // overlaps at that pose (sorted).
  void runFrame(int f, FrameStats& stats, std::vector<vadop::Pair>& detected);
  const std::vector<vadop::Motion>& motions() const { return motions_; }
  const vadop::BroadPhase& broadPhase() const { return *bp_; }

 private:
  Scene scene_;
  uint32_t n_;
  double dt_, r_, wall_;
  std::unique_ptr<vadop::BroadPhase> bp_;
  std::vector<vadop::Motion> motions_;
};

}  // namespace vadop_bench
