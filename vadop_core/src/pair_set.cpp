#include "vadop/pair_set.h"

#include <algorithm>

namespace vadop {

PairSet::PairSet() : slots_(16, kEmpty), mask_(15) {}

uint64_t PairSet::key(BodyId x, BodyId y) {
  const Pair p = makePair(x, y);
  return (uint64_t{p.a} << 32) | p.b;
}

size_t PairSet::home(uint64_t k) const {
  // splitmix64 finaliser: consecutive ids must not land in consecutive slots.
  k += 0x9e3779b97f4a7c15ull;
  k = (k ^ (k >> 30)) * 0xbf58476d1ce4e5b9ull;
  k = (k ^ (k >> 27)) * 0x94d049bb133111ebull;
  k ^= k >> 31;
  return static_cast<size_t>(k) & mask_;
}

bool PairSet::contains(BodyId x, BodyId y) const {
  const uint64_t k = key(x, y);
  for (size_t i = home(k);; i = (i + 1) & mask_) {
    if (slots_[i] == k) return true;
    if (slots_[i] == kEmpty) return false;
  }
}

bool PairSet::insert(BodyId x, BodyId y) {
  if (2 * (size_ + 1) > slots_.size()) grow();
  const uint64_t k = key(x, y);
  for (size_t i = home(k);; i = (i + 1) & mask_) {
    if (slots_[i] == k) return false;
    if (slots_[i] == kEmpty) {
      slots_[i] = k;
      ++size_;
      return true;
    }
  }
}

bool PairSet::erase(BodyId x, BodyId y) {
  const uint64_t k = key(x, y);
  size_t i = home(k);
  for (;; i = (i + 1) & mask_) {
    if (slots_[i] == kEmpty) return false;
    if (slots_[i] == k) break;
  }
  // Backward shift: pull later members of the probe run into the hole when the hole lies on
  // their path from their home slot, so lookups never need tombstones.
  size_t hole = i;
  for (size_t j = (hole + 1) & mask_; slots_[j] != kEmpty; j = (j + 1) & mask_) {
    const size_t h = home(slots_[j]);
    const bool movable = (j > hole) ? (h <= hole || h > j) : (h <= hole && h > j);
    if (movable) {
      slots_[hole] = slots_[j];
      hole = j;
    }
  }
  slots_[hole] = kEmpty;
  --size_;
  return true;
}

void PairSet::clear() {
  std::fill(slots_.begin(), slots_.end(), kEmpty);
  size_ = 0;
}

void PairSet::appendTo(std::vector<Pair>& out) const {
  out.reserve(out.size() + size_);
  for (uint64_t k : slots_) {
    if (k != kEmpty) out.push_back(Pair{static_cast<BodyId>(k >> 32), static_cast<BodyId>(k)});
  }
}

void PairSet::grow() {
  std::vector<uint64_t> old;
  old.swap(slots_);
  slots_.assign(old.size() * 2, kEmpty);
  mask_ = slots_.size() - 1;
  for (uint64_t k : old) {
    if (k == kEmpty) continue;
    size_t i = home(k);
    while (slots_[i] != kEmpty) i = (i + 1) & mask_;
    slots_[i] = k;
  }
}

}  // namespace vadop
