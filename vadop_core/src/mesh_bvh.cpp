// A mesh's sphere tree. See mesh_bvh.h.
#include "mesh_bvh.h"

#include <algorithm>
#include <numeric>
#include <vector>

namespace vadop {
namespace detail {

void buildBvh(PreparedShapeData& d) {
  const auto& P = d.shape.points;
  const auto& T = d.shape.triangles;
  const double m = d.shape.margin;
  const int n = static_cast<int>(T.size());
  d.tris.resize(n);
  std::vector<Eigen::Vector3d> centroid(n);
  for (int i = 0; i < n; ++i) {
    double lever = 0.0;
    for (int k = 0; k < 3; ++k) {
      d.tris[i].v[k] = P[T[i][k]];
      lever = std::max(lever, d.tris[i].v[k].norm());
    }
    d.tris[i].lever = lever + m;
    centroid[i] = (d.tris[i].v[0] + d.tris[i].v[1] + d.tris[i].v[2]) / 3.0;
  }
  std::vector<int> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  d.nodes.reserve(2 * n);
  d.node_boxes.reserve(2 * n);
  // Explicit stack: (begin, end, node index, parent slot) built depth first.
  struct Job {
    int begin, end, node;
  };
  auto makeNode = [&](int begin, int end) {
    BvhNode node;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
    double lever = 0.0;
    for (int i = begin; i < end; ++i) {
      const Tri& t = d.tris[idx[i]];
      for (int k = 0; k < 3; ++k) {
        lo = lo.cwiseMin(t.v[k]);
        hi = hi.cwiseMax(t.v[k]);
      }
      lever = std::max(lever, t.lever);
    }
    node.centre = 0.5 * (lo + hi);
    double r = 0.0;
    for (int i = begin; i < end; ++i) {
      const Tri& t = d.tris[idx[i]];
      for (int k = 0; k < 3; ++k) r = std::max(r, (t.v[k] - node.centre).norm());
    }
    node.radius = r + m;
    node.lever = lever;
    if (end - begin == 1) node.tri = idx[begin];
    d.nodes.push_back(node);
    const Eigen::Vector3d half = 0.5 * (hi - lo) + Eigen::Vector3d::Constant(m);
    d.node_boxes.push_back({node.centre.x(), node.centre.y(), node.centre.z(), half.x(), half.y(), half.z()});
    return static_cast<int>(d.nodes.size()) - 1;
  };
  d.root = makeNode(0, n);
  std::vector<Job> jobs{{0, n, d.root}};
  while (!jobs.empty()) {
    const Job j = jobs.back();
    jobs.pop_back();
    if (j.end - j.begin <= 1) continue;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
    for (int i = j.begin; i < j.end; ++i) {
      lo = lo.cwiseMin(centroid[idx[i]]);
      hi = hi.cwiseMax(centroid[idx[i]]);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const int mid = j.begin + (j.end - j.begin) / 2;
    std::nth_element(idx.begin() + j.begin, idx.begin() + mid, idx.begin() + j.end,
                     [&](int x, int y) { return centroid[x][axis] < centroid[y][axis]; });
    const int left = makeNode(j.begin, mid);
    const int right = makeNode(mid, j.end);
    d.nodes[j.node].left = left;
    d.nodes[j.node].right = right;
    jobs.push_back({j.begin, mid, left});
    jobs.push_back({mid, j.end, right});
  }
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
  Item stack[64];  // median splits keep the depth under log2(triangles) + 1
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
