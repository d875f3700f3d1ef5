#include "cell_grid.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace detail {
namespace {

// build() indexes its cells directly (an array over the occupied range) while that range
// holds at most this many cells per item (4 bytes each), else through the hash table.
constexpr double kDenseCellsPerItem = 8.0;

}  // namespace

void CellGrid::clear() {
  if (dense_) {
    for (const Cell& c : cells_) dense_cell_[denseIndex(c.x, c.y, c.z)] = kEmpty;
    dense_ = false;
  }
  cells_.clear();
  built_ = false;
  cell_start_.clear();  // entries_ keeps its size: build() overwrites it without zeroing it first
  head_.clear();
  nodes_.clear();
  std::fill(state_.begin(), state_.end(), kNone);
  large_.clear();
  live_nodes_ = items_ = 0;
}

void CellGrid::resizeTable(size_t capacity) {
  table_key_.resize(capacity);
  table_cell_.assign(capacity, kEmpty);
  table_mask_ = capacity - 1;
  for (uint32_t c = 0; c < cells_.size(); ++c) {  // re-insert the cells listed so far
    const Cell& k = cells_[c];
    size_t i = cellHash(k.x, k.y, k.z) & table_mask_;
    while (table_cell_[i] != kEmpty) i = (i + 1) & table_mask_;
    table_key_[i] = k;
    table_cell_[i] = c;
  }
}

void CellGrid::setCellSize(double h) {
  if (!(std::isfinite(h) && h > 0.0)) throw InvalidArgument("CellGrid: cell size must be finite and > 0, got " + formatNumber(h));
  h_ = h;
  inv_h_ = 1.0 / h;
}

void CellGrid::reset(double h, double max_abs) {
  setCellSize(h);
  // Coarser cells when coordinates reach that far (with a factor 2 to spare).
  if (std::isfinite(max_abs)) setCellSize(std::max(h, 2.0 * std::abs(max_abs) / kMaxCoordinate));
  clear();
  std::fill(table_cell_.begin(), table_cell_.end(), kEmpty);
}

void CellGrid::build(const double* boxes, size_t count, double h) {
  setCellSize(h);
  clear();  // the hash table is emptied below if used
  built_ = true;
  // Cell ranges first: they size the table and find the range of the occupied cells.
  int32_t cmin[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, cmax[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  const size_t incidences = cellRanges(boxes, count, cmin, cmax);
  items_ = count;
  chooseCellIndex(count, incidences, cmin, cmax);
  listIncidences(boxes, count, incidences);
  sortIncidences(boxes);
}

size_t CellGrid::cellRanges(const double* boxes, size_t count, int32_t* cmin, int32_t* cmax) {
  lo_scratch_.resize(3 * count);
  size_t incidences = 0;
  for (uint32_t s = 0; s < count; ++s) {
    int32_t* lo = &lo_scratch_[3 * static_cast<size_t>(s)];
    int32_t hi[3];
    if (!cellRange(&boxes[6 * static_cast<size_t>(s)], lo, hi)) {
      large_.push_back(s);
      continue;
    }
    incidences += static_cast<size_t>(hi[0] - lo[0] + 1) * static_cast<size_t>(hi[1] - lo[1] + 1) *
                  static_cast<size_t>(hi[2] - lo[2] + 1);
    for (int k = 0; k < 3; ++k) {
      cmin[k] = std::min(cmin[k], lo[k]);
      cmax[k] = std::max(cmax[k], hi[k]);
    }
  }
  return incidences;
}

void CellGrid::chooseCellIndex(size_t count, size_t incidences, const int32_t* cmin, const int32_t* cmax) {
  // Cells found by direct index into an array over that range when it is not much larger than
  // the number of items (a bounded, filled world: one read, no hashing or probing), else by
  // the hash table (sparse or unbounded worlds).
  double range = 1.0;
  for (int k = 0; k < 3; ++k) range *= cmax[k] >= cmin[k] ? static_cast<double>(cmax[k]) - cmin[k] + 1.0 : 0.0;
  dense_ = range <= kDenseCellsPerItem * static_cast<double>(count) + 64.0;
  if (dense_) {
    for (int k = 0; k < 3; ++k) {
      dense_min_[k] = cmin[k];
      dense_dim_[k] = cmax[k] >= cmin[k] ? cmax[k] - cmin[k] + 1 : 0;
    }
    if (dense_cell_.size() < static_cast<size_t>(range)) dense_cell_.resize(static_cast<size_t>(range), kEmpty);
  } else {
    size_t capacity = 16;
    while (capacity < 2 * incidences) capacity *= 2;
    table_key_.resize(capacity);
    table_cell_.assign(capacity, kEmpty);
    table_mask_ = capacity - 1;
  }
}

void CellGrid::listIncidences(const double* boxes, size_t count, size_t incidences) {
  entry_cell_.clear();
  entry_item_.clear();
  entry_cell_.reserve(incidences);
  entry_item_.reserve(incidences);
  const double inv = inv_h_;
  size_t next_large = 0;
  for (uint32_t s = 0; s < count; ++s) {
    if (next_large < large_.size() && large_[next_large] == s) {
      ++next_large;
      continue;
    }
    const double* b = &boxes[6 * static_cast<size_t>(s)];
    const int32_t* lo = &lo_scratch_[3 * static_cast<size_t>(s)];
    const int32_t hx = floorToInt(b[3] * inv), hy = floorToInt(b[4] * inv), hz = floorToInt(b[5] * inv);
    for (int32_t z = lo[2]; z <= hz; ++z) {
      for (int32_t y = lo[1]; y <= hy; ++y) {
        for (int32_t x = lo[0]; x <= hx; ++x) {
          entry_cell_.push_back(addCell(x, y, z));  // the table holds every cell
          entry_item_.push_back(s);
        }
      }
    }
  }
}

void CellGrid::sortIncidences(const double* boxes) {
  // Counting sort of the incidences by cell. Each carries a copy of its box and lo-corner cell,
  // so the pair loops of a cell read one contiguous run of memory (at 10^5 bodies, random reads
  // of the boxes cost more than the tests).
  cell_start_.assign(cells_.size() + 1, 0);
  for (uint32_t c : entry_cell_) ++cell_start_[c + 1];
  for (size_t c = 0; c < cells_.size(); ++c) cell_start_[c + 1] += cell_start_[c];
  entries_.resize(entry_cell_.size());
  for (size_t e = 0; e < entry_item_.size(); ++e) {
    const uint32_t s = entry_item_[e];
    Entry& en = entries_[cell_start_[entry_cell_[e]]++];  // cell_start_ as write cursor
    std::copy_n(&boxes[6 * static_cast<size_t>(s)], 6, en.box);
    std::copy_n(&lo_scratch_[3 * static_cast<size_t>(s)], 3, en.lo_cell);
    en.item = s;
  }
  // cell_start_[c] now holds the end of cell c: shift back.
  for (size_t c = cells_.size(); c > 0; --c) cell_start_[c] = cell_start_[c - 1];
  cell_start_[0] = 0;
}

void CellGrid::remove(uint32_t item) {
  if (!has(item)) return;
  if (state_[item] == kGrid) {
    int32_t lo[3], hi[3];
    if (cellRange(box(item), lo, hi)) {
      live_nodes_ -= static_cast<size_t>(hi[0] - lo[0] + 1) * static_cast<size_t>(hi[1] - lo[1] + 1) *
                     static_cast<size_t>(hi[2] - lo[2] + 1);
    }
  } else {
    large_.erase(std::find(large_.begin(), large_.end(), item));
  }
  ++version_[item];  // its nodes are stale from now on
  state_[item] = kNone;
  --items_;
}

void CellGrid::set(uint32_t item, const double* box) {
  if (built_) throw InvalidArgument("CellGrid::set: the grid was filled by build(); reset() it first");
  if (item >= state_.size()) {
    const size_t n = std::max<size_t>(item + 1, 2 * state_.size());
    state_.resize(n, kNone);
    version_.resize(n, 0);
    box_.resize(6 * n, 0.0);
    lo_cell_.resize(3 * n, 0);
  }
  remove(item);
  double* f = &box_[6 * static_cast<size_t>(item)];
  std::copy_n(box, 6, f);
  ++items_;
  int32_t* lo = &lo_cell_[3 * static_cast<size_t>(item)];
  int32_t hi[3];
  if (!cellRange(f, lo, hi)) {
    state_[item] = kLarge;
    large_.push_back(item);
    return;
  }
  state_[item] = kGrid;
  const uint32_t version = version_[item];
  for (int32_t z = lo[2]; z <= hi[2]; ++z) {
    for (int32_t y = lo[1]; y <= hi[1]; ++y) {
      for (int32_t x = lo[0]; x <= hi[0]; ++x) {
        const uint32_t c = insertCell(x, y, z);
        if (c >= head_.size()) head_.resize(c + 1, -1);
        nodes_.push_back(Node{item, version, head_[c]});
        head_[c] = static_cast<int32_t>(nodes_.size() - 1);
        ++live_nodes_;
      }
    }
  }
}

void CellGrid::compactIfStale() {
  if (nodes_.size() - live_nodes_ <= live_nodes_ / 2 + 256) return;
  std::vector<Node> packed;
  packed.reserve(live_nodes_);
  for (int32_t& head : head_) {
    const int32_t first = head;
    head = -1;
    int32_t last = -1;
    for (int32_t k = first; k >= 0; k = nodes_[k].next) {
      const Node& node = nodes_[k];
      if (node.version != version_[node.item]) continue;
      const int32_t at = static_cast<int32_t>(packed.size());
      packed.push_back(Node{node.item, node.version, -1});
      (last < 0 ? head : packed[last].next) = at;
      last = at;
    }
  }
  nodes_.swap(packed);
}

size_t CellGrid::memoryBytes() const {
  return table_key_.capacity() * sizeof(Cell) + cells_.capacity() * sizeof(Cell) +
         (table_cell_.capacity() + dense_cell_.capacity() + cell_start_.capacity() + entry_cell_.capacity() +
          entry_item_.capacity() + version_.capacity() + large_.capacity()) * sizeof(uint32_t) +
         entries_.capacity() * sizeof(Entry) + (lo_scratch_.capacity() + head_.capacity() + lo_cell_.capacity()) * sizeof(int32_t) +
         nodes_.capacity() * sizeof(Node) + state_.capacity() + box_.capacity() * sizeof(double);
}

}  // namespace detail
}  // namespace vadop
