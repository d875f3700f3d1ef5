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
