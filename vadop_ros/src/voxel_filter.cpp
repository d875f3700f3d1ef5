// At most one point per voxel. See voxel_filter.h.
#include "vadop_ros/voxel_filter.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace vadop_ros {

namespace {

// Bits needed to hold values 0..span.
int bitsFor(uint64_t span) { return span == 0 ? 0 : 64 - __builtin_clzll(span); }

constexpr int kDigitBits = 11;  // 2,048 counters a pass: they stay in the first-level cache

}  // namespace

size_t VoxelFilter::apply(std::vector<Eigen::Vector3d>& points, double voxel) {
  const size_t n = points.size();
  if (n < 2) return 0;
  cells_.resize(n);
  Cell lo, hi;
  lo.fill(INT64_MAX);
  hi.fill(INT64_MIN);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const int64_t c = static_cast<int64_t>(std::floor(points[i][k] / voxel));
      cells_[i][k] = c;
      lo[k] = std::min(lo[k], c);
      hi[k] = std::max(hi[k], c);
    }
  }
  std::array<int, 3> bits;
  for (int k = 0; k < 3; ++k) {
    // The span in unsigned arithmetic: hi - lo may not fit an int64_t.
    bits[k] = bitsFor(static_cast<uint64_t>(hi[k]) - static_cast<uint64_t>(lo[k]));
  }
  keep_.assign(n, 0);
  if (bits[0] + bits[1] + bits[2] <= 64) {
    markByRadix(lo, bits);
  } else {
    markByComparison();
  }
  size_t kept = 0;
  for (size_t i = 0; i < n; ++i) {
    if (keep_[i]) points[kept++] = points[i];
  }
  points.resize(kept);
  return n - kept;
}

void VoxelFilter::markByRadix(const Cell& lo, const std::array<int, 3>& bits) {
  const size_t n = cells_.size();
  keys_.resize(n);
  keys_tmp_.resize(n);
  order_.resize(n);
  order_tmp_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      key = (bits[k] == 64 ? 0 : key << bits[k]) | (static_cast<uint64_t>(cells_[i][k]) - static_cast<uint64_t>(lo[k]));
    }
    keys_[i] = key;
    order_[i] = static_cast<uint32_t>(i);
  }
  // Least significant digit first; each pass stable, so equal keys stay in index order.
  const int total = bits[0] + bits[1] + bits[2];
  for (int shift = 0; shift < total; shift += kDigitBits) {
    uint32_t count[(1 << kDigitBits) + 1] = {};
    const uint64_t mask = (uint64_t{1} << kDigitBits) - 1;
    for (size_t i = 0; i < n; ++i) ++count[((keys_[i] >> shift) & mask) + 1];
    for (int b = 0; b < (1 << kDigitBits); ++b) count[b + 1] += count[b];
    for (size_t i = 0; i < n; ++i) {
      const uint32_t at = count[(keys_[i] >> shift) & mask]++;
      keys_tmp_[at] = keys_[i];
      order_tmp_[at] = order_[i];
    }
    keys_.swap(keys_tmp_);
    order_.swap(order_tmp_);
  }
  for (size_t i = 0; i < n; ++i) {
    if (i == 0 || keys_[i] != keys_[i - 1]) keep_[order_[i]] = 1;
  }
}

void VoxelFilter::markByComparison() {
  const size_t n = cells_.size();
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0u);
  std::sort(order_.begin(), order_.end(), [this](uint32_t a, uint32_t b) {
    return cells_[a] != cells_[b] ? cells_[a] < cells_[b] : a < b;
  });
  for (size_t i = 0; i < n; ++i) {
    if (i == 0 || cells_[order_[i]] != cells_[order_[i - 1]]) keep_[order_[i]] = 1;
  }
}

}  // namespace vadop_ros
