// The VADOP broad phase at scale: each body's velocity-aligned volume (vadop.h) plus its swept
// AABB, with the spatial search done by a uniform grid of swept AABBs instead of one sorted
// list per pool axis. A pair is a candidate iff the swept AABBs overlap and the intervals
// overlap on every pool axis the two bodies share.
// Why not the per-axis lists of sweep_prune.h: in a world of constant density the n intervals
// of one axis crowd into a length that grows like n^(1/3), so each list holds ~n^(5/3)
// overlapping pairs to maintain, of which only O(n) are candidates (README, "Broad phase").
// The grid finds the O(n) nearby pairs in O(n) per frame; VADOP then prunes them. The grid is
// rebuilt each frame, except in slow scenes: there the pairs of overlapping "fat" boxes
// (fat_box_pairs.h) are kept from frame to frame and only bodies that leave their fat boxes are
// re-gridded (incremental mode; same candidates). Its update splits bodies and cells over
// setThreads() threads (same candidates) and takes the caller's swept AABBs when given
// (setFrameBoxes: the World's cull has them). It does not compute contacts; not thread-safe.
#pragma once

#include "vadop/axis_pool.h"
#include "vadop/broad_phase.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace vadop {

class FatBoxPairs;  // internal (src/fat_box_pairs.h)
namespace detail {
class CellGrid;  // internal (src/cell_grid.h)
}

class VadopGridBroadPhase : public BroadPhase {
 public:
  // cell_size (m): 0 chooses it each frame from the bodies' swept boxes (0.5 to 3 times the
  // median box, by an estimated cost; see computePairs).
  // incremental: the incremental mode for slow scenes (fat boxes kept from frame to frame, see
  // computePairs) is used while at most this fraction of the bodies leave their fat boxes in a
  // frame; 0 turns it off, 1 uses it whatever the scene (for tests).
  // Throws vadop::InvalidArgument for a bad configuration (validateVadopConfig), a cell size
  // that is negative or not finite, or `incremental` outside [0, 1].
  static constexpr double kDefaultIncremental = 0.25;
  explicit VadopGridBroadPhase(const VadopConfig& config, double cell_size = 0.0,
                               double incremental = kDefaultIncremental);
  ~VadopGridBroadPhase() override;

  // The plain uniform grid of swept AABBs ("grid"): the same cells, cell-size rule and
  // incremental mode without velocity-aligned axes, so a pair is a candidate iff the swept
  // AABBs overlap. The strongest simple baseline, and what the axes are measured against (as
  // SweepPruneBroadPhase::makeEveryAxis(3) is for sweep and prune). Throws as the constructor.
  static std::unique_ptr<VadopGridBroadPhase> makeBoxOnly(double cell_size = 0.0,
                                                          double incremental = kDefaultIncremental);

  std::string name() const override { return pool_ ? "vadop" : "grid"; }
  size_t memoryBytes() const override;

  // The axis pool of a velocity-aligned engine; throws vadop::InvalidArgument for makeBoxOnly's.
  const AxisPool& pool() const;
  double phi() const { return phi_; }  // radians; 0 without pool
  bool velocityAligned() const { return pool_ != nullptr; }

  using AxisSpan = SweepPruneBroadPhase::AxisSpan;

  // Queries (BroadPhase::query) over [t0, t1] within the frame of the last update are answered
  // from that frame's cells: the bodies whose frame boxes overlap the query's swept AABB over
  // [t0, t1] (a frame box holds the body's swept box over every sub-interval); BroadPhase adds
  // the bodies changed since. Cost: the cells the query box spans and their occupancy (in the
  // incremental mode, which builds no cells, those of the fat boxes' grid: every frame box lies
  // in its body's fat box).
  // The answer is every body whose swept AABB may overlap the query's (no pool-axis pruning: a
  // superset of the update's candidates by at most the bodies whose boxes overlap but whose
  // pool intervals do not).
  struct Stats {
    size_t cells = 0;           // occupied cells
    size_t cell_entries = 0;    // (body, cell) incidences
    size_t large_bodies = 0;    // bodies too large for the grid, tested against everyone
    size_t box_tests = 0;       // AABB tests of bodies sharing a cell
    size_t overlap_tests = 0;   // shared-axis tests (after the AABB and duplicate checks)
    size_t reinserted = 0;      // bodies whose axis set changed (or new) in the last update
    double cell_size = 0;       // of the last update (m)
    bool incremental = false;   // the last update used the fat boxes (else the full rebuild)
    bool fat_rebuilt = false;   // ... and had to build them from scratch
    size_t escaped = 0;         // bodies given new fat boxes in the last incremental update
    size_t fat_pairs = 0;       // pairs of overlapping fat boxes kept
    double update_seconds = 0;  // c_u: axis selection, intervals and boxes (incremental mode:
                                // the intervals needed are computed on demand, in c_s)
    double sort_seconds = 0;    // c_s: grid and pair tests
  };
  const Stats& stats() const { return stats_; }

 protected:
  void onAdd(BodyId id) override;
  void onRemove(BodyId id) override;
  void onSetMotion(BodyId id) override;
  void computePairs(double t0, double t1, std::vector<Pair>& out) override;
  bool queryFrame(const double* box, std::vector<BodyId>& out) override;

 private:
  friend struct BroadPhaseTestAccess;  // the tests' view of the volumes (tests/broad_phase_access.h)
  // The body's volume of the last update: its pool axes (ascending) with their intervals,
  // followed by the swept AABB as three spans on the "axes" pool().size() + 0, 1, 2 (x, y, z),
  // which every body has. Empty for a body added since.
  std::vector<AxisSpan> volume(BodyId id) const;
  // Unit direction of a span's axis (pool axis, or x, y, z past the pool).
  Eigen::Vector3d axisDirection(uint32_t axis) const;
  struct BoxOnly {};
  VadopGridBroadPhase(BoxOnly, double cell_size, double incremental);
  void setOptions(double cell_size, double incremental);
  // Cell size by the estimated cost of the frame's boxes (step 3 of computePairs).
  double chooseCellSize(const double* world_lo, const double* world_hi);
  // The steps of computePairs: 1. new axis sets for the bodies whose motion changed; 2. the
  // alive bodies' slots, swept boxes, axis ranks and interval offsets; 3. the cells of the
  // boxes; 4. the pairs of overlapping boxes of each cell into hits_.
  void selectChangedAxes(double frame, int threads);
  void assignSlots(double t0, double t1, size_t slots, int threads);
  void buildCells(size_t slots);
  void testCellPairs(int threads, size_t blocks);
  static constexpr uint32_t kNoSlot = ~uint32_t{0};
  // Pairs of slots whose boxes overlap, found in one block of the work (cells, or slots in the
  // incremental mode), and the box tests that found them.
  struct SlotPair {
    uint32_t a, b;
  };
  struct SlotPairs {
    std::vector<SlotPair> pairs;
    size_t box_tests = 0;
    size_t shared_tests = 0;  // pairs whose boxes overlap (their shared axes tested)
    void clear() {
      pairs.clear();
      box_tests = 0;
      shared_tests = 0;
    }
  };
  // A pair whose boxes overlap, into `hits` for testSharedAxes.
  void boxHit(uint32_t a, uint32_t b, SlotPairs& hits);
  void clearAxes(BodyId id);
  // Each slot of `large` (ascending not required) against every other slot, each pair once.
  void testLargeAgainstAll(const std::vector<uint32_t>& large, SlotPairs& hits);
  // The incremental mode's pairs of overlapping boxes into hits_ (blocks of slots on `threads`
  // threads); false when it declines (the full path then runs).
  bool computeFromFatBoxes(double step, int threads, size_t blocks);
  // Its fat boxes built from scratch (false: not worth it at this escape rate), or those of
  // the bodies that left theirs renewed (false: too many left, the full path takes over).
  bool rebuildFatBoxes(double step, int threads);
  bool refreshFatBoxes(double step, int threads);
  void appendFatBox(uint32_t slot, double step);
  double expectedEscapeRate(double step) const;
  bool boxesOverlap(uint32_t a, uint32_t b) const;
  bool overlapOnShared(uint32_t a, uint32_t b) const;  // needs both slots' intervals
  // The pairs of hits_ whose intervals overlap on every shared pool axis, into `out`; the
  // intervals of their slots first (each once, in slot order). Counts the tests in stats_.
  void testSharedAxes(int threads, std::vector<Pair>& out);
  // f(axis, interval) for each pool axis of slot s: its body's swept volume over the last
  // update's frame moving with `motion` (the update's), projected now.
  template <class F>
  void forEachProjected(uint32_t s, const Motion& motion, F&& f) const;
  // The slot's pool-axis intervals (see intervals_); slots are independent.
  void projectSlot(uint32_t s);

  std::unique_ptr<AxisPool> pool_;
  VadopConfig config_;
  double phi_ = 0.0;
  AxisZones zones_{};
  double cell_size_ = 0.0;
  size_t words_ = 1;  // 64-bit words of an axis bitset

  // Persistent per body (indexed by BodyId): its axis set as a bitset (words_ per body, flat:
  // the per-frame pass reads it sequentially), and whether its motion changed.
  std::vector<uint64_t> axis_bits_;
  std::vector<Eigen::Vector3d> axis_direction_;  // the direction axis_bits_ was chosen about
  std::vector<uint8_t> dirty_flag_;
  std::vector<BodyId> dirty_;
  std::vector<BodyId> scratch_changed_;  // the dirty bodies of an update, each once

  // Per frame, per slot (the alive bodies in id order), contiguous for the pair loops.
  std::vector<BodyId> slot_body_;
  std::vector<uint32_t> slot_of_;      // BodyId -> slot of the last update, or kNoSlot
  std::vector<double> box_;            // 6 per slot: lo x y z, hi x y z
  std::vector<uint64_t> bits_;         // words_ per slot
  std::vector<uint16_t> rank_;         // words_ per slot: entries before each word
  std::vector<uint32_t> offset_;       // first interval of the slot
  // All slots' pool-axis intervals, computed for the slots of pairs whose boxes overlap only
  // (testSharedAxes; most slots in a crowded frame, few in a sparse one); interval_ready_ says
  // which are set. A slot whose intervals were not computed and whose body got a new motion
  // since keeps the update's motion in update_motion_ (for volume(); copying it costs a tenth
  // of projecting, and setMotion runs for every body every cycle in the monitor).
  static constexpr uint8_t kIntervalsSet = 1, kMotionKept = 3;
  std::vector<Interval> intervals_;
  std::vector<uint8_t> interval_ready_;
  std::vector<Motion> update_motion_;  // per slot, valid where interval_ready_ is kMotionKept
  std::vector<SlotPairs> hits_;          // per block of the last update, the large bodies' last
  std::vector<uint32_t> scratch_slots_;  // the slots whose intervals an update computes
  double frame_t0_ = 0.0, frame_t1_ = 0.0;  // of the last update
  bool framed_ = false;      // an update has run (the slots and boxes describe its frame)
  bool cells_ready_ = false; // grid_ holds the cells of the last update's boxes
  std::unique_ptr<detail::CellGrid> grid_;  // the frame's cells (slots as items)
  std::vector<uint32_t> large_slots_;  // the fat path's large bodies as slots (grid_ lists its own)
  std::vector<double> scratch_extent_;

  // Incremental mode: the fat boxes and their pairs, and when to (re)build them. After a
  // frame where too many bodies left their fat boxes, the full path runs for backoff_ frames
  // (doubling up to 64) before the next attempt: a fast scene pays for few attempts.
  double incremental_ = 0.0;
  std::unique_ptr<FatBoxPairs> fat_;
  bool fat_valid_ = false;
  int retry_wait_ = 0, backoff_ = 1, streak_ = 0;
  std::vector<BodyId> fat_ids_;
  std::vector<double> fat_boxes_;
  std::vector<uint8_t> scratch_large_;
  Stats stats_;
};

}  // namespace vadop
