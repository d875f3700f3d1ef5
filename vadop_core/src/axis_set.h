// The set of pool axes a body is projected on, as both engines with VADOPs store it: a bit set
// of ceil(m / 64) words and, per word, the number of set bits in the words before it, so that
// the body's interval on axis k (intervals in ascending axis order) is a popcount away and the
// axes two bodies share are an AND away. It holds no intervals and knows no geometry.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vadop {
namespace detail {

// rank[w] = number of set bits in bits[0..w-1].
inline void buildAxisRanks(const uint64_t* bits, size_t words, uint16_t* rank) {
  if (words == 0) return;
  rank[0] = 0;
  for (size_t w = 1; w < words; ++w) rank[w] = static_cast<uint16_t>(rank[w - 1] + __builtin_popcountll(bits[w - 1]));
}

// Number of axes in the set (= the body's interval count).
inline uint32_t axisCount(const uint64_t* bits, const uint16_t* rank, size_t words) {
  return words == 0 ? 0 : rank[words - 1] + static_cast<uint32_t>(__builtin_popcountll(bits[words - 1]));
}

// Whether the intervals of two bodies (anything with .lo and .hi, in ascending axis order)
// overlap on every axis both sets hold; true when they share none (the paper's rule: the
// boxes alone decide). Always inlined, so that it is compiled into each popcount clone of its
// caller (popcount.h).
template <class Interval>
__attribute__((always_inline)) inline bool overlapOnSharedAxes(const uint64_t* bits_a, const uint16_t* rank_a,
                                                               const Interval* iv_a, const uint64_t* bits_b,
                                                               const uint16_t* rank_b, const Interval* iv_b,
                                                               size_t words) {
  for (size_t w = 0; w < words; ++w) {
    const uint64_t wa = bits_a[w], wb = bits_b[w];
    for (uint64_t common = wa & wb; common != 0; common &= common - 1) {
      const uint64_t below = (common & (~common + 1)) - 1;  // bits under the lowest shared one
      const Interval& x = iv_a[rank_a[w] + __builtin_popcountll(wa & below)];
      const Interval& y = iv_b[rank_b[w] + __builtin_popcountll(wb & below)];
      if (x.lo > y.hi || y.lo > x.hi) return false;
    }
  }
  return true;
}

// The lowest axis both sets hold, or ~0u when they share none.
inline uint32_t firstSharedAxis(const uint64_t* bits_a, const uint64_t* bits_b, size_t words) {
  for (size_t w = 0; w < words; ++w) {
    const uint64_t common = bits_a[w] & bits_b[w];
    if (common != 0) return static_cast<uint32_t>(64 * w + __builtin_ctzll(common));
  }
  return ~uint32_t{0};
}

}  // namespace detail
}  // namespace vadop
