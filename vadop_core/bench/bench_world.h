// The world of vadop_bench: n spheres in a cubic box (the VADOP paper's experiment), elastic
// responses between spheres (equal masses: the normal velocity components are exchanged) and
// with the walls (reflection), impacts processed in time order inside each frame.
//
// ContinuousWorld runs any vadop::BroadPhase the same way, so every method sees the same code
// around its broad phase:
//   1. broad phase:  bp.update(t0, t1) over the swept spheres of the frame       (c_u + c_s)
//   2. narrow phase: vadop::timeOfImpact on every candidate pair, hits queued     (c_t)
//   3. responses in time order (vadop::ImpactQueue). After a response at tc the bodies
//      involved get new motions from tc, their pending impacts are invalidated, and each is
//      re-predicted against the bodies it can now reach over [tc, t1]             (c_r; the
//      narrow-phase calls of the re-prediction count in c_t)
//
// Mid-frame re-queries (step 3). The frame's candidate pairs were computed for the motions of
// the frame start, so a body whose velocity changed at tc may now reach bodies that were not
// its candidates. Exhaustive re-prediction against every body is O(n) per response, and the
// library's SweepPruneBroadPhase has no single-body query, so the bench answers these queries
// with one structure shared by every method (the result does not depend on the method):
// RequeryGrid, a uniform grid over the axis-aligned box of each body's remaining path (the
// frame's swept box for a body that has not changed, the box of its new path over [tc, t1]
// for one that has). In slow scenes the grid is kept for up to 16 frames: the boxes then hold
// each body's path over all of them, and the bodies that changed velocity since the build are
// listed anew each frame. A body's remaining path always lies inside its box, so the grid
// query is complete; the ground-truth run (brute force) instead scans every body with the exact
// swept-capsule test (RequeryMode::kScan), and the per-frame impact lists of both must match
// (vadop_bench checks this for every method and exits non-zero on a miss).
#pragma once

#include "vadop/broad_phase.h"
#include "vadop/distance.h"
#include "vadop/impact_queue.h"
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
// Bodies are added to the broad phase with this much extra margin (the narrow phase reports a
// hit at gap <= tolerance, so the broad phase must see the spheres padded by it).
constexpr double kBroadPadding = kToiTolerance;

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

// Uniform grid over the boxes of the bodies' remaining paths (see the file comment).
class RequeryGrid {
 public:
  // Rebuilds from the frame's swept boxes (one per body, every body alive).
  void build(const std::vector<Box>& boxes, double half);
  // Body `id` has a new remaining path with box `box`.
  void moved(uint32_t id, const Box& box);
  // Every body other than `id` whose box overlaps `box`, each once (unordered). The boxes are
  // held in single precision (half the bytes to scan: the query is memory-bound), so the
  // answer may also hold bodies whose boxes miss by a rounding (relative 6e-8), never fewer:
  // the narrow phase drops those.
  void query(uint32_t id, const Box& box, std::vector<uint32_t>& out);
  size_t memoryBytes() const;

 private:
  int cellOf(double x) const;
  size_t index(int x, int y, int z) const { return (static_cast<size_t>(z) * g_ + y) * g_ + x; }

  double origin_ = 0.0, h_ = 1.0, inv_h_ = 1.0;
  int g_ = 1;
  struct FloatBox {  // a Box in single precision
    float lo[3], hi[3];
  };
  static FloatBox toFloat(const Box& b);
  static bool overlaps(const FloatBox& a, const FloatBox& b) {
    return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
           a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
  }
  // Bodies still on their frame path, by the cell of their box's lo corner (CSR), each with a
  // copy of its box, so that a query scans contiguous memory. A body that moves has its entry
  // emptied (lo > hi), which no box overlaps.
  struct Entry {
    FloatBox box;
    uint32_t body;
  };
  std::vector<uint32_t> cell_start_;
  std::vector<Entry> entries_;
  std::vector<uint32_t> entry_of_;          // body -> its index in entries_, or kNone
  static constexpr uint32_t kNone = ~uint32_t{0};
  // Bodies that changed velocity this frame (and boxes larger than a cell): listed, with their
  // current box, in every cell that box overlaps; an older listing of the same body is stale.
  std::vector<uint32_t> moved_version_;
  struct Node {
    FloatBox box;
    uint32_t body, version;
    int32_t next;
  };
  std::vector<int32_t> dyn_head_;           // per cell: first node, or -1
  std::vector<size_t> dyn_touched_;         // cells whose dyn_head_ is set, for the reset
  std::vector<Node> dyn_nodes_;
  std::vector<uint32_t> stamp_;             // dedup of the moved bodies within one query
  uint32_t stamp_now_ = 0;
};

enum class RequeryMode { kGrid, kScan };

struct FrameStats {
  double update_s = 0, sort_s = 0, test_s = 0, response_s = 0, requery_s = 0;
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
  ContinuousWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp, RequeryMode mode);
  // The same from given motions (an oracle run from another method's state).
  ContinuousWorld(const Scene& scene, const std::vector<vadop::Motion>& motions,
                  std::unique_ptr<vadop::BroadPhase> bp, RequeryMode mode);

  double frameLength() const { return dt_; }
  // Runs frame f, [f dt, (f + 1) dt]. Appends the sphere-sphere impacts in processing order.
  void runFrame(int f, FrameStats& stats, std::vector<LoggedImpact>* log);
  const std::vector<vadop::Motion>& motions() const { return motions_; }
  const vadop::BroadPhase& broadPhase() const { return *bp_; }
  size_t memoryBytes() const;  // the world's own structures (queue, re-query grid)

 private:
  void predictPair(uint32_t a, uint32_t b, double ts, double t1);
  // False only when the two spheres stay more than 2 tolerances apart over [ts, t1], so that
  // vadop::timeOfImpact would report no hit: a cull from a compact copy of the motions (one
  // cache line per body, where a vadop::Motion spans three), the same for every method.
  bool mayTouch(uint32_t a, uint32_t b, double ts, double t1) const;
  void predictWall(uint32_t i, double ts, double t1);
  void setMotion(uint32_t i, const Eigen::Vector3d& v, double tc);
  void requery(uint32_t i, double tc, double t1, std::vector<uint32_t>& out);

  Scene scene_;
  uint32_t n_;
  double dt_, wall_;  // wall_ = half - radius: the range of the centres
  std::shared_ptr<const vadop::Shape> narrow_shape_, broad_shape_;
  vadop::PreparedShape narrow_prepared_;  // the narrow phase's prepared sphere (as World does)
  std::unique_ptr<vadop::BroadPhase> bp_;
  RequeryMode mode_;
  std::vector<vadop::Motion> motions_;
  struct alignas(64) Kinematics {  // of motions_[i]: position at t_ref, t_ref, velocity
    Eigen::Vector3d p;
    double t_ref;
    Eigen::Vector3d v;
    // = vadop::Motion::positionAt (the bodies only translate), the same arithmetic.
    Eigen::Vector3d at(double t) const { return p + v * (t - t_ref); }
  };
  // sweptBox(motions_[i], broad radius, ta, tb) from the compact copy (the same box).
  Box pathBox(uint32_t i, double ta, double tb) const;
  std::vector<Kinematics> kin_;
  vadop::ImpactQueue queue_;
  RequeryGrid grid_;
  void prepareRequeryGrid(int f);
  bool grid_built_ = false;             // prepared for this frame
  int grid_first_frame_ = 0, grid_last_frame_ = 0;  // the grid holds the paths of these frames
                                                    // (last excluded)
  std::vector<uint8_t> moved_flag_;     // changed velocity since the grid was built
  std::vector<uint32_t> moved_since_build_;
  std::vector<Box> boxes_;
  std::vector<uint32_t> scratch_;
  double frame_t1_ = 0;
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
