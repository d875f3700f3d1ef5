#include "fat_box_pairs.h"

#include "vadop/error.h"
#include "grid_cells.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace {

// Cell coordinates are packed into 21 bits each.
constexpr int32_t kKeyRange = 1 << 20;

inline bool boxesOverlap(const double* a, const double* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

}  // namespace

size_t FatBoxPairs::KeyHash::operator()(uint64_t k) const { return static_cast<size_t>(detail::mixCellKey(k)); }

uint64_t FatBoxPairs::key(int32_t x, int32_t y, int32_t z) {
  const auto field = [](int32_t v) { return static_cast<uint64_t>(v + kKeyRange) & 0x1fffff; };
  return field(x) | field(y) << 21 | field(z) << 42;
}

void FatBoxPairs::reset(double h, double max_abs) {
  if (!(std::isfinite(h) && h > 0.0)) throw InvalidArgument("FatBoxPairs: cell size must be finite and > 0, got " + formatNumber(h));
  // Coarser cells when coordinates reach that far, so that boxes stay within the key range
  // (with a factor 2 to spare) instead of all becoming large.
  if (std::isfinite(max_abs)) h = std::max(h, 2.0 * std::abs(max_abs) / kKeyRange);
  h_ = h;
  inv_h_ = 1.0 / h;
  std::fill(state_.begin(), state_.end(), kNone);
  for (auto& a : adj_) a.clear();
  for (auto& v : version_) ++v;
  large_.clear();
  cells_.clear();
  nodes_.clear();
  live_nodes_ = bodies_ = pair_count_ = 0;
}

void FatBoxPairs::grow(BodyId id) {
  if (id < state_.size()) return;
  const size_t n = std::max<size_t>(id + 1, 2 * state_.size());
  state_.resize(n, kNone);
  version_.resize(n, 0);
  box_.resize(6 * n, 0.0);
  adj_.resize(n);
  in_update_.resize(n, 0);
  stamp_.resize(n, 0);
}

bool FatBoxPairs::contains(BodyId id, const double* box) const {
  if (!has(id)) return false;
  const double* f = &box_[6 * static_cast<size_t>(id)];
  return f[0] <= box[0] && f[1] <= box[1] && f[2] <= box[2] && box[3] <= f[3] && box[4] <= f[4] && box[5] <= f[5];
}

bool FatBoxPairs::cellRange(const double* box, int32_t lo[3], int32_t hi[3]) const {
  size_t count = 1;
  for (int k = 0; k < 3; ++k) {
    const double a = box[k] * inv_h_, b = box[3 + k] * inv_h_;
    if (!(a > -kKeyRange + 1 && b < kKeyRange - 1)) return false;  // also NaN
    lo[k] = detail::floorToInt(a);
    hi[k] = detail::floorToInt(b);
    count *= static_cast<size_t>(hi[k] - lo[k] + 1);
    if (count > kMaxCells) return false;
  }
  return true;
}

void FatBoxPairs::unlinkPartners(BodyId id) {
  for (BodyId j : adj_[id]) {
    auto& other = adj_[j];
    const auto it = std::find(other.begin(), other.end(), id);
    if (it != other.end()) {
      *it = other.back();
      other.pop_back();
    }
  }
  pair_count_ -= adj_[id].size();
  adj_[id].clear();
}

void FatBoxPairs::remove(BodyId id) {
  if (!has(id)) return;
  if (state_[id] == kGrid) {
    int32_t lo[3], hi[3];
    if (cellRange(&box_[6 * static_cast<size_t>(id)], lo, hi)) {
      live_nodes_ -= static_cast<size_t>(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
    }
    unlinkPartners(id);
  } else {
    large_.erase(std::find(large_.begin(), large_.end(), id));
  }
  ++version_[id];  // its grid nodes are stale from now on
  state_[id] = kNone;
  --bodies_;
}

void FatBoxPairs::update(const std::vector<BodyId>& ids, const std::vector<double>& boxes) {
  if (boxes.size() != 6 * ids.size()) {
    throw InvalidArgument("FatBoxPairs::update: " + std::to_string(ids.size()) + " ids need " +
                          std::to_string(6 * ids.size()) + " box coordinates, got " + std::to_string(boxes.size()));
  }
  // 1. Out with the old boxes, in with the new ones.
  for (size_t i = 0; i < ids.size(); ++i) {
    const BodyId id = ids[i];
    grow(id);
    remove(id);
    double* f = &box_[6 * static_cast<size_t>(id)];
    std::copy_n(&boxes[6 * i], 6, f);
    in_update_[id] = 1;
    ++bodies_;
    int32_t lo[3], hi[3];
    if (!cellRange(f, lo, hi)) {
      state_[id] = kLarge;
      large_.push_back(id);
      continue;
    }
    state_[id] = kGrid;
    const uint32_t version = version_[id];
    for (int32_t z = lo[2]; z <= hi[2]; ++z) {
      for (int32_t y = lo[1]; y <= hi[1]; ++y) {
        for (int32_t x = lo[0]; x <= hi[0]; ++x) {
          int32_t& head = cells_.insert(key(x, y, z), -1);
          nodes_.push_back(Node{id, version, head});
          head = static_cast<int32_t>(nodes_.size() - 1);
          ++live_nodes_;
        }
      }
    }
  }
  // 2. New partners: every current fat box overlapping a new one. A pair of two updated bodies
  //    is found from both sides and kept from the smaller id's.
  for (const BodyId id : ids) {
    if (state_[id] != kGrid) continue;
    if (++stamp_now_ == 0) {
      std::fill(stamp_.begin(), stamp_.end(), 0);
      stamp_now_ = 1;
    }
    stamp_[id] = stamp_now_;
    const double* f = &box_[6 * static_cast<size_t>(id)];
    int32_t lo[3], hi[3];
    cellRange(f, lo, hi);
    for (int32_t z = lo[2]; z <= hi[2]; ++z) {
      for (int32_t y = lo[1]; y <= hi[1]; ++y) {
        for (int32_t x = lo[0]; x <= hi[0]; ++x) {
          const int32_t* head = cells_.find(key(x, y, z));
          for (int32_t k = head ? *head : -1; k >= 0; k = nodes_[k].next) {
            const Node& node = nodes_[k];
            const BodyId j = node.body;
            if (node.version != version_[j] || stamp_[j] == stamp_now_) continue;
            stamp_[j] = stamp_now_;
            if (in_update_[j] && j < id) continue;
            if (!boxesOverlap(f, &box_[6 * static_cast<size_t>(j)])) continue;
            adj_[id].push_back(j);
            adj_[j].push_back(id);
            ++pair_count_;
          }
        }
      }
    }
  }
  for (const BodyId id : ids) in_update_[id] = 0;
}

size_t FatBoxPairs::memoryBytes() const {
  size_t bytes = state_.capacity() + in_update_.capacity() +
                 (version_.capacity() + stamp_.capacity() + large_.capacity()) * sizeof(uint32_t) +
                 box_.capacity() * sizeof(double) + adj_.capacity() * sizeof(std::vector<BodyId>) +
                 cells_.memoryBytes() + nodes_.capacity() * sizeof(Node);
  for (const auto& a : adj_) bytes += a.capacity() * sizeof(BodyId);
  return bytes;
}

}  // namespace vadop
