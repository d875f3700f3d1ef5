// The uniform grid of axis-aligned boxes behind every grid of the broad phases: cells keyed by
// exact integer coordinates (floor of a coordinate over the cell size), each box listed in
// every cell it spans, a box spanning more than kMaxCells cells (or beyond the coordinate
// range) kept apart as "large" for the caller to test. It is filled one of two ways:
//  - build(): a batch of boxes at once, each cell's entries contiguous and carrying a copy of
//    their box (the per-frame grid of VadopGridBroadPhase, whose pair loops walk the cells);
//  - set() / remove(): one box at a time, entries chained per cell, a replaced box's entries
//    left stale and skipped (the kept fat boxes of fat_box_pairs.h, the bodies a broad phase's
//    queries see changed since its update).
// Either way forEachOverlap answers which boxes overlap a query box, each once. It knows
// nothing of motion or time, and it is not thread-safe.
#pragma once

#include "grid_cells.h"
#include "vadop/detail/large_array.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vadop {
namespace detail {

class CellGrid {
 public:
  static constexpr size_t kMaxCells = 256;
  // Cell coordinates of listed boxes stay within +-kMaxCoordinate (exact in int32).
  static constexpr double kMaxCoordinate = 1 << 29;
  static constexpr uint32_t kEmpty = ~uint32_t{0};

  struct Cell {
    int32_t x, y, z;
  };
  struct Entry {  // one (box, cell) incidence of build()
    double box[6];      // lo x y z, hi x y z
    int32_t lo_cell[3]; // cell of the box's lo corner
    uint32_t item;
  };

  // Empties the grid for set(): cells of size h (> 0, finite; throws InvalidArgument
  // otherwise), or coarser if box coordinates reach max_abs (their largest magnitude), so that
  // boxes stay in the coordinate range instead of all becoming large.
  void reset(double h, double max_abs = 0.0);
  // Empties the grid and lists items 0 .. count-1 with `boxes` (6 doubles each) in cells of
  // size h (> 0, finite; the caller keeps coordinates / h within kMaxCoordinate, boxes beyond
  // it are large). set() and remove() need a reset() after it.
  void build(const double* boxes, size_t count, double h);
  double cellSize() const { return h_; }

  // --- one box at a time (after reset()) ---
  bool has(uint32_t item) const { return item < state_.size() && state_[item] != kNone; }
  bool isLarge(uint32_t item) const { return item < state_.size() && state_[item] == kLarge; }
  // The box of `item` (lo x y z, hi x y z); only while has(item).
  const double* box(uint32_t item) const { return &box_[6 * static_cast<size_t>(item)]; }
  void set(uint32_t item, const double* box);  // replaces any box it had
  void remove(uint32_t item);                  // no-op without a box
  size_t items() const { return items_; }
  // Stale entries outnumber live ones 3 to 1: reset to give the memory back.
  bool wasteful() const { return nodes_.size() > 4 * live_nodes_ + 4096; }
  // Drops the stale entries from the cells' chains when they are more than half the live ones,
  // packing each cell's live entries side by side in their order (a query then walks one run
  // of memory instead of live entries strewn among two stale ones or more). O(entries).
  void compactIfStale();

  // --- either way ---
  // Calls f(item) once for every item (large ones excluded) whose box overlaps `box` (closed
  // intervals), reported from the cell holding the lo corner of the two boxes' intersection.
  template <class F>
  void forEachOverlap(const double* box, F&& f) const;
  // The large items (build(): ascending).
  const std::vector<uint32_t>& large() const { return large_; }

  // --- the cells of build(), for pair loops ---
  size_t cellCount() const { return cells_.size(); }
  const Cell& cell(size_t c) const { return cells_[c]; }
  // Entries of cell c, [first, last): the caller may reorder them within the cell.
  Entry* entriesBegin(size_t c) { return entries_.data() + cell_start_[c]; }
  Entry* entriesEnd(size_t c) { return entries_.data() + cell_start_[c + 1]; }
  size_t entryCount() const { return built_ ? entries_.size() : 0; }

  size_t memoryBytes() const;

 private:
  enum : uint8_t { kNone = 0, kGrid = 1, kLarge = 2 };
  struct Node {  // one (box, cell) incidence of set()
    uint32_t item;
    uint32_t version;
    int32_t next;
  };
  // Cell range of a box; false if it spans more than kMaxCells cells or leaves the
  // coordinate range (also for NaN).
  bool cellRange(const double* box, int32_t lo[3], int32_t hi[3]) const;
  void clear();  // all but the hash table's contents
  void setCellSize(double h);  // throws InvalidArgument unless finite and > 0 (nothing changed)
  void resizeTable(size_t capacity);
  // The steps of build(): each box's cell range (lo corners into lo_scratch_, boxes spanning
  // too many cells into large_; returns the incidences, widens [cmin, cmax] to the occupied
  // range); a dense array or the hash table to find cells by; the (cell, item) incidences;
  // their counting sort by cell into entries_ and cell_start_.
  size_t cellRanges(const double* boxes, size_t count, int32_t* cmin, int32_t* cmax);
  void chooseCellIndex(size_t count, size_t incidences, const int32_t* cmin, const int32_t* cmax);
  void listIncidences(const double* boxes, size_t count, size_t incidences);
  void sortIncidences(const double* boxes);
  uint32_t findCell(int32_t x, int32_t y, int32_t z) const;  // or kEmpty
  uint32_t insertCell(int32_t x, int32_t y, int32_t z);      // find or add, growing the table
  uint32_t addCell(int32_t x, int32_t y, int32_t z);         // find or add, table large enough
  static bool overlaps(const double* a, const double* b) {
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
  }
  template <class F>
  void scanAll(const double* box, F&& f) const;

  double h_ = 1.0, inv_h_ = 1.0;
  bool built_ = false;  // filled by build() (else by set())

  // Cell lookup: an open-addressing hash table of cell coordinates, or (build() of a compact
  // set of cells) an array over their range; cell index -> coordinates in cells_.
  std::vector<Cell> table_key_;
  std::vector<uint32_t> table_cell_;  // cell index, or kEmpty
  size_t table_mask_ = 0;
  bool dense_ = false;
  LargeArray<uint32_t> dense_cell_;  // cell index or kEmpty (all kEmpty while !dense_)
  int32_t dense_min_[3] = {0, 0, 0}, dense_dim_[3] = {0, 0, 0};
  size_t denseIndex(int32_t x, int32_t y, int32_t z) const {
    return (static_cast<size_t>(z - dense_min_[2]) * static_cast<size_t>(dense_dim_[1]) +
            static_cast<size_t>(y - dense_min_[1])) * static_cast<size_t>(dense_dim_[0]) +
           static_cast<size_t>(x - dense_min_[0]);
  }
  std::vector<Cell> cells_;

  // build(): entries sorted by cell (counting sort).
  LargeArray<uint32_t> cell_start_;
  LargeArray<Entry> entries_;
  std::vector<int32_t> lo_scratch_;
  std::vector<uint32_t> entry_cell_, entry_item_;

  // set(): per cell the first node of its chain; per item its state, box, lo-corner cell and
  // version (nodes of older versions are stale).
  std::vector<int32_t> head_;
  std::vector<Node> nodes_;
  size_t live_nodes_ = 0, items_ = 0;
  std::vector<uint8_t> state_;
  std::vector<uint32_t> version_;
  std::vector<double> box_;
  std::vector<int32_t> lo_cell_;
  std::vector<uint32_t> large_;
};

// Spreads a cell's coordinates over the hash table.
inline uint64_t cellHash(int32_t x, int32_t y, int32_t z) {
  return mixCellKey((static_cast<uint64_t>(static_cast<uint32_t>(x)) * 0x9e3779b1u) ^
                    (static_cast<uint64_t>(static_cast<uint32_t>(y)) << 21) ^
                    (static_cast<uint64_t>(static_cast<uint32_t>(z)) << 42));
}

inline bool CellGrid::cellRange(const double* box, int32_t lo[3], int32_t hi[3]) const {
  size_t count = 1;
  for (int k = 0; k < 3; ++k) {
    const double a = box[k] * inv_h_, b = box[3 + k] * inv_h_;
    if (!(a > -kMaxCoordinate && b < kMaxCoordinate)) return false;  // also NaN
    lo[k] = floorToInt(a);
    hi[k] = floorToInt(b);
    if (hi[k] < lo[k]) return false;  // an inverted box: no cell
    count *= static_cast<size_t>(hi[k] - lo[k] + 1);
    if (count > kMaxCells) return false;
  }
  return true;
}

inline uint32_t CellGrid::findCell(int32_t x, int32_t y, int32_t z) const {
  if (dense_) {
    if (x < dense_min_[0] || y < dense_min_[1] || z < dense_min_[2] || x >= dense_min_[0] + dense_dim_[0] ||
        y >= dense_min_[1] + dense_dim_[1] || z >= dense_min_[2] + dense_dim_[2]) {
      return kEmpty;
    }
    return dense_cell_[denseIndex(x, y, z)];
  }
  if (table_cell_.empty()) return kEmpty;
  for (size_t i = cellHash(x, y, z) & table_mask_;; i = (i + 1) & table_mask_) {
    const uint32_t cell = table_cell_[i];
    if (cell == kEmpty) return kEmpty;
    const Cell& k = table_key_[i];
    if (k.x == x && k.y == y && k.z == z) return cell;
  }
}

inline uint32_t CellGrid::insertCell(int32_t x, int32_t y, int32_t z) {
  if (2 * (cells_.size() + 1) > table_cell_.size()) resizeTable(std::max<size_t>(16, 2 * table_cell_.size()));
  return addCell(x, y, z);
}

inline uint32_t CellGrid::addCell(int32_t x, int32_t y, int32_t z) {
  if (dense_) {
    uint32_t& cell = dense_cell_[denseIndex(x, y, z)];
    if (cell == kEmpty) {
      cell = static_cast<uint32_t>(cells_.size());
      cells_.push_back(Cell{x, y, z});
    }
    return cell;
  }
  for (size_t i = cellHash(x, y, z) & table_mask_;; i = (i + 1) & table_mask_) {
    const uint32_t cell = table_cell_[i];
    if (cell == kEmpty) {
      table_key_[i] = Cell{x, y, z};
      table_cell_[i] = static_cast<uint32_t>(cells_.size());
      cells_.push_back(Cell{x, y, z});
      return table_cell_[i];
    }
    const Cell& k = table_key_[i];
    if (k.x == x && k.y == y && k.z == z) return cell;
  }
}

template <class F>
void CellGrid::scanAll(const double* box, F&& f) const {
  if (built_) {  // each item once: from the entry in its own lo-corner cell
    for (size_t c = 0; c < cells_.size(); ++c) {
      const Cell& k = cells_[c];
      for (uint32_t e = cell_start_[c]; e < cell_start_[c + 1]; ++e) {
        const Entry& en = entries_[e];
        if (en.lo_cell[0] == k.x && en.lo_cell[1] == k.y && en.lo_cell[2] == k.z && overlaps(box, en.box)) f(en.item);
      }
    }
    return;
  }
  for (uint32_t i = 0; i < state_.size(); ++i) {
    if (state_[i] == kGrid && overlaps(box, this->box(i))) f(i);
  }
}

template <class F>
void CellGrid::forEachOverlap(const double* box, F&& f) const {
  if (cells_.empty()) return;
  int32_t lo[3], hi[3];
  if (!cellRange(box, lo, hi)) {  // a query as large as that: every listed item, once
    scanAll(box, f);
    return;
  }
  // An item is listed in every cell it spans: it is reported from the cell holding the lo
  // corner of its overlap with the query, a cell both span.
  auto here = [&](const int32_t* item_lo, int32_t x, int32_t y, int32_t z) {
    return std::max(item_lo[0], lo[0]) == x && std::max(item_lo[1], lo[1]) == y && std::max(item_lo[2], lo[2]) == z;
  };
  if (built_) {
    // In three passes (the cells, their entry ranges, the entries), so that the memory loads of
    // the cells overlap instead of each waiting for the previous cell's entries: a query of a
    // random body is bound by these loads once the grid outgrows the caches. cellRange bounds
    // the cells by kMaxCells.
    struct Found {
      int32_t x, y, z;
      uint32_t cell;
    };
    Found found[kMaxCells];
    size_t count = 0;
    for (int32_t z = lo[2]; z <= hi[2]; ++z) {
      for (int32_t y = lo[1]; y <= hi[1]; ++y) {
        for (int32_t x = lo[0]; x <= hi[0]; ++x) {
          const uint32_t c = findCell(x, y, z);
          if (c != kEmpty) found[count++] = Found{x, y, z, c};
        }
      }
    }
    for (size_t i = 0; i < count; ++i) __builtin_prefetch(entries_.data() + cell_start_[found[i].cell]);
    for (size_t i = 0; i < count; ++i) {
      const Found& k = found[i];
      for (uint32_t e = cell_start_[k.cell]; e < cell_start_[k.cell + 1]; ++e) {
        const Entry& en = entries_[e];
        if (overlaps(box, en.box) && here(en.lo_cell, k.x, k.y, k.z)) f(en.item);
      }
    }
    return;
  }
  for (int32_t z = lo[2]; z <= hi[2]; ++z) {
    for (int32_t y = lo[1]; y <= hi[1]; ++y) {
      for (int32_t x = lo[0]; x <= hi[0]; ++x) {
        const uint32_t c = findCell(x, y, z);
        if (c == kEmpty) continue;
        for (int32_t k = head_[c]; k >= 0; k = nodes_[k].next) {
          const Node& node = nodes_[k];
          const uint32_t i = node.item;
          if (node.version != version_[i]) continue;
          if (overlaps(box, this->box(i)) && here(&lo_cell_[3 * static_cast<size_t>(i)], x, y, z)) f(i);
        }
      }
    }
  }
}

}  // namespace detail
}  // namespace vadop
