// A hash grid of axis-aligned boxes that change one at a time: each body's box is listed in
// every cell it spans (cells keyed by a hash, so the grid is unbounded and sparse), and a box
// spanning more than kMaxCells cells is "large", kept apart for the caller to test. Replacing
// or removing a box only bumps the body's version: its old listings go stale and are skipped,
// and wasteful() tells when to reset. The kept fat boxes of the incremental grid engine
// (fat_box_pairs.h) and the bodies changed since a broad phase's update (its queries) use it.
// It knows nothing of motion or time, and it is not thread-safe.
#pragma once

#include "vadop/detail/flat_map.h"
#include "vadop/pair_set.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vadop {
namespace detail {

class BoxGrid {
 public:
  static constexpr size_t kMaxCells = 256;

  // Forgets every box; cells of size h (> 0, finite), or coarser if box coordinates reach
  // max_abs (their largest magnitude), so that cells stay in the key range.
  void reset(double h, double max_abs = 0.0);
  double cellSize() const { return h_; }

  bool has(BodyId id) const { return id < state_.size() && state_[id] != kNone; }
  bool isLarge(BodyId id) const { return id < state_.size() && state_[id] == kLarge; }
  // The box of `id` (lo x y z, hi x y z); only while has(id).
  const double* box(BodyId id) const { return &box_[6 * static_cast<size_t>(id)]; }
  // Sets the box of `id` (6 doubles), replacing any it had.
  void set(BodyId id, const double* box);
  void remove(BodyId id);  // no-op without a box

  // Calls f(j) once for every body j in the cells (large ones excluded) whose box overlaps
  // `box`. Not reentrant (one dedup stamp).
  template <class F>
  void forEachOverlap(const double* box, F&& f);
  const std::vector<BodyId>& large() const { return large_; }

  size_t bodies() const { return bodies_; }
  // Stale listings outnumber live ones 3 to 1: reset to give the memory back.
  bool wasteful() const { return nodes_.size() > 4 * live_nodes_ + 4096; }
  size_t memoryBytes() const;

 private:
  enum : uint8_t { kNone = 0, kGrid = 1, kLarge = 2 };
  struct Node {
    BodyId body;
    uint32_t version;
    int32_t next;
  };
  struct KeyHash {
    size_t operator()(uint64_t k) const;
  };
  void grow(BodyId id);
  // Cell range of a box; false if it spans more than kMaxCells cells or leaves the key range.
  bool cellRange(const double* box, int32_t lo[3], int32_t hi[3]) const;
  static uint64_t key(int32_t x, int32_t y, int32_t z);
  static bool overlaps(const double* a, const double* b) {
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
  }

  double h_ = 1.0, inv_h_ = 1.0;
  std::vector<uint8_t> state_;     // per BodyId
  std::vector<uint32_t> version_;  // per BodyId: listings of older versions are stale
  std::vector<double> box_;        // 6 per BodyId
  std::vector<BodyId> large_;
  FlatMap<uint64_t, int32_t, KeyHash> cells_;  // cell key -> first node
  std::vector<Node> nodes_;
  size_t live_nodes_ = 0, bodies_ = 0;
  std::vector<uint32_t> stamp_;    // per BodyId, dedup within one forEachOverlap
  uint32_t stamp_now_ = 0;
};

template <class F>
void BoxGrid::forEachOverlap(const double* box, F&& f) {
  int32_t lo[3], hi[3];
  if (++stamp_now_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    stamp_now_ = 1;
  }
  if (!cellRange(box, lo, hi)) {  // a query as large as that: every listed body, once
    for (BodyId j = 0; j < state_.size(); ++j) {
      if (state_[j] == kGrid && overlaps(box, this->box(j))) f(j);
    }
    return;
  }
  for (int32_t z = lo[2]; z <= hi[2]; ++z) {
    for (int32_t y = lo[1]; y <= hi[1]; ++y) {
      for (int32_t x = lo[0]; x <= hi[0]; ++x) {
        const int32_t* head = cells_.find(key(x, y, z));
        for (int32_t k = head ? *head : -1; k >= 0; k = nodes_[k].next) {
          const Node& node = nodes_[k];
          const BodyId j = node.body;
          if (node.version != version_[j] || stamp_[j] == stamp_now_) continue;
          stamp_[j] = stamp_now_;
          if (overlaps(box, this->box(j))) f(j);
        }
      }
    }
  }
}

}  // namespace detail
}  // namespace vadop
