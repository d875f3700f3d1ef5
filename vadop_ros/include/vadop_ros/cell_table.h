// A map from integer grid cells (x, y, z) to a uint32_t, for grids rebuilt with every sensor
// message: the sensor filter's bins of bodies (a cloud's voxels are sorted instead:
// voxel_filter.h). Open addressing with linear probing over a power-of-two table kept at most
// half full, emptied by a generation count instead of a pass over the table, and kept from
// message to message: no allocation per cell (node-based hash maps allocated one per cell). It
// does not grow while filled: reset() sizes it for the insertions to come, and inserting more
// than that aborts (a caller's bug, never the message's).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace vadop_ros {

class CellTable {
 public:
  // 64 bits a coordinate: a 1 mm cell at the library's largest coordinate overflows 32.
  using Cell = std::array<int64_t, 3>;

  // Empty, with room for up to `insertions` cells. The table grows as needed and shrinks only
  // when four times too large: a count that wanders about a power of two does not reallocate
  // it at every message.
  void reset(size_t insertions) {
    int bits = 4;
    while ((size_t{1} << bits) < 2 * insertions) ++bits;
    if (bits > bits_ || bits + 2 < bits_) {
      bits_ = bits;
      slots_.assign(size_t{1} << bits, Slot{});
      current_ = 0;
    }
    if (++current_ == 0) {  // wrapped: a stale slot's mark could equal the new one
      for (Slot& s : slots_) s.generation = 0;
      current_ = 1;
    }
    room_ = (size_t{1} << bits_) / 2;
  }

  // The cell's value, 0 when it was not in (then `inserted` is true; a new cell's value is 0).
  uint32_t& insert(const Cell& c, bool& inserted) {
    for (size_t k = slot(c);; k = (k + 1) & mask()) {
      Slot& s = slots_[k];
      if (s.generation != current_) {
        if (room_ == 0) std::abort();  // more cells than reset() was told: the caller's bug
        --room_;
        s.generation = current_;
        s.cell = c;
        s.value = 0;
        inserted = true;
        return s.value;
      }
      if (s.cell == c) {
        inserted = false;
        return s.value;
      }
    }
  }

  // The cell's value, or null when it is not in.
  const uint32_t* find(const Cell& c) const {
    if (bits_ == 0) return nullptr;
    for (size_t k = slot(c);; k = (k + 1) & mask()) {
      const Slot& s = slots_[k];
      if (s.generation != current_) return nullptr;
      if (s.cell == c) return &s.value;
    }
  }

 private:
  size_t mask() const { return (size_t{1} << bits_) - 1; }
  size_t slot(const Cell& c) const {
    // Large odd multipliers (as in spatial hashing), then Fibonacci hashing's top bits:
    // neighbouring cells spread over the table.
    const uint64_t h = (static_cast<uint64_t>(c[0]) * 73856093ull ^ static_cast<uint64_t>(c[1]) * 19349663ull ^
                        static_cast<uint64_t>(c[2]) * 83492791ull) *
                       0x9e3779b97f4a7c15ull;
    return static_cast<size_t>(h >> (64 - bits_));
  }

  // A slot's fields side by side (32 bytes: half a cache line): a probe reads one line, not
  // three (the tables outgrow the caches; a cloud's voxels are met in no order).
  struct alignas(32) Slot {
    Cell cell{};
    uint32_t value = 0;
    uint32_t generation = 0;  // the slot is taken when it equals current_
  };
  std::vector<Slot> slots_;
  uint32_t current_ = 0;
  int bits_ = 0;
  size_t room_ = 0;
};

}  // namespace vadop_ros
