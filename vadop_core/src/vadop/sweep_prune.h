// Incremental sweep and prune over the axes of an axis pool, the engine of the VADOP broad
// phase and of its fixed-axis baselines (k-DOP, and AABB with the 3 coordinate axes).
// Each pool axis keeps a sorted array of the endpoints of the bodies that use it; every
// update re-sorts by insertion sort, and the swaps that start or end an overlap maintain a
// hash set of candidate pairs: a pair is a candidate iff its intervals overlap on every
// axis the two bodies share. Memory is O(sum of axes used + candidate pairs); there is no
// n x n matrix. It does not compute contacts (narrow phase) and is not thread-safe.
#pragma once

#include "vadop/axis_pool.h"
#include "vadop/broad_phase.h"
#include "vadop/pair_set.h"
#include "vadop/vadop.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace vadop {

class SweepPruneBroadPhase : public BroadPhase {
 public:
  // VADOP: each body uses the pool axes nearly orthogonal to its velocity (see vadop.h).
  // Throws vadop::InvalidArgument for a bad configuration (see validateVadopConfig).
  explicit SweepPruneBroadPhase(const VadopConfig& config);

  // Fixed-axis sweep and prune: every body on every axis of an m-axis pool; m = 3 is the
  // classic sweep and prune of swept AABBs on x, y, z.
  static std::unique_ptr<SweepPruneBroadPhase> makeEveryAxis(int m);

  std::string name() const override;
  size_t memoryBytes() const override;

  const AxisPool& pool() const { return *pool_; }
  double phi() const { return phi_; }  // radians
  bool velocityAligned() const { return aligned_; }

  struct AxisSpan {
    uint32_t axis;
    Interval interval;
  };

  struct Stats {
    size_t endpoints = 0;      // in all lists
    size_t swaps = 0;          // insertion-sort moves in the last update
    size_t overlap_tests = 0;  // shared-axis tests triggered by swaps and queries
    size_t reinserted = 0;     // bodies whose axis set changed (or new) in the last update
    double update_seconds = 0; // c_u: axis selection and new intervals
    double sort_seconds = 0;   // c_s: re-sorting the lists and maintaining the pairs
  };
  const Stats& stats() const { return stats_; }

 protected:
  void onAdd(BodyId id) override;
  void onRemove(BodyId id) override;
  void onSetMotion(BodyId id) override;
  void computePairs(double t0, double t1, std::vector<Pair>& out) override;
  // From the sorted lists of the last update: the bodies whose intervals overlap the box's
  // projection on every axis they use (a binary search and a scan per axis: every axis for
  // the velocity-aligned engine, one for the every-axis ones, whose bodies all use each).
  bool queryFrame(const double* box, std::vector<BodyId>& out) override;

 private:
  friend struct BroadPhaseTestAccess;  // the tests' view of the volumes (tests/broad_phase_access.h)
  // The body's volume of the last update: its axes (ascending) and intervals. Empty for a
  // body added since.
  std::vector<AxisSpan> volume(BodyId id) const;

  SweepPruneBroadPhase(std::unique_ptr<AxisPool> pool, const VadopConfig& config, bool aligned);

  struct Entry {  // one axis of one body
    uint32_t axis;
    double lo, hi;
  };
  // Endpoints do not know their position and bodies do not track them: every update refreshes
  // the values in one sequential pass per list, which costs one read per endpoint, where
  // tracking positions costs a random write per swap. An endpoint whose generation differs from
  // its body's is stale (the body left the list) and is dropped by that pass.
  struct Endpoint {
    double value;
    uint32_t body;
    uint32_t ref;  // generation << 13 | entry index << 1 | 1 for a max endpoint
    bool isMax() const { return ref & 1u; }
    uint32_t entry() const { return (ref >> 1) & 0xfffu; }
    uint32_t generation() const { return ref >> 13; }
  };
  static uint32_t makeRef(uint32_t generation, uint32_t entry, bool is_max) {
    return (generation << 13) | (entry << 1) | (is_max ? 1u : 0u);
  }
  struct State {
    std::vector<Entry> entries;  // ascending axis
    // Which axes the body uses, one bit per pool axis, and for each 64-bit word the number of
    // entries before it: the shared axes of two bodies are an AND away, and an axis' entry is
    // found by a popcount. ceil(m / 64) words: fewer bits than the body has entries whenever
    // sin(phi) > 1/64, which phi >= rho guarantees for every pool size allowed.
    std::vector<uint64_t> axis_bits;
    std::vector<uint16_t> rank;
    uint32_t generation = 0;     // of its live endpoints (19 bits)
    bool listed = false;         // endpoints are in the lists
    bool dirty = false;          // motion changed since the last update
  };
  bool isLive(const Endpoint& e) const {
    const State& s = states_[e.body];
    return s.listed && s.generation == e.generation();
  }
  void setAxes(State& s, const std::vector<uint32_t>& axes);

  static bool before(const Endpoint& x, const Endpoint& y) {
    // Closed intervals: at equal values a min sorts before a max, so touching counts.
    return x.value < y.value || (x.value == y.value && !x.isMax() && y.isMax());
  }
  // Whether the two bodies' intervals overlap on every axis they share (src/axis_set.h).
  bool overlapOnShared(BodyId a, BodyId b);
  void unlist(BodyId id);  // erase its pairs, make its endpoints stale
  template <class F>
  void forEachOverlapOnAxis(BodyId id, const Entry& e, F&& f) const;
  void refresh(uint32_t axis);  // drop stale endpoints, load the new values
  void insertionSort(uint32_t axis);
  void mergePending(uint32_t axis);

  std::unique_ptr<AxisPool> pool_;
  VadopConfig config_;
  bool aligned_ = true;
  double phi_ = 0.0;
  AxisZones zones_{};
  std::vector<State> states_;
  std::vector<BodyId> dirty_;
  std::vector<std::vector<Endpoint>> lists_;
  std::vector<std::vector<Endpoint>> pending_;
  std::vector<double> max_length_;
  std::vector<uint32_t> query_stamp_;  // by BodyId: bodies already tested in this query
  uint32_t query_now_ = 0;
  PairSet pairs_;
  Stats stats_;
};

}  // namespace vadop
