// PairSet against std::set under a long random sequence of inserts and erases: the
// backward-shift deletion is the part that can silently lose members.
#include "vadop/pair_set.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

namespace vadop {
namespace {

TEST(PairSet, MatchesStdSetUnderRandomOperations) {
  std::mt19937 rng(42);
  PairSet set;
  std::set<Pair> ref;
  std::uniform_int_distribution<BodyId> id(0, 300);
  for (int step = 0; step < 400000; ++step) {
    const BodyId a = id(rng), b = id(rng);
    if (a == b) continue;
    const int op = rng() % 3;
    if (op == 0) {
      EXPECT_EQ(set.insert(a, b), ref.insert(makePair(a, b)).second);
    } else if (op == 1) {
      EXPECT_EQ(set.erase(b, a), ref.erase(makePair(a, b)) == 1);
    } else {
      EXPECT_EQ(set.contains(a, b), ref.count(makePair(a, b)) == 1);
    }
    ASSERT_EQ(set.size(), ref.size());
  }
  std::vector<Pair> all;
  set.appendTo(all);
  std::sort(all.begin(), all.end());
  EXPECT_EQ(all, std::vector<Pair>(ref.begin(), ref.end()));
  set.clear();
  EXPECT_EQ(set.size(), 0u);
  EXPECT_FALSE(set.contains(all.front().a, all.front().b));
}

TEST(PairSet, OrderOfArgumentsDoesNotMatter) {
  PairSet set;
  EXPECT_TRUE(set.insert(7, 3));
  EXPECT_FALSE(set.insert(3, 7));
  EXPECT_TRUE(set.contains(3, 7));
  EXPECT_TRUE(set.erase(7, 3));
  EXPECT_FALSE(set.contains(7, 3));
}

}  // namespace
}  // namespace vadop
