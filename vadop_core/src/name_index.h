// The index from body names to BodyIds of a World: an open-addressing table whose slots hold a
// name's hash beside its id (eight to a cache line), so that a lookup reads one line of the
// table and then the record the id points to, where the caller keeps the name. It does not own
// or copy names, and it is not thread-safe for writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string_view>
#include <vector>

namespace vadop {
namespace detail {

class NameIndex {
 public:
  static constexpr uint32_t kNone = ~uint32_t{0};

  size_t size() const { return size_; }
  // The id listed under `name`, or kNone; nameOf(id) gives the name the caller keeps for id.
  template <class NameOf>
  uint32_t find(std::string_view name, const NameOf& nameOf) const {
    if (slots_.empty()) return kNone;
    const uint32_t h = hashOf(name);
    for (size_t i = h & mask_;; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.id == kNone) return kNone;
      if (s.hash == h && nameOf(s.id) == name) return s.id;
    }
  }
  // Room for `count` names: insert() of up to that many does not allocate. May throw
  // std::bad_alloc (nothing changed then).
  void reserve(size_t count) {
    size_t capacity = 16;
    while (capacity < 2 * count) capacity *= 2;  // load at most 1/2: short probe runs
    if (capacity <= slots_.size()) return;
    std::vector<Slot> old(capacity, Slot{0, kNone});
    old.swap(slots_);
    mask_ = capacity - 1;
    for (const Slot& s : old) {
      if (s.id != kNone) place(s);
    }
  }
  // Lists `name` (absent) under `id`; the room must have been reserved: does not throw.
  void insert(std::string_view name, uint32_t id) noexcept {
    place(Slot{hashOf(name), id});
    ++size_;
  }
  // Unlists `name` if listed; does not throw. Linear probing with backward shifts: no
  // tombstones, so lookups stay as short after many removals.
  template <class NameOf>
  void erase(std::string_view name, const NameOf& nameOf) noexcept {
    if (slots_.empty()) return;
    const uint32_t h = hashOf(name);
    size_t i = h & mask_;
    for (;; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.id == kNone) return;
      if (s.hash == h && nameOf(s.id) == name) break;
    }
    // Move back every later slot of the run whose home lies at or before the hole.
    for (size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (slots_[j].id == kNone) break;
      const size_t home = slots_[j].hash & mask_;
      // j may move to i when home is not cyclically within (i, j].
      if (((j - home) & mask_) >= ((j - i) & mask_)) {
        slots_[i] = slots_[j];
        i = j;
      }
    }
    slots_[i] = Slot{0, kNone};
    --size_;
  }
  // f(id) for every listed id, in table order.
  template <class F>
  void forEach(F&& f) const {
    for (const Slot& s : slots_) {
      if (s.id != kNone) f(s.id);
    }
  }

 private:
  struct Slot {
    uint32_t hash;
    uint32_t id;
  };
  static uint32_t hashOf(std::string_view name) {
    const uint64_t h = std::hash<std::string_view>{}(name);
    return static_cast<uint32_t>(h ^ (h >> 32));
  }
  void place(const Slot& slot) noexcept {
    size_t i = slot.hash & mask_;
    while (slots_[i].id != kNone) i = (i + 1) & mask_;
    slots_[i] = slot;
  }

  std::vector<Slot> slots_;
  size_t mask_ = 0;
  size_t size_ = 0;
};

}  // namespace detail
}  // namespace vadop
