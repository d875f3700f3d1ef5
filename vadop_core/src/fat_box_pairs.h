// The pairs a slow scene keeps from frame to frame: each body has a "fat" box (a box expected
// to contain its swept boxes for some frames to come), a hash grid holds the fat boxes, and each
// body lists the bodies whose fat boxes overlap its own. Changing a body's fat box costs
// O(cells it spans x their occupancy); bodies whose fat boxes did not change keep their pairs.
// VadopGridBroadPhase's incremental mode is built on it. It knows nothing of swept volumes or
// time (the caller decides when a fat box no longer holds), and it is not thread-safe.
#pragma once

#include "vadop/broad_phase.h"
#include "vadop/detail/flat_map.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vadop {

class FatBoxPairs {
 public:
  // A fat box spanning more cells than this is "large": it is kept out of the grid and off the
  // partner lists, and the caller tests it against every body.
  static constexpr size_t kMaxCells = 256;

  // Forgets every body; the next update() uses cell size h (> 0, finite), or coarser cells if
  // box coordinates reach max_abs (their largest magnitude), so that cells stay in the key range.
  void reset(double h, double max_abs = 0.0);
  double cellSize() const { return h_; }

  bool has(BodyId id) const { return id < state_.size() && state_[id] != kNone; }
  bool isLarge(BodyId id) const { return id < state_.size() && state_[id] == kLarge; }
  // Whether box (lo x y z, hi x y z) lies inside the fat box of `id` (false if it has none).
  bool contains(BodyId id, const double* box) const;
  // Sets the fat boxes of `ids` (6 doubles each in `boxes`, lo x y z then hi x y z; ids
  // distinct), replacing those they had, and brings their partner lists up to date.
  void update(const std::vector<BodyId>& ids, const std::vector<double>& boxes);
  // Forgets `id` (no-op if it has no fat box).
  void remove(BodyId id);

  // Bodies in the grid whose fat boxes overlap that of `id` (empty for a large body).
  const std::vector<BodyId>& partners(BodyId id) const { return adj_[id]; }
  const std::vector<BodyId>& large() const { return large_; }

  size_t bodies() const { return bodies_; }
  size_t pairs() const { return pair_count_; }
  // Stale grid entries (left by bodies that moved) outnumber live ones 3 to 1: reset and
  // rebuild to give the memory back.
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
  void unlinkPartners(BodyId id);

  double h_ = 1.0, inv_h_ = 1.0;
  std::vector<uint8_t> state_;            // per BodyId
  std::vector<uint32_t> version_;         // per BodyId: grid nodes of older versions are stale
  std::vector<double> box_;               // 6 per BodyId
  std::vector<std::vector<BodyId>> adj_;  // per BodyId
  std::vector<BodyId> large_;
  detail::FlatMap<uint64_t, int32_t, KeyHash> cells_;  // cell key -> first node
  std::vector<Node> nodes_;
  size_t live_nodes_ = 0, bodies_ = 0, pair_count_ = 0;
  std::vector<uint8_t> in_update_;        // per BodyId, during update()
  std::vector<uint32_t> stamp_;           // per BodyId, dedup within one query
  uint32_t stamp_now_ = 0;
};

}  // namespace vadop
