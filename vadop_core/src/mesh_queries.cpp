// Sphere-tree traversals of meshes: the static distance and the certified step. See
// mesh_queries.h.
#include "mesh_queries.h"

#include "convex_distance.h"
#include "separation_step.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace vadop {
namespace detail {

// Closest pair over all leaf pairs (static distance for meshes).
DistanceResult meshDistance(const Side& A, const Side& B, const Tolerances& tol) {
  DistanceResult best;
  best.distance = kInf;
  best.lower_bound = kInf;
  int iterations = 0;
  std::vector<std::pair<int, int>> stack;
  stack.emplace_back(A.root(), B.root());
  // lower_bound: min over every leaf pair of its certified bound; pruned pairs are bounded
  // by their spheres (a valid lower bound of everything inside).
  double pruned_lower = kInf;
  while (!stack.empty()) {
    const auto [ia, ib] = stack.back();
    stack.pop_back();
    const double D = (A.centre(ia) - B.centre(ib)).norm() - A.radius(ia) - B.radius(ib);
    if (D >= best.distance) {
      pruned_lower = std::min(pruned_lower, D);
      continue;
    }
    if (A.leaf(ia) && B.leaf(ib)) {
      const Convex ca = A.convex(ia), cb = B.convex(ib);
      DistanceResult r = convexDistance(ca, cb, ca.origin() - cb.origin(), tol.abs_tol, tol.rel_tol, tol.max_iter, nullptr);
      iterations += r.iterations;
      best.lower_bound = std::min(best.lower_bound, r.lower_bound);
      if (r.distance < best.distance) {
        const double lb = best.lower_bound;
        best = r;
        best.lower_bound = lb;
      }
      continue;
    }
    const bool split_a = !A.leaf(ia) && (B.leaf(ib) || A.radius(ia) >= B.radius(ib));
    int c1, c2;
    if (split_a) {
      c1 = A.d->nodes[ia].left;
      c2 = A.d->nodes[ia].right;
      const double d1 = (A.centre(c1) - B.centre(ib)).norm() - A.radius(c1);
      const double d2 = (A.centre(c2) - B.centre(ib)).norm() - A.radius(c2);
      if (d1 < d2) std::swap(c1, c2);  // push the farther first
      stack.emplace_back(c1, ib);
      stack.emplace_back(c2, ib);
    } else {
      c1 = B.d->nodes[ib].left;
      c2 = B.d->nodes[ib].right;
      const double d1 = (B.centre(c1) - A.centre(ia)).norm() - B.radius(c1);
      const double d2 = (B.centre(c2) - A.centre(ia)).norm() - B.radius(c2);
      if (d1 < d2) std::swap(c1, c2);
      stack.emplace_back(ia, c1);
      stack.emplace_back(ia, c2);
    }
  }
  best.lower_bound = std::min(best.lower_bound, pruned_lower);
  best.lower_bound = std::min(best.lower_bound, best.distance);
  best.iterations = iterations;
  return best;
}

namespace {

// A pair of nodes waiting in meshStep's search, ordered by the step it could at most limit.
struct PairItem {
  double key;  // the pair cannot limit the step below key (-inf: may touch now)
  double D;    // lower bound of the pair's gap now
  int ia, ib;
  bool operator<(const PairItem& o) const { return key > o.key; }  // min-heap
};

// Best-first traversal of the pairs of bounding balls, ordered by the step each pair could
// at most limit: the search stops as soon as no remaining pair can shorten the best step.
class MeshStepSearch {
 public:
  MeshStepSearch(const Side& A, const Side& B, double horizon, double touch, double adv, const Tolerances& tol)
      : A(A), B(B), horizon(horizon), touch(touch), adv(adv), tol(tol), best_step(horizon) {
    out.closest.distance = kInf;
    out.closest.lower_bound = kInf;
  }

  AdvanceStep run() {
    PairItem it = bound(A.root(), B.root());
    for (;;) {
      const bool open = out.touching ? it.D < out.closest.distance  // the closest contact only
                                     : it.key < best_step;
      // No remaining pair can shorten the step: the heap is ordered by key, `it` its least.
      if (!open && !out.touching) break;
      if (open && A.leaf(it.ia) && B.leaf(it.ib)) {
        visitLeaves(it.ia, it.ib);
      } else if (open) {
        // The children of its larger inner node. The one of lower key goes on at once when no
        // waiting pair has a lower one (what the heap would give next): half the heap's work,
        // the same order of pairs.
        PairItem first, second;
        splitPair(it.ia, it.ib, first, second);
        if (second.key < first.key) std::swap(first, second);
        push(second);
        if (heap.front().key >= first.key) {
          it = first;
          continue;
        }
        push(first);
      }
      if (heap.empty()) break;
      std::pop_heap(heap.begin(), heap.end());
      it = heap.back();
      heap.pop_back();
    }
    out.closest.iterations = iterations;
    return finish();
  }

 private:
  // The pair's bounds now: its gap's lower bound and the earliest step it could limit.
  PairItem bound(int ia, int ib) const {
    const Eigen::Vector3d ca_w = A.centre(ia), cb_w = B.centre(ib);
    const Eigen::Vector3d dc = cb_w - ca_w;
    const double dcn = dc.norm();
    PairItem it{-kInf, dcn - A.radius(ia) - B.radius(ib), ia, ib};
    if (it.D > touch && dcn > 0.0) {
      // The two bounding balls, separated along the fixed centre line u: their separation
      // closes at most at mu (the balls turn about their own centres; only the centres'
      // motion counts), and it bounds the gap of everything inside them.
      const Eigen::Vector3d u = dc / dcn;
      const double mu = u.dot(A.kin.v - B.kin.v) + A.kin.w.cross(u).norm() * (ca_w - A.p).norm() +
                        B.kin.w.cross(u).norm() * (cb_w - B.p).norm();
      it.key = mu > 0.0 ? (it.D - adv) / mu : kInf;
    }
    return it;
  }

  void push(const PairItem& it) {
    heap.push_back(it);
    std::push_heap(heap.begin(), heap.end());
  }

  // Cheap screen before GJK: the exact separation of the two pieces along their centroid line
  // (ga to gb) with the linear motion bound (a valid certificate, only weaker). True when it
  // shows that the pair cannot shorten the best step.
  bool screenedOut(const Convex& ca, const Convex& cb, const Eigen::Vector3d& ga, const Eigen::Vector3d& gb) const {
    const Eigen::Vector3d u = (gb - ga).normalized();
    const double su = u.dot(cb.p - ca.p) - ca.h(u) - cb.h(-u);
    if (!(su > touch)) return false;
    const double mu =
        u.dot(A.kin.v - B.kin.v) + ca.lever * A.kin.w.cross(u).norm() + cb.lever * B.kin.w.cross(u).norm();
    return mu <= 0.0 || su - adv >= best_step * mu;
  }

  // A pair of leaves: its distance now, then (unless some pair touches) its certified step.
  void visitLeaves(int ia, int ib) {
    const Convex ca = A.convex(ia), cb = B.convex(ib);
    const Eigen::Vector3d ga = ca.centre(), gb = cb.centre();
    if (!out.touching && (gb - ga).squaredNorm() > 0.0 && screenedOut(ca, cb, ga, gb)) return;
    Eigen::Vector3d cert;
    const DistanceResult r = convexDistance(ca, cb, ga - gb, tol.abs_tol, tol.rel_tol, tol.max_iter, &cert);
    iterations += r.iterations;
    if (r.distance < out.closest.distance) {
      out.closest = r;
      closest_a = ia;
      closest_b = ib;
    }
    if (r.cores_overlap || r.distance <= touch) {
      out.touching = true;
      return;
    }
    if (out.touching) return;
    bool clear = false;
    const double st = separationStep(ca, A.kin, cb, B.kin, cert, horizon, adv, best_step, &clear);
    best_step = std::min(best_step, st);
  }

  // The pair's two children: the children of its larger inner node with the other node.
  void splitPair(int ia, int ib, PairItem& first, PairItem& second) const {
    const bool split_a = !A.leaf(ia) && (B.leaf(ib) || A.radius(ia) >= B.radius(ib));
    if (split_a) {
      first = bound(A.d->nodes[ia].left, ib);
      second = bound(A.d->nodes[ia].right, ib);
    } else {
      first = bound(ia, B.d->nodes[ib].left);
      second = bound(ia, B.d->nodes[ib].right);
    }
  }

  // The step found, or the refined contact when some pair touches.
  AdvanceStep finish() {
    if (out.touching) {
      out.closest = refineContact(A.convex(closest_a), B.convex(closest_b), out.closest);
      return out;
    }
    out.step = best_step;
    // Clear: every leaf pair examined certified the whole horizon and every other pair was
    // bounded beyond it.
    out.clear = best_step >= horizon;
    if (!std::isfinite(out.closest.distance)) {
      // Every pair was bounded away: report the centres' direction.
      const Eigen::Vector3d cc = B.centre(B.root()) - A.centre(A.root());
      out.closest.normal = cc.squaredNorm() > 0.0 ? Eigen::Vector3d(cc.normalized()) : Eigen::Vector3d::UnitX();
      out.closest.point_a = A.centre(A.root());
      out.closest.point_b = B.centre(B.root());
      out.closest.distance = out.closest.lower_bound =
          (B.centre(B.root()) - A.centre(A.root())).norm() - A.radius(A.root()) - B.radius(B.root());
    }
    return out;
  }

  const Side& A;
  const Side& B;
  const double horizon, touch, adv;
  const Tolerances& tol;
  AdvanceStep out;
  double best_step;
  int iterations = 0;
  int closest_a = -1, closest_b = -1;
  std::vector<PairItem> heap;
};

}  // namespace

AdvanceStep meshStep(const Side& A, const Side& B, double horizon, double touch, double adv,
                     const Tolerances& tol) {
  return MeshStepSearch(A, B, horizon, touch, adv, tol).run();
}

}  // namespace detail
}  // namespace vadop
