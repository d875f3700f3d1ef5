// A mesh's sphere tree. See mesh_bvh.h.
#include "mesh_bvh.h"

#include <algorithm>
#include <vector>

namespace vadop {
namespace detail {

namespace {

struct Item {
  Eigen::Vector3d centroid;
  int tri;
};

// Splits items[0, n) (n >= 2) across the widest axis of their centroids at about their median:
// returns k in [1, n) with every item before k at or below every item from k on along that axis.
// Ranges up to kExact items are split at the exact median (nth_element); larger ones at the
// median of kSamples evenly spaced items, in one partition pass instead of nth_element's
// several; the halves stay near even (test_point_set bounds the depth).
int splitItems(Item* items, int n) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
  for (int i = 0; i < n; ++i) {
    lo = lo.cwiseMin(items[i].centroid);
    hi = hi.cwiseMax(items[i].centroid);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const auto below = [axis](const Item& x, const Item& y) { return x.centroid[axis] < y.centroid[axis]; };
  constexpr int kExact = 64, kSamples = 31;
  if (n <= kExact) {
    std::nth_element(items, items + n / 2, items + n, below);
    return n / 2;
  }
  double sample[kSamples];
  for (int s = 0; s < kSamples; ++s) {
    sample[s] = items[static_cast<int64_t>(n) * (2 * s + 1) / (2 * kSamples)].centroid[axis];
  }
  std::nth_element(sample, sample + kSamples / 2, sample + kSamples);
  const double pivot = sample[kSamples / 2];
  const auto firstNotBelow = [&](auto&& below_pivot) {
    return static_cast<int>(std::partition(items, items + n, below_pivot) - items);
  };
  int k = firstNotBelow([&](const Item& x) { return x.centroid[axis] < pivot; });
  if (k == 0) k = firstNotBelow([&](const Item& x) { return x.centroid[axis] <= pivot; });  // pivot = least key
  if (k == 0 || k == n) {  // every key equal: any split is one
    return n / 2;
  }
  return k;
}

// The bounds bottom up: a leaf's box, ball (about the box's centre) and lever arm from its
// padded triangle exactly; a node's box the union of its children's, its ball the smallest
// about its box's centre that holds theirs (a node's ball then needs no pass over its
// triangles: the tree of a sensor's 10,000 points is rebuilt for every cloud). Every node was
// created before its children: one pass in reverse order meets the children first.
void fitBounds(PreparedShapeData& d) {
  const double m = d.shape.margin;
  d.node_boxes.assign(d.nodes.size(), {});
  for (int i = static_cast<int>(d.nodes.size()) - 1; i >= 0; --i) {
    BvhNode& node = d.nodes[i];
    std::array<double, 6>& box = d.node_boxes[i];
    if (node.tri >= 0) {
      const Tri& t = d.tris[node.tri];
      const Eigen::Vector3d lo = t.v[0].cwiseMin(t.v[1]).cwiseMin(t.v[2]);
      const Eigen::Vector3d hi = t.v[0].cwiseMax(t.v[1]).cwiseMax(t.v[2]);
      node.centre = 0.5 * (lo + hi);
      double r = 0.0;
      for (int k = 0; k < 3; ++k) r = std::max(r, (t.v[k] - node.centre).norm());
      node.radius = r + m;
      node.lever = t.lever;
      const Eigen::Vector3d half = 0.5 * (hi - lo) + Eigen::Vector3d::Constant(m);
      box = {node.centre.x(), node.centre.y(), node.centre.z(), half.x(), half.y(), half.z()};
      continue;
    }
    const std::array<double, 6>& a = d.node_boxes[node.left];
    const std::array<double, 6>& b = d.node_boxes[node.right];
    Eigen::Vector3d lo, hi;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(a[k] - a[3 + k], b[k] - b[3 + k]);
      hi[k] = std::max(a[k] + a[3 + k], b[k] + b[3 + k]);
    }
    node.centre = 0.5 * (lo + hi);
    const BvhNode& l = d.nodes[node.left];
    const BvhNode& r = d.nodes[node.right];
    node.radius = std::max((l.centre - node.centre).norm() + l.radius, (r.centre - node.centre).norm() + r.radius);
    node.lever = std::max(l.lever, r.lever);
    const Eigen::Vector3d half = 0.5 * (hi - lo);
    box = {node.centre.x(), node.centre.y(), node.centre.z(), half.x(), half.y(), half.z()};
  }
}

// Large sets: the items in the order of their centroids' Morton codes (10 bits an axis over
// the items' largest extent), sorted in three radix passes. The code of a cell of the
// implicit octree over that extent is a prefix, so a range of sorted items whose first and last
// codes first differ at bit b splits where bit b turns to 1: each node is an octree cell, split
// in two along one axis, and the build is linear after the sort. Items sharing one code (within
// a 1/1024th of the extent on every axis) split at their middle. The depth stays under
// 30 + log2(n) + 1.
int mortonSplit(const uint32_t* codes, int begin, int end) {
  const uint32_t first = codes[begin], last = codes[end - 1];
  if (first == last) return (begin + end) / 2;
  const uint32_t bit = uint32_t{1} << (31 - __builtin_clz(first ^ last));
  // The first item with that bit set (the codes below it agree with `first` above it).
  return static_cast<int>(std::partition_point(codes + begin, codes + end, [bit](uint32_t c) { return (c & bit) == 0; }) -
                          codes);
}

// Spreads the low 10 bits of x to every third bit (bit k to bit 3k).
uint32_t spreadBits(uint32_t x) {
  x &= 0x3ffu;
  x = (x | (x << 16)) & 0x030000ffu;
  x = (x | (x << 8)) & 0x0300f00fu;
  x = (x | (x << 4)) & 0x030c30c3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

// The items' triangles in Morton order of their centroids (tri_order) and their codes.
void mortonOrder(const std::vector<Item>& items, std::vector<int>& tri_order, std::vector<uint32_t>& codes) {
  const int n = static_cast<int>(items.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
  for (const Item& it : items) {
    lo = lo.cwiseMin(it.centroid);
    hi = hi.cwiseMax(it.centroid);
  }
  // One scale for the three axes: the octree's cells are cubes, so a flat set's first splits
  // are across its wide axes (per-axis scales would split a 20 m x 20 m x 1 m slab across its
  // height as early as across its width).
  const double extent = (hi - lo).maxCoeff();
  const double scale = extent > 0.0 ? 1023.0 / extent : 0.0;
  std::vector<uint32_t> key(n), key_tmp(n);
  std::vector<int> tri(n), tri_tmp(n);
  for (int i = 0; i < n; ++i) {
    uint32_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::min(1023.0, std::max(0.0, (items[i].centroid[k] - lo[k]) * scale));
      code |= spreadBits(static_cast<uint32_t>(q)) << k;
    }
    key[i] = code;
    tri[i] = items[i].tri;
  }
  // Least significant digit first, 10 bits a pass (stable: equal codes keep their order).
  for (int shift = 0; shift < 30; shift += 10) {
    uint32_t count[1025] = {};
    for (int i = 0; i < n; ++i) ++count[((key[i] >> shift) & 0x3ffu) + 1];
    for (int b = 0; b < 1024; ++b) count[b + 1] += count[b];
    for (int i = 0; i < n; ++i) {
      const uint32_t at = count[(key[i] >> shift) & 0x3ffu]++;
      key_tmp[at] = key[i];
      tri_tmp[at] = tri[i];
    }
    key.swap(key_tmp);
    tri.swap(tri_tmp);
  }
  tri_order = std::move(tri);
  codes = std::move(key);
}

}  // namespace

void buildBvh(PreparedShapeData& d) {
  const auto& P = d.shape.points;
  const auto& T = d.shape.triangles;
  const double m = d.shape.margin;
  const int n = static_cast<int>(T.size());
  d.tris.resize(n);
  // The splits partition (centroid, triangle) items held side by side, not indices into the
  // centroids: the keys compared come with the items moved.
  std::vector<Item> items(n);
  for (int i = 0; i < n; ++i) {
    double lever = 0.0;
    for (int k = 0; k < 3; ++k) {
      d.tris[i].v[k] = P[T[i][k]];
      lever = std::max(lever, d.tris[i].v[k].norm());
    }
    d.tris[i].lever = lever + m;
    items[i] = {(d.tris[i].v[0] + d.tris[i].v[1] + d.tris[i].v[2]) / 3.0, i};
  }
  d.nodes.clear();
  d.nodes.reserve(2 * n);
  // The structure top down, each node created before its children; then their bounds
  // (fitBounds). Up to kMedianMax triangles (a robot's meshes, built once): median splits of
  // the centroids along their widest axis. Beyond (a sensor's points, rebuilt for every
  // message): Morton order, in linear time after the sort (mortonSplit).
  constexpr int kMedianMax = 2048;
  const bool morton = n > kMedianMax;
  std::vector<int> tri_order;
  std::vector<uint32_t> codes;
  if (morton) mortonOrder(items, tri_order, codes);
  struct Job {
    int begin, end, node;
  };
  d.nodes.emplace_back();
  d.root = 0;
  std::vector<Job> jobs{{0, n, d.root}};
  while (!jobs.empty()) {
    const Job j = jobs.back();
    jobs.pop_back();
    if (j.end - j.begin == 1) {
      d.nodes[j.node].tri = morton ? tri_order[j.begin] : items[j.begin].tri;
      continue;
    }
    const int mid = morton ? mortonSplit(codes.data(), j.begin, j.end)
                           : splitItems(items.data() + j.begin, j.end - j.begin) + j.begin;
    const int left = static_cast<int>(d.nodes.size());
    d.nodes.emplace_back();
    d.nodes.emplace_back();
    d.nodes[j.node].left = left;
    d.nodes[j.node].right = left + 1;
    jobs.push_back({j.begin, mid, left});
    jobs.push_back({mid, j.end, left + 1});
  }
  fitBounds(d);
}

uint64_t partsMeetingTree(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
                          const double* part_boxes, uint64_t parts, double slack) {
  if (d.root < 0 || parts == 0) return 0;
  const Eigen::Matrix3d absR = R.cwiseAbs();
  uint64_t met = 0;
  // Depth first, each node with the parts whose boxes met all its ancestors' boxes.
  struct Item {
    int node;
    uint64_t parts;
  };
  Item stack[64];  // the depth stays under 30 + log2(triangles) + 1 (buildBvh)
  int top = 0;
  stack[top++] = {d.root, parts};
  while (top > 0) {
    const Item it = stack[--top];
    const uint64_t open = it.parts & ~met;  // parts already met need no more search
    if (open == 0) continue;
    const std::array<double, 6>& nb = d.node_boxes[it.node];
    // The node's box turned into the fixed frame: the box about the turned centre with half
    // extents |R| h (bounds the turned box), grown by the slack.
    const Eigen::Vector3d c = R * Eigen::Vector3d(nb[0], nb[1], nb[2]) + p;
    const Eigen::Vector3d h = absR * Eigen::Vector3d(nb[3], nb[4], nb[5]) + Eigen::Vector3d::Constant(slack);
    const double node_box[6] = {c.x() - h.x(), c.y() - h.y(), c.z() - h.z(), c.x() + h.x(), c.y() + h.y(), c.z() + h.z()};
    uint64_t here = 0;
    for (uint64_t bits = open; bits != 0; bits &= bits - 1) {
      const int k = __builtin_ctzll(bits);
      const double* b = part_boxes + 6 * k;
      const bool overlap = b[0] <= node_box[3] && node_box[0] <= b[3] && b[1] <= node_box[4] && node_box[1] <= b[4] &&
                           b[2] <= node_box[5] && node_box[2] <= b[5];
      here |= uint64_t{overlap} << k;
    }
    if (here == 0) continue;
    const BvhNode& node = d.nodes[it.node];
    if (node.tri >= 0) {
      met |= here;
      if (met == parts) return met;
      continue;
    }
    stack[top++] = {node.right, here};
    stack[top++] = {node.left, here};
  }
  return met;
}

}  // namespace detail
}  // namespace vadop
