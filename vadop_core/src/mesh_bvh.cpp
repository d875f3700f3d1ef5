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

bool treeMeetsBox(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p, const double* box,
                  double slack) {
  if (d.root < 0) return false;
  // The box in the mesh's frame would be a rotated box; the node's centre in the fixed frame is
  // one product per node instead.
  int stack[64];
  int top = 0;
  stack[top++] = d.root;
  while (top > 0) {
    const BvhNode& node = d.nodes[stack[--top]];
    const Eigen::Vector3d c = R * node.centre + p;
    double gap2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double out = std::max({box[k] - c[k], c[k] - box[3 + k], 0.0});
      gap2 += out * out;
    }
    const double r = node.radius + slack;
    if (gap2 > r * r) continue;
    if (node.tri >= 0) return true;
    // Median splits keep the depth under log2(triangles) + 1 < 64.
    stack[top++] = node.right;
    stack[top++] = node.left;
  }
  return false;
}

}  // namespace detail
}  // namespace vadop
