// Cell arithmetic shared by the broad phase's cell grid (cell_grid.h), the response loop's hash
// of pairs and the bit-set walk of the VADOP axis sets.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vadop {
namespace detail {

// floor() as an integer without the libm call (baseline x86-64 has no inline rounding before
// SSE4.1): truncate, then step down for negatives. Exact for |x| < 2^31; callers bound it.
inline int32_t floorToInt(double x) {
  const int32_t i = static_cast<int32_t>(x);
  return i - static_cast<int32_t>(x < static_cast<double>(i));
}

// Finaliser of MurmurHash3: spreads a cell key over all 64 bits before masking.
inline uint64_t mixCellKey(uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdull;
  k ^= k >> 33;
  return k;
}

// Calls f(k) for every set bit k of a bit set of `words` 64-bit words, ascending.
template <class F>
void forEachSetBit(const uint64_t* bits, size_t words, F&& f) {
  for (size_t w = 0; w < words; ++w) {
    for (uint64_t x = bits[w]; x != 0; x &= x - 1) f(static_cast<uint32_t>(64 * w + __builtin_ctzll(x)));
  }
}

}  // namespace detail
}  // namespace vadop
