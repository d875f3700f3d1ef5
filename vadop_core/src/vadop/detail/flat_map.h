// An open-addressing hash map from a trivially copyable key to a trivially copyable value, for
// hot paths (World's NameIndex; the bench's ImpactQueue): one contiguous array, linear
// probing, deletion by backward shift (no tombstones), so lookups stay short whatever the
// history of inserts and erases. Not a general container: no iterators that survive a change, no exception safety
// beyond "reserve() first, then insert() cannot throw". Not thread-safe.
#pragma once

#include "vadop/detail/large_array.h"

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vadop {
namespace detail {

template <class Key, class Value, class Hash>
class FlatMap {
 public:
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  size_t capacity() const { return slots_.size(); }
  size_t memoryBytes() const { return slots_.capacity() * sizeof(Slot); }

  // Makes room for `n` elements: inserting until size() == n allocates nothing.
  void reserve(size_t n) {
    size_t cap = slots_.empty() ? 16 : slots_.size();
    while (n * 4 > cap * 3) cap *= 2;  // load factor <= 3/4
    if (cap != slots_.size()) rehash(cap);
  }

  Value* find(const Key& k) {
    return findIf(Hash{}(k), [&k](const Key& x) { return x == k; });
  }
  const Value* find(const Key& k) const { return const_cast<FlatMap*>(this)->find(k); }
  // The member whose key satisfies `is`, looked up from `hash` (= Hash{}(key) of that key):
  // for keys that stand for something kept elsewhere (a name behind an id).
  template <class Is>
  Value* findIf(size_t hash, const Is& is) {
    if (size_ == 0) return nullptr;
    for (size_t i = hash & mask_;; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (!s.used) return nullptr;
      if (is(s.key)) return &s.value;
    }
  }
  template <class Is>
  const Value* findIf(size_t hash, const Is& is) const {
    return const_cast<FlatMap*>(this)->findIf(hash, is);
  }
  // f(key, value) for every member, in table order.
  template <class F>
  void forEach(const F& f) const {
    for (const Slot& s : slots_) {
      if (s.used) f(s.key, s.value);
    }
  }

  // Inserts k with `value` if absent; returns the stored value (the old one if k was present).
  // Allocates when full: call reserve(size() + 1) first to make it non-throwing.
  Value& insert(const Key& k, const Value& value) {
    reserve(size_ + 1);
    size_t i = home(k);
    for (;; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (!s.used) break;
      if (s.key == k) return s.value;
    }
    slots_[i] = Slot{k, value, true};
    ++size_;
    return slots_[i].value;
  }

  // Removes k; returns whether it was present. Never allocates.
  bool erase(const Key& k) {
    return eraseIf(Hash{}(k), [&k](const Key& x) { return x == k; });
  }
  // Removes the member whose key satisfies `is` (looked up as findIf); returns whether there
  // was one. Never allocates.
  template <class Is>
  bool eraseIf(size_t hash, const Is& is) {
    if (size_ == 0) return false;
    size_t i = hash & mask_;
    for (;; i = (i + 1) & mask_) {
      if (!slots_[i].used) return false;
      if (is(slots_[i].key)) break;
    }
    // Backward shift: move later members of the probe run into the hole when their home
    // position does not lie cyclically in (hole, j].
    size_t hole = i;
    for (size_t j = (i + 1) & mask_; slots_[j].used; j = (j + 1) & mask_) {
      const size_t h = home(slots_[j].key);
      const bool stays = hole <= j ? (hole < h && h <= j) : (hole < h || h <= j);
      if (stays) continue;
      slots_[hole] = slots_[j];
      hole = j;
    }
    slots_[hole].used = false;
    --size_;
    return true;
  }

  void clear() {
    slots_.clear();
    slots_.shrink_to_fit();
    size_ = 0;
    mask_ = 0;
  }

  // Gives memory back once the map holds under 1/8 of its capacity. May throw std::bad_alloc
  // (then the map is unchanged).
  void shrinkIfSparse() {
    if (slots_.size() <= 64 || size_ * 8 >= slots_.size()) return;
    size_t cap = 16;
    while (size_ * 4 > cap * 3) cap *= 2;
    rehash(2 * cap);
  }

 private:
  struct Slot {
    Key key;
    Value value;
    bool used;
  };
  size_t home(const Key& k) const { return Hash{}(k) & mask_; }

  void rehash(size_t cap) {
    LargeArray<Slot> old(cap, Slot{Key{}, Value{}, false});
    old.swap(slots_);
    mask_ = cap - 1;
    for (const Slot& s : old) {
      if (!s.used) continue;
      size_t i = home(s.key);
      while (slots_[i].used) i = (i + 1) & mask_;
      slots_[i] = s;
    }
  }

  LargeArray<Slot> slots_;
  size_t size_ = 0;
  size_t mask_ = 0;
};

}  // namespace detail
}  // namespace vadop
