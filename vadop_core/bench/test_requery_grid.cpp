// RequeryGrid (the bench world's mid-frame re-query structure) against a brute-force loop over
// the current boxes: after a build and under repeated moves (small boxes and wide ones, some far
// outside the box of the build, bodies moved again so that their old listings are stale), every
// query must return exactly the bodies whose current box overlaps, each once, never its own.
#include "bench_world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace {

using vadop_bench::Box;
using vadop_bench::RequeryGrid;

Box randomBox(std::mt19937_64& rng, double half, double max_extent) {
  std::uniform_real_distribution<double> c(-half - 1.0, half + 1.0), e(0.0, max_extent);
  Box b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = c(rng);
    b.hi[k] = b.lo[k] + e(rng);
  }
  return b;
}

std::vector<uint32_t> bruteForce(const std::vector<Box>& boxes, uint32_t id, const Box& q) {
  std::vector<uint32_t> out;
  for (uint32_t k = 0; k < boxes.size(); ++k) {
    if (k != id && vadop_bench::overlaps(boxes[k], q)) out.push_back(k);
  }
  return out;
}

TEST(RequeryGrid, QueriesMatchBruteForceUnderMoves) {
  std::mt19937_64 rng(11);
  const double half = 30.0;
  size_t checked = 0, found = 0;
  for (int round = 0; round < 6; ++round) {
    const uint32_t n = 400 + 300 * round;
    std::vector<Box> boxes(n);
    for (auto& b : boxes) b = randomBox(rng, half, round % 2 ? 4.0 : 1.5);
    for (int w = 0; w < 5; ++w) boxes[rng() % n] = randomBox(rng, half, 25.0);  // wide at build
    RequeryGrid grid;
    grid.build(boxes, half);
    std::vector<uint32_t> got;
    for (int step = 0; step < 600; ++step) {
      const uint32_t id = static_cast<uint32_t>(rng() % n);
      if (step % 3 != 2) {  // move: mostly cell-sized boxes, some wide, some far outside
        const double ext = step % 17 == 0 ? 20.0 : 3.0;
        boxes[id] = randomBox(rng, step % 29 == 0 ? 3.0 * half : half, ext);
        grid.moved(id, boxes[id]);
      }
      const Box q = randomBox(rng, half, step % 11 == 0 ? 30.0 : 5.0);
      grid.query(id, q, got);
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, bruteForce(boxes, id, q)) << "round " << round << " step " << step;
      ++checked;
      found += got.size();
    }
  }
  EXPECT_GT(found, checked);  // the queries were not trivially empty
}

}  // namespace
