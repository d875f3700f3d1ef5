// CellGrid against a brute-force loop over the same boxes: whichever way the grid was filled
// (build() of a batch, set()/remove() one box at a time with stale entries left behind, then
// compacted or not),
// forEachOverlap reports each overlapping box that is not large exactly once, and the large
// ones are exactly the boxes spanning more than kMaxCells cells or leaving the coordinate range.
// Scenes: compact (build() takes the dense cell array), sparse (the hash table), boxes on cell
// boundaries, queries spanning more cells than a scan costs.
#include "vadop/error.h"
#include "cell_grid.h"  // internal (vadop_core/src)

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <vector>

namespace vadop {
namespace {

using detail::CellGrid;
using Box = std::vector<double>;

bool overlap(const Box& a, const double* b) {
  for (int k = 0; k < 3; ++k) {
    if (a[k] > b[3 + k] || b[k] > a[3 + k]) return false;
  }
  return true;
}

// Independent of the grid's arithmetic: cells counted with std::floor, range by comparison.
bool expectLarge(const Box& b, double h) {
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double lo = b[k] / h, hi = b[3 + k] / h;
    if (!(std::abs(lo) < CellGrid::kMaxCoordinate && std::abs(hi) < CellGrid::kMaxCoordinate)) return true;
    cells *= std::floor(hi) - std::floor(lo) + 1.0;
  }
  return cells > static_cast<double>(CellGrid::kMaxCells);
}

// Every query answer of `grid` against the brute force over `boxes` (item -> box).
void expectQueriesMatch(const CellGrid& grid, const std::map<uint32_t, Box>& boxes, const std::vector<Box>& queries) {
  std::vector<int> count;
  for (const Box& q : queries) {
    count.assign(boxes.empty() ? 0 : boxes.rbegin()->first + 1, 0);
    grid.forEachOverlap(q.data(), [&](uint32_t item) {
      ASSERT_LT(item, count.size());
      ++count[item];
    });
    for (const auto& [item, box] : boxes) {
      const bool large = expectLarge(box, grid.cellSize());
      const int want = !large && overlap(q, box.data()) ? 1 : 0;
      ASSERT_EQ(count[item], want) << "item " << item << (large ? " (large)" : "");
    }
    for (uint32_t i = 0; i < count.size(); ++i) {
      if (!boxes.count(i)) ASSERT_EQ(count[i], 0) << "item " << i << " has no box";
    }
  }
}

struct Scene {
  double extent;  // boxes' lo corners in [-extent, extent]^3
  double size;    // and sizes up to this
  double h;       // cell size
};

Box randomBox(std::mt19937_64& rng, const Scene& s) {
  std::uniform_real_distribution<double> pos(-s.extent, s.extent), size(0.0, s.size), u01(0.0, 1.0);
  Box b(6);
  const double r = u01(rng);
  for (int k = 0; k < 3; ++k) {
    b[k] = pos(rng);
    if (r < 0.1) b[k] = std::round(b[k] / s.h) * s.h;  // on a cell boundary
    b[3 + k] = b[k] + (r < 0.05 ? 40.0 * s.h : r < 0.15 ? 0.0 : size(rng));  // long, flat, ordinary
  }
  return b;
}

// Random boxes, and boxes about listed ones (a sparse scene's random queries meet nothing).
std::vector<Box> randomQueries(std::mt19937_64& rng, const Scene& s, const std::map<uint32_t, Box>& boxes) {
  std::vector<Box> q;
  for (int i = 0; i < 30; ++i) q.push_back(randomBox(rng, s));
  std::uniform_real_distribution<double> grow(-0.5 * s.size, 2.0 * s.size);
  for (auto it = boxes.begin(); it != boxes.end() && q.size() < 90; ++it) {
    Box b = it->second;
    for (int k = 0; k < 3; ++k) {
      b[k] -= std::max(0.0, grow(rng));
      b[3 + k] = std::max(b[k], b[3 + k] + grow(rng));
    }
    q.push_back(b);
  }
  q.push_back({-2 * s.extent, -2 * s.extent, -2 * s.extent, 2 * s.extent, 2 * s.extent, 2 * s.extent});  // a scan
  q.push_back({0.0, 0.0, 0.0, 0.0, 0.0, 0.0});                                                        // a point
  return q;
}

// The first fills its cells (the dense array at n = 400), the second is sparse (hash table).
const Scene kScenes[] = {{3.0, 1.0, 0.7}, {1000.0, 2.0, 1.0}, {20.0, 3.0, 0.25}};

TEST(CellGrid, BuildAnswersEveryOverlapOnceAgainstBruteForce) {
  uint64_t seed = 0;
  for (const Scene& s : kScenes) {
    for (size_t n : {1, 2, 37, 400}) {
      std::mt19937_64 rng(++seed);
      std::vector<double> flat;
      std::map<uint32_t, Box> boxes;
      for (uint32_t i = 0; i < n; ++i) {
        boxes[i] = randomBox(rng, s);
        flat.insert(flat.end(), boxes[i].begin(), boxes[i].end());
      }
      CellGrid grid;
      grid.build(flat.data(), n, s.h);
      std::vector<uint32_t> large;
      for (const auto& [i, b] : boxes) {
        if (expectLarge(b, s.h)) large.push_back(i);
      }
      EXPECT_EQ(grid.large(), large);
      // The cells hold each non-large box once per cell it spans, with its own box and item.
      size_t entries = 0;
      for (size_t c = 0; c < grid.cellCount(); ++c) {
        for (auto* e = grid.entriesBegin(c); e != grid.entriesEnd(c); ++e, ++entries) {
          ASSERT_EQ(Box(e->box, e->box + 6), boxes.at(e->item));
          const CellGrid::Cell& cell = grid.cell(c);
          for (int k = 0; k < 3; ++k) {
            const int32_t coord = k == 0 ? cell.x : k == 1 ? cell.y : cell.z;
            ASSERT_LE(std::floor(e->box[k] / s.h), coord);
            ASSERT_GE(std::floor(e->box[3 + k] / s.h), coord);
          }
        }
      }
      EXPECT_EQ(entries, grid.entryCount());
      expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
      // set() needs a reset(): the built grid is refused and unchanged.
      EXPECT_THROW(grid.set(0, flat.data()), InvalidArgument);
      expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
    }
  }
}

TEST(CellGrid, SetAndRemoveAnswerEveryOverlapOnceAgainstBruteForce) {
  uint64_t seed = 100;
  for (const Scene& s : kScenes) {
    std::mt19937_64 rng(++seed);
    std::uniform_int_distribution<uint32_t> pick(0, 299);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    CellGrid grid;
    grid.reset(s.h);
    std::map<uint32_t, Box> boxes;
    for (int round = 0; round < 8; ++round) {
      for (int op = 0; op < 150; ++op) {
        const uint32_t item = pick(rng);
        if (u01(rng) < 0.2) {
          grid.remove(item);
          boxes.erase(item);
        } else {
          boxes[item] = randomBox(rng, s);
          grid.set(item, boxes[item].data());
        }
      }
      ASSERT_EQ(grid.items(), boxes.size());
      for (uint32_t i = 0; i < 300; ++i) {
        ASSERT_EQ(grid.has(i), boxes.count(i) == 1) << i;
        if (grid.has(i)) {
          ASSERT_EQ(grid.isLarge(i), expectLarge(boxes[i], s.h)) << i;
          ASSERT_EQ(Box(grid.box(i), grid.box(i) + 6), boxes[i]);
        }
      }
      expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
    }
    grid.reset(s.h);  // forgets everything
    EXPECT_EQ(grid.items(), 0u);
    boxes.clear();
    expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
  }
}

TEST(CellGrid, CompactionDropsTheStaleEntriesAndKeepsEveryAnswer) {
  uint64_t seed = 300;
  for (const Scene& s : kScenes) {
    std::mt19937_64 rng(++seed);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    CellGrid grid;
    grid.reset(s.h);
    std::map<uint32_t, Box> boxes;
    for (uint32_t i = 0; i < 300; ++i) {
      boxes[i] = randomBox(rng, s);
      grid.set(i, boxes[i].data());
    }
    for (int round = 0; round < 6; ++round) {
      // Every box set anew (its old entries stale), some removed: then compacted, and again
      // set and removed on top of the packed chains.
      for (uint32_t i = 0; i < 300; ++i) {
        if (u01(rng) < 0.1) {
          grid.remove(i);
          boxes.erase(i);
        } else {
          boxes[i] = randomBox(rng, s);
          grid.set(i, boxes[i].data());
        }
      }
      const size_t before = grid.memoryBytes();
      grid.compactIfStale();
      EXPECT_LT(grid.memoryBytes(), before) << "round " << round;  // a third of the entries at most were live
      expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
      for (uint32_t i = 0; i < 300; i += 7) {
        boxes[i] = randomBox(rng, s);
        grid.set(i, boxes[i].data());
      }
      grid.remove(3);
      boxes.erase(3);
      expectQueriesMatch(grid, boxes, randomQueries(rng, s, boxes));
    }
  }
}

TEST(CellGrid, CoordinatesBeyondTheRangeAreLargeAndResetCoarsensCells) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CellGrid grid;
  grid.reset(1.0);
  const Box far = {1e12, 0, 0, 1e12 + 1, 1, 1}, bad = {nan, 0, 0, 1, 1, 1}, near = {0, 0, 0, 1, 1, 1};
  grid.set(0, far.data());
  grid.set(1, bad.data());
  grid.set(2, near.data());
  EXPECT_TRUE(grid.isLarge(0));
  EXPECT_TRUE(grid.isLarge(1));
  EXPECT_FALSE(grid.isLarge(2));
  expectQueriesMatch(grid, {{0, far}, {2, near}}, {near, far, {-1, -1, -1, 2, 2, 2}});
  // With the coordinates' reach given, cells grow so that the far box is listed.
  grid.reset(1.0, 2e12);
  EXPECT_GE(grid.cellSize(), 2.0 * 2e12 / CellGrid::kMaxCoordinate);
  grid.set(0, far.data());
  EXPECT_FALSE(grid.isLarge(0));
  expectQueriesMatch(grid, {{0, far}}, {far, near});
  EXPECT_THROW(grid.reset(0.0), InvalidArgument);
  EXPECT_THROW(grid.reset(nan), InvalidArgument);
  EXPECT_FALSE(grid.isLarge(0));  // a refused reset changes nothing
  EXPECT_TRUE(grid.has(0));
}

}  // namespace
}  // namespace vadop
