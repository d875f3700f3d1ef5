// FatBoxPairs against a brute-force double loop: after any sequence of updates and removals,
// each body's partners are exactly the bodies (in the grid) whose boxes overlap its own.
#include "vadop/error.h"
#include "fat_box_pairs.h"  // internal (vadop_core/src)

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

namespace vadop {
namespace {

using BoxMap = std::map<BodyId, std::vector<double>>;

bool overlap(const std::vector<double>& a, const std::vector<double>& b) {
  for (int k = 0; k < 3; ++k) {
    if (a[k] > b[3 + k] || b[k] > a[3 + k]) return false;
  }
  return true;
}

void expectMatchesBruteForce(const FatBoxPairs& fp, const BoxMap& boxes) {
  ASSERT_EQ(fp.bodies(), boxes.size());
  size_t pairs = 0;
  for (const auto& [id, box] : boxes) {
    ASSERT_TRUE(fp.has(id)) << id;
    std::set<BodyId> want;
    if (!fp.isLarge(id)) {
      for (const auto& [j, other] : boxes) {
        if (j != id && !fp.isLarge(j) && overlap(box, other)) want.insert(j);
      }
    }
    const auto& got_list = fp.partners(id);
    const std::set<BodyId> got(got_list.begin(), got_list.end());
    ASSERT_EQ(got.size(), got_list.size()) << "duplicate partner of " << id;
    ASSERT_EQ(got, want) << "partners of " << id;
    pairs += want.size();
  }
  EXPECT_EQ(fp.pairs(), pairs / 2);
}

TEST(FatBoxPairs, PartnersMatchABruteForceLoopUnderRandomUpdatesAndRemovals) {
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> pos(-10.0, 10.0), size(0.05, 2.0), u01(0.0, 1.0);
    FatBoxPairs fp;
    fp.reset(seed == 3 ? 0.1 : 1.5);  // seed 3: small cells, many large boxes
    BoxMap boxes;
    size_t large_seen = 0;
    auto randomBox = [&] {
      std::vector<double> b(6);
      for (int k = 0; k < 3; ++k) {
        b[k] = pos(rng);
        b[3 + k] = b[k] + (u01(rng) < 0.03 ? 15.0 : size(rng));  // a few very long boxes
      }
      return b;
    };
    for (int step = 0; step < 300; ++step) {
      // A batch of new or changed bodies (ids distinct), then sometimes a removal.
      std::vector<BodyId> ids;
      std::vector<double> flat;
      const int batch = 1 + static_cast<int>(u01(rng) * 8);
      for (int i = 0; i < batch; ++i) {
        const BodyId id = static_cast<BodyId>(u01(rng) * 60);
        if (std::find(ids.begin(), ids.end(), id) != ids.end()) continue;
        const auto b = randomBox();
        ids.push_back(id);
        flat.insert(flat.end(), b.begin(), b.end());
        boxes[id] = b;
      }
      fp.update(ids, flat);
      if (u01(rng) < 0.3 && !boxes.empty()) {
        const BodyId gone = std::next(boxes.begin(), static_cast<long>(u01(rng) * boxes.size()))->first;
        fp.remove(gone);
        boxes.erase(gone);
      }
      large_seen += fp.large().size();
      expectMatchesBruteForce(fp, boxes);
      if (::testing::Test::HasFatalFailure()) return;
      // Every box it holds is contained in itself and not in a shrunk copy.
      for (const auto& [id, b] : boxes) {
        ASSERT_TRUE(fp.contains(id, b.data()));
        std::vector<double> out = b;
        out[3] += 0.5;
        ASSERT_FALSE(fp.contains(id, out.data()));
      }
    }
    if (seed == 3) EXPECT_GT(large_seen, 0u) << "small cells: no large box exercised";
    fp.reset(2.0);
    EXPECT_EQ(fp.bodies(), 0u);
    EXPECT_EQ(fp.pairs(), 0u);
  }
}

// Batches of hundreds of ids, as a crowd's escapes give, so that update() shares its queries
// out: on 1, 2 and 4 threads every partner list is the same, in the same order, and matches
// the brute-force loop.
TEST(FatBoxPairs, ThreadsGiveTheSameListsInTheSameOrder) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pos(-20.0, 20.0), size(0.1, 3.0), u01(0.0, 1.0);
  const int counts[] = {1, 2, 4};
  FatBoxPairs fp[3];
  for (FatBoxPairs& f : fp) f.reset(2.0);
  BoxMap boxes;
  for (int step = 0; step < 12; ++step) {
    std::vector<BodyId> ids;
    std::vector<double> flat;
    const size_t batch = step == 0 ? 1200 : 200 + static_cast<size_t>(u01(rng) * 400);
    std::set<BodyId> chosen;
    while (chosen.size() < batch) chosen.insert(static_cast<BodyId>(u01(rng) * 1200));
    for (const BodyId id : chosen) {
      std::vector<double> b(6);
      for (int k = 0; k < 3; ++k) {  // a crowd on a floor: z within 1 m
        b[k] = k == 2 ? u01(rng) : pos(rng);
        b[3 + k] = b[k] + (u01(rng) < 0.01 ? 60.0 : size(rng));
      }
      ids.push_back(id);
      flat.insert(flat.end(), b.begin(), b.end());
      boxes[id] = b;
    }
    std::shuffle(ids.begin(), ids.end(), rng);  // the caller's order, not sorted
    flat.clear();
    for (const BodyId id : ids) flat.insert(flat.end(), boxes[id].begin(), boxes[id].end());
    for (int t = 0; t < 3; ++t) fp[t].update(ids, flat, counts[t]);
    expectMatchesBruteForce(fp[0], boxes);
    if (::testing::Test::HasFatalFailure()) return;
    for (int t = 1; t < 3; ++t) {
      ASSERT_EQ(fp[t].pairs(), fp[0].pairs()) << counts[t] << " threads, step " << step;
      for (const auto& [id, box] : boxes) {
        ASSERT_EQ(fp[t].partners(id), fp[0].partners(id)) << counts[t] << " threads, body " << id;
      }
    }
  }
  EXPECT_GT(fp[0].pairs(), 1000u) << "too sparse to exercise the blocks";
}

TEST(FatBoxPairs, BadInputThrows) {
  FatBoxPairs fp;
  EXPECT_THROW(fp.reset(0.0), InvalidArgument);
  EXPECT_THROW(fp.reset(-1.0), InvalidArgument);
  fp.reset(1.0);
  EXPECT_THROW(fp.update({1, 2}, std::vector<double>(6)), InvalidArgument);
  EXPECT_EQ(fp.bodies(), 0u);
}

}  // namespace
}  // namespace vadop
