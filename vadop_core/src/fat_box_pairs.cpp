#include "fat_box_pairs.h"

#include "vadop/detail/parallel_for.h"
#include "vadop/error.h"

#include <algorithm>

namespace vadop {

void FatBoxPairs::reset(double h, double max_abs) {
  grid_.reset(h, max_abs);  // throws for a bad cell size before anything changes
  for (auto& a : adj_) a.clear();
  pair_count_ = 0;
}

bool FatBoxPairs::contains(BodyId id, const double* box) const {
  if (!has(id)) return false;
  const double* f = grid_.box(id);
  return f[0] <= box[0] && f[1] <= box[1] && f[2] <= box[2] && box[3] <= f[3] && box[4] <= f[4] && box[5] <= f[5];
}

void FatBoxPairs::unlinkPartners(BodyId id) {
  if (id >= adj_.size()) return;
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
  unlinkPartners(id);
  grid_.remove(id);
}

void FatBoxPairs::update(const std::vector<BodyId>& ids, const std::vector<double>& boxes, int threads) {
  if (boxes.size() != 6 * ids.size()) {
    throw InvalidArgument("FatBoxPairs::update: " + std::to_string(ids.size()) + " ids need " +
                          std::to_string(6 * ids.size()) + " box coordinates, got " + std::to_string(boxes.size()));
  }
  // 1. Out with the old boxes, in with the new ones.
  for (size_t i = 0; i < ids.size(); ++i) {
    const BodyId id = ids[i];
    if (adj_.size() <= id) {
      const size_t n = std::max<size_t>(id + 1, 2 * adj_.size());
      adj_.resize(n);
      in_update_.resize(n, 0);
    }
    remove(id);
    grid_.set(id, &boxes[6 * i]);
    in_update_[id] = 1;
  }
  grid_.compactIfStale();
  // 2. New partners: every current fat box in the grid overlapping a new one. A pair of two
  //    updated bodies is found from both sides and kept from the smaller id's. The queries
  //    only read the grid: blocks of ids on the threads, linked after in block order (the
  //    order of one thread). A query costs microseconds (its cells hold dozens of boxes).
  constexpr size_t kIdsPerThread = 32;
  constexpr size_t kBlocksPerThread = 4;
  const size_t workers = std::min<size_t>(static_cast<size_t>(std::max(threads, 1)), ids.size() / kIdsPerThread);
  const size_t blocks = workers > 1 ? kBlocksPerThread * workers : 1;
  if (found_.size() < blocks) found_.resize(blocks);
  detail::parallelFor(static_cast<int>(workers), blocks, 1, 1, [&](size_t block) {
    auto& found = found_[block];
    found.clear();
    for (size_t i = detail::blockBegin(ids.size(), blocks, block), end = detail::blockBegin(ids.size(), blocks, block + 1);
         i < end; ++i) {
      const BodyId id = ids[i];
      if (grid_.isLarge(id)) continue;
      grid_.forEachOverlap(grid_.box(id), [&](BodyId j) {
        if (j == id || (in_update_[j] && j < id)) return;
        found.emplace_back(id, j);
      });
    }
  });
  for (size_t block = 0; block < blocks; ++block) {
    for (const auto& [id, j] : found_[block]) {
      adj_[id].push_back(j);
      adj_[j].push_back(id);
    }
    pair_count_ += found_[block].size();
  }
  for (const BodyId id : ids) in_update_[id] = 0;
}

size_t FatBoxPairs::memoryBytes() const {
  size_t bytes = grid_.memoryBytes() + in_update_.capacity() + adj_.capacity() * sizeof(std::vector<BodyId>);
  for (const auto& a : adj_) bytes += a.capacity() * sizeof(BodyId);
  for (const auto& f : found_) bytes += f.capacity() * sizeof(f[0]);
  return bytes;
}

}  // namespace vadop
