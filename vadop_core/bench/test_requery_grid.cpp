// RequeryGrid (the bench world's mid-frame re-query structure) against a brute-force loop over
// the current boxes: after a build and under repeated moves (small boxes and wide ones, some far
// outside the box of the build, bodies moved again so that their old listings are stale), every
// query must return every body whose current box overlaps, each once, never its own, and
// nothing beyond the bodies whose boxes come within single-precision rounding (the grid holds
// its boxes as floats).
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

// The bodies whose box, grown by `slack` relative to the coordinates, overlaps q.
std::vector<uint32_t> bruteForce(const std::vector<Box>& boxes, uint32_t id, const Box& q, double slack = 0.0) {
  std::vector<uint32_t> out;
  for (uint32_t k = 0; k < boxes.size(); ++k) {
    Box b = boxes[k];
    b.lo.array() -= slack * (1.0 + b.lo.array().abs());
    b.hi.array() += slack * (1.0 + b.hi.array().abs());
    if (k != id && vadop_bench::overlaps(b, q)) out.push_back(k);
  }
  return out;
}

bool isSubset(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  return std::includes(b.begin(), b.end(), a.begin(), a.end());
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
      ASSERT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << "duplicate, step " << step;
      ASSERT_TRUE(isSubset(bruteForce(boxes, id, q), got)) << "missed a body: round " << round << " step " << step;
      ASSERT_TRUE(isSubset(got, bruteForce(boxes, id, q, 1e-6))) << "far body: round " << round << " step " << step;
      ++checked;
      found += got.size();
    }
  }
  EXPECT_GT(found, checked);  // the queries were not trivially empty
}

// Rounding to float must never separate boxes: those that touch the query at a face (in double)
// or overlap it by far less than a float's resolution are found.
TEST(RequeryGrid, FindsBoxesTouchingBelowFloatResolution) {
  const double half = 30.0;
  std::vector<Box> boxes(3);
  const Eigen::Vector3d lo(1.1, -7.3, 12.7);
  boxes[0] = Box{lo, lo + Eigen::Vector3d(2.0, 2.0, 2.0)};
  boxes[1] = Box{Eigen::Vector3d(20.0, 20.0, 20.0), Eigen::Vector3d(21.0, 21.0, 21.0)};
  boxes[2] = Box{Eigen::Vector3d(-20.0, -20.0, -20.0), Eigen::Vector3d(-19.0, -19.0, -19.0)};
  RequeryGrid grid;
  grid.build(boxes, half);
  std::vector<uint32_t> got;
  const double eps = 1e-12;
  // Query boxes above box 0 from x = its hi (exact face contact) or just inside it, and below
  // it up to x = its lo or just inside.
  for (const double x0 : {boxes[0].hi.x(), boxes[0].hi.x() - eps}) {
    const Box q{Eigen::Vector3d(x0, lo.y() + 0.5, lo.z() + 0.5), Eigen::Vector3d(x0 + 1.0, lo.y() + 1.0, lo.z() + 1.0)};
    grid.query(2, q, got);
    EXPECT_EQ(got, std::vector<uint32_t>{0}) << "above, x0 = " << x0;
  }
  for (const double x1 : {lo.x(), lo.x() + eps}) {
    const Box q{Eigen::Vector3d(x1 - 1.0, lo.y() + 0.5, lo.z() + 0.5), Eigen::Vector3d(x1, lo.y() + 1.0, lo.z() + 1.0)};
    grid.query(2, q, got);
    EXPECT_EQ(got, std::vector<uint32_t>{0}) << "below, x1 = " << x1;
  }
  // The same after box 0 moved (its listing in the moved bodies' lists).
  boxes[0] = Box{lo + Eigen::Vector3d(0.3, 0.0, 0.0), lo + Eigen::Vector3d(2.3, 2.0, 2.0)};
  grid.moved(0, boxes[0]);
  const Box q{Eigen::Vector3d(boxes[0].hi.x(), lo.y(), lo.z()), Eigen::Vector3d(boxes[0].hi.x() + 1.0, lo.y() + 1.0, lo.z() + 1.0)};
  grid.query(2, q, got);
  EXPECT_EQ(got, std::vector<uint32_t>{0});
}

}  // namespace
