// A set of unordered body pairs: open addressing with linear probing and backward-shift
// deletion (no tombstones), so memory is O(pairs) and insert/erase/contains are O(1) on
// average. It does not order the pairs: sort the output of appendTo when order matters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vadop {

using BodyId = uint32_t;

struct Pair {
  BodyId a = 0;  // a < b
  BodyId b = 0;
  friend bool operator==(const Pair& x, const Pair& y) { return x.a == y.a && x.b == y.b; }
  friend bool operator<(const Pair& x, const Pair& y) { return x.a < y.a || (x.a == y.a && x.b < y.b); }
};

inline Pair makePair(BodyId x, BodyId y) { return x < y ? Pair{x, y} : Pair{y, x}; }

class PairSet {
 public:
  PairSet();
  bool insert(BodyId x, BodyId y);  // true when the pair was not there
  bool erase(BodyId x, BodyId y);   // true when the pair was there
  bool contains(BodyId x, BodyId y) const;
  void clear();
  size_t size() const { return size_; }
  void appendTo(std::vector<Pair>& out) const;
  size_t memoryBytes() const { return slots_.capacity() * sizeof(uint64_t); }

 private:
  static uint64_t key(BodyId x, BodyId y);
  size_t home(uint64_t k) const;
  void grow();

  static constexpr uint64_t kEmpty = ~uint64_t{0};
  std::vector<uint64_t> slots_;
  size_t mask_ = 0;
  size_t size_ = 0;
};

}  // namespace vadop
