// The pairs a slow scene keeps from frame to frame: each body has a "fat" box (a box expected
// to contain its swept boxes for some frames to come), a hash grid holds the fat boxes, and each
// body lists the bodies whose fat boxes overlap its own (the grid is detail::CellGrid, filled box by box). Changing a body's fat box costs
// O(cells it spans x their occupancy); bodies whose fat boxes did not change keep their pairs.
// VadopGridBroadPhase's incremental mode is built on it. It knows nothing of swept volumes or
// time (the caller decides when a fat box no longer holds), and it is not thread-safe.
#pragma once

#include "vadop/broad_phase.h"
#include "cell_grid.h"

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vadop {

class FatBoxPairs {
 public:
  // A fat box spanning more cells than this is "large": it is kept out of the grid and off the
  // partner lists, and the caller tests it against every body.
  static constexpr size_t kMaxCells = detail::CellGrid::kMaxCells;

  // Forgets every body; the next update() uses cell size h (> 0, finite), or coarser cells if
  // box coordinates reach max_abs (their largest magnitude), so that cells stay in the key range.
  void reset(double h, double max_abs = 0.0);
  double cellSize() const { return grid_.cellSize(); }

  bool has(BodyId id) const { return grid_.has(id); }
  bool isLarge(BodyId id) const { return grid_.isLarge(id); }
  // Whether box (lo x y z, hi x y z) lies inside the fat box of `id` (false if it has none).
  bool contains(BodyId id, const double* box) const;
  // Sets the fat boxes of `ids` (6 doubles each in `boxes`, lo x y z then hi x y z; ids
  // distinct), replacing those they had, and brings their partner lists up to date. The grid
  // queries of the new boxes run on up to `threads` threads; the lists come out the same,
  // in the same order, whatever the count.
  void update(const std::vector<BodyId>& ids, const std::vector<double>& boxes, int threads = 1);
  // Forgets `id` (no-op if it has no fat box).
  void remove(BodyId id);

  // Bodies in the grid whose fat boxes overlap that of `id` (empty for a large body).
  const std::vector<BodyId>& partners(BodyId id) const { return adj_[id]; }
  const std::vector<BodyId>& large() const { return grid_.large(); }
  // Calls f(j) once for every body in the grid (large ones excluded) whose fat box overlaps
  // `box` (lo x y z, hi x y z).
  template <class F>
  void forEachOverlap(const double* box, F&& f) {
    grid_.forEachOverlap(box, std::forward<F>(f));
  }

  size_t bodies() const { return grid_.items(); }
  size_t pairs() const { return pair_count_; }
  // Reset and rebuild to give the memory of stale grid listings back.
  bool wasteful() const { return grid_.wasteful(); }
  size_t memoryBytes() const;

 private:
  void unlinkPartners(BodyId id);

  detail::CellGrid grid_;
  std::vector<std::vector<BodyId>> adj_;  // per BodyId
  std::vector<uint8_t> in_update_;        // per BodyId, during update()
  // update()'s new pairs (id, partner), per block of its ids: kept for their storage.
  std::vector<std::vector<std::pair<BodyId, BodyId>>> found_;
  size_t pair_count_ = 0;
};

}  // namespace vadop
