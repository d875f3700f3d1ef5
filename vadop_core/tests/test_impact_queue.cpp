// ImpactQueue: time order with deterministic ties, replacement of a pair's impact, eager
// invalidation by body, and a randomized comparison with a brute-force reference (a map of
// pending impacts re-sorted after every operation). Memory follows the pending impacts.
#include "impact_queue.h"  // the bench's queue (vadop_core/bench, library vadop_response_loop)
#include "vadop/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <unordered_map>
#include <utility>
#include <vector>

namespace vadop {
namespace {

TimeOfImpact at(double time, Eigen::Vector3d normal = Eigen::Vector3d::UnitX()) {
  TimeOfImpact i;
  i.hit = true;
  i.time = time;
  i.normal = normal;
  i.point = Eigen::Vector3d(time, 0, 0);
  return i;
}

std::vector<std::pair<uint64_t, uint64_t>> drainPairs(ImpactQueue& q) {
  std::vector<std::pair<uint64_t, uint64_t>> out;
  while (!q.empty()) {
    const QueuedImpact x = q.pop();
    out.emplace_back(x.a, x.b);
  }
  return out;
}

TEST(ImpactQueue, PopsInTimeOrder) {
  ImpactQueue q;
  q.push(1, 2, at(0.5));
  q.push(3, 4, at(0.1));
  q.push(5, 6, at(0.9));
  q.push(7, 8, at(0.3));
  ASSERT_EQ(q.size(), 4u);
  EXPECT_EQ(q.top().impact.time, 0.1);
  std::vector<double> times;
  while (!q.empty()) times.push_back(q.pop().impact.time);
  EXPECT_EQ(times, (std::vector<double>{0.1, 0.3, 0.5, 0.9}));
}

TEST(ImpactQueue, TiesBreakByPairOrder) {
  ImpactQueue q;
  q.push(5, 9, at(1.0));
  q.push(2, 7, at(1.0));
  q.push(2, 3, at(1.0));
  q.push(8, 1, at(1.0));  // stored as (1, 8)
  q.push(4, 6, at(0.5));
  const auto order = drainPairs(q);
  const std::vector<std::pair<uint64_t, uint64_t>> expected{{4, 6}, {1, 8}, {2, 3}, {2, 7}, {5, 9}};
  EXPECT_EQ(order, expected);
}

TEST(ImpactQueue, StoresPairsSmallerKeyFirstWithTheNormalFromItToTheOther) {
  ImpactQueue q;
  q.push(9, 4, at(0.2, Eigen::Vector3d(0, 0, 1)));  // normal from 9 to 4
  const QueuedImpact& top = q.top();
  EXPECT_EQ(top.a, 4u);
  EXPECT_EQ(top.b, 9u);
  EXPECT_EQ(top.impact.normal, Eigen::Vector3d(0, 0, -1));  // from 4 to 9
  q.push(4, 7, at(0.3, Eigen::Vector3d(0, 1, 0)));
  EXPECT_EQ(q.find(7, 4)->impact.normal, Eigen::Vector3d(0, 1, 0));
}

TEST(ImpactQueue, PushingAPairAgainReplacesItsImpact) {
  ImpactQueue q;
  q.push(1, 2, at(0.5));
  q.push(3, 4, at(0.4));
  q.push(2, 1, at(0.1));  // earlier: moves to the front
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.top().a, 1u);
  EXPECT_EQ(q.top().impact.time, 0.1);
  q.push(1, 2, at(0.8));  // later: moves behind (3, 4)
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.count(1), 1u);
  EXPECT_EQ(q.pop().a, 3u);
  EXPECT_EQ(q.pop().impact.time, 0.8);
  EXPECT_TRUE(q.empty());
}

TEST(ImpactQueue, InvalidateRemovesEveryImpactOfTheBodyAndNothingElse) {
  ImpactQueue q;
  q.push(1, 2, at(0.1));
  q.push(2, 3, at(0.2));
  q.push(3, 4, at(0.3));
  q.push(2, 5, at(0.4));
  q.push(4, 5, at(0.5));
  EXPECT_EQ(q.count(2), 3u);
  EXPECT_EQ(q.invalidate(2), 3u);
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.count(2), 0u);
  EXPECT_FALSE(q.contains(1, 2));
  EXPECT_FALSE(q.contains(3, 2));
  EXPECT_EQ(q.count(4), 2u);
  EXPECT_EQ(q.invalidate(2), 0u);   // nothing left
  EXPECT_EQ(q.invalidate(42), 0u);  // never seen
  // A new impact of the invalidated body is queued normally.
  q.push(2, 4, at(0.05));
  EXPECT_EQ(q.top().a, 2u);
  EXPECT_EQ(drainPairs(q), (std::vector<std::pair<uint64_t, uint64_t>>{{2, 4}, {3, 4}, {4, 5}}));
}

TEST(ImpactQueue, EraseFindPopUntilAndSorted) {
  ImpactQueue q;
  for (uint64_t i = 0; i < 10; ++i) q.push(i, i + 100, at(0.1 * static_cast<double>(10 - i)));
  EXPECT_TRUE(q.erase(105, 5));
  EXPECT_FALSE(q.erase(5, 105));
  ASSERT_NE(q.find(3, 103), nullptr);
  EXPECT_DOUBLE_EQ(q.find(103, 3)->impact.time, 0.7);
  EXPECT_EQ(q.find(5, 105), nullptr);
  const auto sorted = q.sorted();
  ASSERT_EQ(sorted.size(), 9u);
  EXPECT_EQ(q.size(), 9u);  // sorted() does not pop
  for (size_t i = 1; i < sorted.size(); ++i) EXPECT_LT(sorted[i - 1].impact.time, sorted[i].impact.time);
  const auto early = q.popUntil(0.35);  // times 0.1, 0.2, 0.3 (i = 9, 8, 7)
  ASSERT_EQ(early.size(), 3u);
  EXPECT_EQ(early[0].a, 9u);
  EXPECT_EQ(early[2].a, 7u);
  EXPECT_EQ(q.size(), 6u);
  EXPECT_GT(q.top().impact.time, 0.35);
}

TEST(ImpactQueue, BadInputThrowsAndLeavesTheQueueUnchanged) {
  ImpactQueue q;
  q.push(1, 2, at(0.5));
  EXPECT_THROW(q.push(3, 3, at(0.1)), InvalidArgument);
  EXPECT_THROW(q.push(3, 4, at(std::numeric_limits<double>::quiet_NaN())), InvalidArgument);
  EXPECT_THROW(q.push(1, 2, at(std::numeric_limits<double>::infinity())), InvalidArgument);
  TimeOfImpact bad = at(0.1);
  bad.normal.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(q.push(3, 4, bad), InvalidArgument);
  EXPECT_EQ(q.size(), 1u);
  EXPECT_EQ(q.top().impact.time, 0.5);
  EXPECT_EQ(q.count(3), 0u);
  q.pop();
  EXPECT_THROW(q.top(), InvalidArgument);
  EXPECT_THROW(q.pop(), InvalidArgument);
}

// The reference: every pending impact in a map, sorted on demand.
struct Reference {
  std::map<std::pair<uint64_t, uint64_t>, TimeOfImpact> pending;
  std::vector<QueuedImpact> sorted() const {
    std::vector<QueuedImpact> out;
    for (const auto& kv : pending) out.push_back(QueuedImpact{kv.first.first, kv.first.second, kv.second});
    std::sort(out.begin(), out.end(), [](const QueuedImpact& x, const QueuedImpact& y) {
      if (x.impact.time != y.impact.time) return x.impact.time < y.impact.time;
      return std::make_pair(x.a, x.b) < std::make_pair(y.a, y.b);
    });
    return out;
  }
  size_t count(uint64_t body) const {
    size_t n = 0;
    for (const auto& kv : pending) n += kv.first.first == body || kv.first.second == body;
    return n;
  }
};

void expectSame(const std::vector<QueuedImpact>& got, const std::vector<QueuedImpact>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].a, want[i].a) << i;
    ASSERT_EQ(got[i].b, want[i].b) << i;
    ASSERT_EQ(got[i].impact.time, want[i].impact.time) << i;
    ASSERT_EQ(got[i].impact.normal, want[i].impact.normal) << i;
    ASSERT_EQ(got[i].impact.point, want[i].impact.point) << i;
  }
}

TEST(ImpactQueue, MatchesABruteForceReferenceUnderRandomOperations) {
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    std::mt19937_64 rng(seed);
    const uint64_t bodies = seed <= 2 ? 12 : 60;  // few bodies: many replacements and shared bodies
    std::uniform_int_distribution<uint64_t> body(0, bodies - 1);
    std::uniform_int_distribution<int> coarse(0, 20);  // times from a small set: many ties
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    ImpactQueue q;
    Reference ref;
    size_t pops = 0, invalidated = 0, replaced = 0;
    for (int step = 0; step < 6000; ++step) {
      const double r = u01(rng);
      if (r < 0.5) {
        uint64_t a = body(rng), b = body(rng);
        if (a == b) continue;
        const double t = u01(rng) < 0.5 ? 0.05 * coarse(rng) : u01(rng);
        Eigen::Vector3d n = Eigen::Vector3d::Random().normalized();
        TimeOfImpact imp = at(t, n);
        imp.point = Eigen::Vector3d::Random();
        q.push(a, b, imp);
        if (a > b) {
          std::swap(a, b);
          imp.normal = -imp.normal;
        }
        replaced += ref.pending.count({a, b});
        ref.pending[{a, b}] = imp;
      } else if (r < 0.7) {
        if (ref.pending.empty()) {
          ASSERT_TRUE(q.empty());
          continue;
        }
        const QueuedImpact want = ref.sorted().front();
        const QueuedImpact got = q.pop();
        ASSERT_EQ(got.a, want.a);
        ASSERT_EQ(got.b, want.b);
        ASSERT_EQ(got.impact.time, want.impact.time);
        ref.pending.erase({want.a, want.b});
        ++pops;
      } else if (r < 0.85) {
        const uint64_t x = body(rng);
        const size_t want = ref.count(x);
        for (auto it = ref.pending.begin(); it != ref.pending.end();) {
          it = it->first.first == x || it->first.second == x ? ref.pending.erase(it) : std::next(it);
        }
        ASSERT_EQ(q.invalidate(x), want);
        invalidated += want;
      } else if (r < 0.95) {
        const uint64_t a = body(rng), b = body(rng);
        const bool want = ref.pending.erase({std::min(a, b), std::max(a, b)}) > 0;
        ASSERT_EQ(q.erase(a, b), want);
      } else {
        const double t = u01(rng) * 0.5;
        const auto got = q.popUntil(t);
        std::vector<QueuedImpact> want;
        for (const auto& x : ref.sorted()) {
          if (x.impact.time > t) break;
          want.push_back(x);
          ref.pending.erase({x.a, x.b});
        }
        expectSame(got, want);
        pops += got.size();
      }
      ASSERT_EQ(q.size(), ref.pending.size());
      if (!ref.pending.empty()) {
        const auto want = ref.sorted().front();
        ASSERT_EQ(q.top().a, want.a);
        ASSERT_EQ(q.top().b, want.b);
      }
      const uint64_t probe = body(rng);
      ASSERT_EQ(q.count(probe), ref.count(probe));
      if (step % 250 == 0) expectSame(q.sorted(), ref.sorted());
    }
    expectSame(q.sorted(), ref.sorted());
    // The run exercised every kind of operation.
    EXPECT_GT(pops, 300u);
    EXPECT_GT(invalidated, 100u);
    EXPECT_GT(replaced, 50u);
  }
}

TEST(ImpactQueue, MemoryFollowsThePendingImpactsNotTheHistory) {
  ImpactQueue q;
  const size_t empty_bytes = q.memoryBytes();
  // A burst of 40,000 impacts over 2,000 bodies, then every body's velocity changes.
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<uint64_t> body(0, 1999);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  while (q.size() < 40000) {
    const uint64_t a = body(rng), b = body(rng);
    if (a != b) q.push(a, b, at(u01(rng)));
  }
  const size_t peak = q.memoryBytes();
  EXPECT_GT(peak, 40000u * sizeof(QueuedImpact));
  for (uint64_t x = 0; x < 2000; ++x) q.invalidate(x);
  EXPECT_TRUE(q.empty());
  // Long churn at a small number of pending impacts: the history does not accumulate.
  for (int round = 0; round < 200000; ++round) {
    const uint64_t a = body(rng) % 20, b = 20 + body(rng) % 20;
    q.push(a, b, at(u01(rng)));
    if (q.size() > 50) q.invalidate(body(rng) % 40);
  }
  EXPECT_LE(q.size(), 400u);
  EXPECT_LT(q.memoryBytes(), peak / 8) << "empty " << empty_bytes << ", peak " << peak;
  q.clear();
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.count(3), 0u);
}

}  // namespace
}  // namespace vadop

namespace vadop {
namespace {

// The queue's hash map against std::unordered_map: keys from a small range collide in long
// probe runs (and wrap around the end of the array), so erase's backward shift is exercised.
struct WeakHash {  // 7 home slots at the very end of the array, whatever its size
  size_t operator()(uint64_t k) const { return ~static_cast<size_t>(k % 7); }
};
template <class Hash>
void checkFlatMapAgainstStd(uint64_t seed, uint64_t key_range) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<uint64_t> key(0, key_range - 1);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  detail::FlatMap<uint64_t, uint64_t, Hash> map;
  std::unordered_map<uint64_t, uint64_t> ref;
  for (int step = 0; step < 40000; ++step) {
    const uint64_t k = key(rng);
    const double r = u01(rng);
    if (r < 0.5) {
      const uint64_t v = rng();
      const uint64_t got = map.insert(k, v);
      const uint64_t want = ref.emplace(k, v).first->second;
      ASSERT_EQ(got, want) << "insert " << k;
    } else if (r < 0.9) {
      ASSERT_EQ(map.erase(k), ref.erase(k) == 1) << "erase " << k;
    } else {
      map.shrinkIfSparse();
    }
    ASSERT_EQ(map.size(), ref.size());
    const uint64_t probe = key(rng);
    const uint64_t* f = map.find(probe);
    const auto it = ref.find(probe);
    ASSERT_EQ(f != nullptr, it != ref.end()) << "find " << probe;
    if (f) ASSERT_EQ(*f, it->second);
  }
  for (const auto& [k, v] : ref) {
    const uint64_t* f = map.find(k);
    ASSERT_TRUE(f != nullptr) << k;
    EXPECT_EQ(*f, v);
  }
}

struct MixHash {
  size_t operator()(uint64_t k) const { return static_cast<size_t>(k * 0x9e3779b97f4a7c15ULL >> 7); }
};

TEST(FlatMap, MatchesStdUnorderedMapUnderRandomInsertEraseAndShrink) {
  checkFlatMapAgainstStd<WeakHash>(1, 60);     // collisions: long runs, wrap-around
  checkFlatMapAgainstStd<MixHash>(2, 50);      // dense
  checkFlatMapAgainstStd<MixHash>(3, 20000);   // growth to thousands, then shrinking
}

TEST(FlatMap, ShrinksWhenSparseAndReserveMakesInsertAllocationFree) {
  detail::FlatMap<uint64_t, uint64_t, MixHash> map;
  for (uint64_t k = 0; k < 10000; ++k) map.insert(k, k);
  const size_t big = map.capacity();
  for (uint64_t k = 10; k < 10000; ++k) ASSERT_TRUE(map.erase(k));
  map.shrinkIfSparse();
  EXPECT_LT(map.capacity(), big / 100);
  for (uint64_t k = 0; k < 10; ++k) ASSERT_EQ(*map.find(k), k);
  map.reserve(500);
  const size_t cap = map.capacity();
  for (uint64_t k = 10; k < 500; ++k) map.insert(k, k);
  EXPECT_EQ(map.capacity(), cap);
}

}  // namespace
}  // namespace vadop
