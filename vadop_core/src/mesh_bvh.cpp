// A mesh's sphere tree. See mesh_bvh.h.
#include "mesh_bvh.h"

#include "vadop/detail/parallel_for.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace vadop {
namespace detail {

namespace {

// Items a thread takes at least, and at a time, where the build shares out its work (a
// sensor's points, rebuilt for every message; a robot's meshes stay on one thread).
constexpr int kPerThread = 2048;
constexpr size_t kChunk = 1024;

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

// The bounds bottom up of the nodes [begin, end) (their children within the range, or fitted
// before): a leaf's box and ball (about the box's centre) from its padded triangle
// exactly; a node's box the union of its children's, its ball the smallest about its box's
// centre that holds theirs (a node's ball then needs no pass over its triangles: the tree of a
// sensor's 10,000 points is rebuilt for every cloud). Every node is created before its
// children: one pass in reverse order meets the children first.
void fitBounds(PreparedShapeData& d, int begin, int end) {
  const double m = d.shape.margin;
  for (int i = end - 1; i >= begin; --i) {
    BvhNode& node = d.nodes[i];
    std::array<double, 6>& box = d.node_boxes[i];
    if (node.tri >= 0) {
      const Tri& t = d.tris[node.tri];
      const Eigen::Vector3d lo = t.v[0].cwiseMin(t.v[1]).cwiseMin(t.v[2]);
      const Eigen::Vector3d hi = t.v[0].cwiseMax(t.v[1]).cwiseMax(t.v[2]);
      node.centre = 0.5 * (lo + hi);
      double r2 = 0.0;  // one square root a leaf, not one a vertex (a sensor's points: every message)
      for (int k = 0; k < 3; ++k) r2 = std::max(r2, (t.v[k] - node.centre).squaredNorm());
      node.radius = std::sqrt(r2) + m;
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
void mortonOrder(const std::vector<Item>& items, int threads, std::vector<int>& tri_order,
                 std::vector<uint32_t>& codes) {
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
  parallelFor(threads, n, kPerThread, kChunk, [&](size_t i) {
    uint32_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::min(1023.0, std::max(0.0, (items[i].centroid[k] - lo[k]) * scale));
      code |= spreadBits(static_cast<uint32_t>(q)) << k;
    }
    key[i] = code;
    tri[i] = items[i].tri;
  });
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

void buildBvh(PreparedShapeData& d, int threads) {
  const auto& P = d.shape.points;
  const auto& T = d.shape.triangles;
  const double m = d.shape.margin;
  const int n = static_cast<int>(T.size());
  threads = n >= 2 * kPerThread ? threadCount(threads) : 1;
  // The splits partition (centroid, triangle) items held side by side, not indices into the
  // centroids: the keys compared come with the items moved.
  std::vector<Item> items(n);
  parallelFor(threads, n, kPerThread, kChunk, [&](size_t i) {
    items[i] = {(P[T[i][0]] + P[T[i][1]] + P[T[i][2]]) / 3.0, static_cast<int>(i)};
  });
  // Up to kMedianMax triangles (a robot's meshes, built once): median splits of the centroids
  // along their widest axis. Beyond (a sensor's points, rebuilt for every message): Morton
  // order, in linear time after the sort (mortonSplit).
  constexpr int kMedianMax = 2048;
  const bool morton = n > kMedianMax;
  std::vector<int> tri_order;
  std::vector<uint32_t> codes;
  if (morton) mortonOrder(items, threads, tri_order, codes);
  const auto split = [&](int begin, int end) {
    return morton ? mortonSplit(codes.data(), begin, end) : splitItems(items.data() + begin, end - begin) + begin;
  };
  // A range of items and where its subtree's root goes: the child `right` of node `parent`
  // (-1: the tree's root).
  struct Range {
    int begin, end, parent;
    bool right;
  };
  d.tris.resize(n);
  d.nodes.assign(2 * static_cast<size_t>(n) - 1, BvhNode{});
  d.node_boxes.assign(d.nodes.size(), {});
  int created = 0;
  const auto link = [&d](const Range& r, int node) {
    if (r.parent >= 0) (r.right ? d.nodes[r.parent].right : d.nodes[r.parent].left) = node;
  };
  // The tree's top, breadth first, until about four ranges a thread (with one thread: none,
  // the whole set is one range); the ranges' subtrees then on the threads, each in the nodes
  // after the top that its leaves' count gives it (m leaves: 2m - 1 nodes). The same splits
  // whatever the thread count: only the nodes' order differs.
  std::vector<Range> ranges{{0, n, -1, false}}, next;
  while (threads > 1 && ranges.size() < 4 * static_cast<size_t>(threads)) {
    next.clear();
    for (const Range& r : ranges) {
      if (r.end - r.begin < 2 * kPerThread / 4) {
        next.push_back(r);
        continue;
      }
      const int node = created++;
      link(r, node);
      const int mid = split(r.begin, r.end);
      next.push_back({r.begin, mid, node, false});
      next.push_back({mid, r.end, node, true});
    }
    if (next.size() == ranges.size()) break;
    ranges.swap(next);
  }
  const int top = created;
  std::vector<int> first(ranges.size());
  for (size_t k = 0; k < ranges.size(); ++k) {
    first[k] = created;
    created += 2 * (ranges[k].end - ranges[k].begin) - 1;
  }
  d.root = 0;
  parallelFor(threads, ranges.size(), 1, 1, [&](size_t k) {
    // Depth first, each node created before its children.
    struct Job {
      int begin, end, node;
    };
    int next_node = first[k];
    const int root = next_node++;
    link(ranges[k], root);
    std::vector<Job> jobs{{ranges[k].begin, ranges[k].end, root}};
    while (!jobs.empty()) {
      const Job j = jobs.back();
      jobs.pop_back();
      if (j.end - j.begin == 1) {
        d.nodes[j.node].tri = j.begin;
        continue;
      }
      const int mid = split(j.begin, j.end);
      const int left = next_node;
      next_node += 2;
      d.nodes[j.node].left = left;
      d.nodes[j.node].right = left + 1;
      jobs.push_back({j.begin, mid, left});
      jobs.push_back({mid, j.end, left + 1});
    }
    // The range's triangles, in the order of its leaves (a leaf's neighbours in the tree are
    // its neighbours in memory: the queries' descents, and the bounds here, read them in turn).
    for (int i = ranges[k].begin; i < ranges[k].end; ++i) {
      const int t = morton ? tri_order[i] : items[i].tri;
      double lever2 = 0.0;
      for (int c = 0; c < 3; ++c) {
        d.tris[i].v[c] = P[T[t][c]];
        lever2 = std::max(lever2, d.tris[i].v[c].squaredNorm());
      }
      d.tris[i].lever = std::sqrt(lever2) + m;
    }
    fitBounds(d, first[k], next_node);
  });
  fitBounds(d, 0, top);
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
    double node_box[6];
    turnedNodeBox(d.node_boxes[it.node], R, absR, p, slack, node_box);
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
