#include "box_grid.h"

#include "vadop/error.h"
#include "grid_cells.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace detail {
namespace {

// Cell coordinates are packed into 21 bits each.
constexpr int32_t kKeyRange = 1 << 20;

}  // namespace

size_t BoxGrid::KeyHash::operator()(uint64_t k) const { return static_cast<size_t>(mixCellKey(k)); }

uint64_t BoxGrid::key(int32_t x, int32_t y, int32_t z) {
  const auto field = [](int32_t v) { return static_cast<uint64_t>(v + kKeyRange) & 0x1fffff; };
  return field(x) | field(y) << 21 | field(z) << 42;
}

void BoxGrid::reset(double h, double max_abs) {
  if (!(std::isfinite(h) && h > 0.0)) throw InvalidArgument("BoxGrid: cell size must be finite and > 0, got " + formatNumber(h));
  // Coarser cells when coordinates reach that far, so that boxes stay within the key range
  // (with a factor 2 to spare) instead of all becoming large.
  if (std::isfinite(max_abs)) h = std::max(h, 2.0 * std::abs(max_abs) / kKeyRange);
  h_ = h;
  inv_h_ = 1.0 / h;
  std::fill(state_.begin(), state_.end(), kNone);
  for (auto& v : version_) ++v;
  large_.clear();
  cells_.clear();
  nodes_.clear();
  live_nodes_ = bodies_ = 0;
}

void BoxGrid::grow(BodyId id) {
  if (id < state_.size()) return;
  const size_t n = std::max<size_t>(id + 1, 2 * state_.size());
  state_.resize(n, kNone);
  version_.resize(n, 0);
  box_.resize(6 * n, 0.0);
  stamp_.resize(n, 0);
}

bool BoxGrid::cellRange(const double* box, int32_t lo[3], int32_t hi[3]) const {
  size_t count = 1;
  for (int k = 0; k < 3; ++k) {
    const double a = box[k] * inv_h_, b = box[3 + k] * inv_h_;
    if (!(a > -kKeyRange + 1 && b < kKeyRange - 1)) return false;  // also NaN
    lo[k] = floorToInt(a);
    hi[k] = floorToInt(b);
    count *= static_cast<size_t>(hi[k] - lo[k] + 1);
    if (count > kMaxCells) return false;
  }
  return true;
}

void BoxGrid::remove(BodyId id) {
  if (!has(id)) return;
  if (state_[id] == kGrid) {
    int32_t lo[3], hi[3];
    if (cellRange(box(id), lo, hi)) {
      live_nodes_ -= static_cast<size_t>(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
    }
  } else {
    large_.erase(std::find(large_.begin(), large_.end(), id));
  }
  ++version_[id];  // its listings are stale from now on
  state_[id] = kNone;
  --bodies_;
}

void BoxGrid::set(BodyId id, const double* box) {
  grow(id);
  remove(id);
  double* f = &box_[6 * static_cast<size_t>(id)];
  std::copy_n(box, 6, f);
  ++bodies_;
  int32_t lo[3], hi[3];
  if (!cellRange(f, lo, hi)) {
    state_[id] = kLarge;
    large_.push_back(id);
    return;
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

size_t BoxGrid::memoryBytes() const {
  return state_.capacity() + (version_.capacity() + stamp_.capacity() + large_.capacity()) * sizeof(uint32_t) +
         box_.capacity() * sizeof(double) + cells_.memoryBytes() + nodes_.capacity() * sizeof(Node);
}

}  // namespace detail
}  // namespace vadop
