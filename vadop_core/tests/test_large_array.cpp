// LargeArrayAllocator: a std::vector on it holds what a plain one holds through growth, copies
// and shrinking across the 2 MiB threshold, and its blocks are aligned as the type asks (huge
// blocks to 2 MiB). The sanitizer build checks that each block goes back to the allocator
// that made it.
#include "vadop/detail/large_array.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

namespace vadop {
namespace {

using detail::LargeArray;
using detail::LargeArrayAllocator;

TEST(LargeArray, HoldsWhatAPlainVectorHoldsAcrossTheHugePageThreshold) {
  std::mt19937_64 rng(7);
  LargeArray<uint64_t> a;
  std::vector<uint64_t> b;
  const size_t threshold = LargeArrayAllocator<uint64_t>::kHugePage / sizeof(uint64_t);
  // Growth by push_back through the threshold, then resize down and up, copy, shrink_to_fit.
  for (size_t i = 0; i < 3 * threshold; ++i) {
    const uint64_t v = rng();
    a.push_back(v);
    b.push_back(v);
  }
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));
  a.resize(threshold / 2);
  b.resize(threshold / 2);
  a.shrink_to_fit();  // a huge block replaced by a small one
  LargeArray<uint64_t> c = a;
  c.resize(2 * threshold, 5);
  b.resize(2 * threshold, 5);
  EXPECT_TRUE(std::equal(c.begin(), c.end(), b.begin()));
  EXPECT_EQ(reinterpret_cast<uintptr_t>(c.data()) % LargeArrayAllocator<uint64_t>::kHugePage, 0u);
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));
}

struct alignas(64) Line {
  uint64_t word[8];
};

TEST(LargeArray, AlignsOverAlignedTypesSmallAndHuge) {
  for (size_t n : {size_t{1}, size_t{3}, size_t{100}, LargeArrayAllocator<Line>::kHugePage / sizeof(Line) + 1}) {
    LargeArray<Line> v(n);
    for (size_t i = 0; i < n; ++i) v[i].word[7] = i;
    EXPECT_EQ(reinterpret_cast<uintptr_t>(v.data()) % 64, 0u) << n;
    EXPECT_EQ(v[n - 1].word[7], n - 1);
  }
}

TEST(LargeArray, RefusesSizesBeyondTheAddressSpace) {
  LargeArrayAllocator<Line> alloc;
  EXPECT_THROW(alloc.allocate(static_cast<size_t>(-1) / sizeof(Line) + 1), std::bad_array_new_length);
}

}  // namespace
}  // namespace vadop
