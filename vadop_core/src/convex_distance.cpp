// Distance between two posed convex cores (GJK, certified along the best direction found;
// penetration direction on overlap) and the contact refinement. See convex_distance.h.
#include "convex_distance.h"

#include "gjk.h"
#include "penetration.h"

#include <algorithm>

namespace vadop {
namespace detail {

DistanceResult convexDistance(const Convex& A, const Convex& B, const Eigen::Vector3d& guess,
                              double abs_tol, double rel_tol, int max_iter, Eigen::Vector3d* cert,
                              WarmStart* warm, bool penetration) {
  if (A.shape && B.shape && A.shape->kind == CoreKind::kPoint && B.shape->kind == CoreKind::kPoint) {
    // Two spheres: the cores are their centres, the answer exact in closed form (a fleet of
    // spheres, turning, spends most of its narrow phase in this call; GJK's set-up and
    // iterations took 8% of the node's CPU at 1,000 robots).
    const Eigen::Vector3d a = A.origin(), b = B.origin();
    const Eigen::Vector3d d = b - a;
    const double len = d.norm();
    if (len > 0.0) {
      if (warm) warm->n = 0;
      const Eigen::Vector3d m = d / len;
      DistanceResult r;
      r.iterations = 1;
      r.normal = m;
      r.distance = len - (A.rounding + B.rounding);
      r.lower_bound = std::min(separation(A, B, m), r.distance);
      r.point_a = a + A.rounding * m;
      r.point_b = b - B.rounding * m;
      if (cert) *cert = m;
      return r;
    }
  }
  SVert seed[3];
  int seed_n = 0;
  if (warm) {
    for (; seed_n < warm->n; ++seed_n) {
      SVert& v = seed[seed_n];
      v.a = A.R * warm->a[seed_n] + A.p + A.shift;
      v.b = B.R * warm->b[seed_n] + B.p + B.shift;
      v.w = v.a - v.b;
    }
  }
  const Gjk g = runGjk(A, B, guess, abs_tol, rel_tol, max_iter, kInf, seed_n > 0 ? seed : nullptr, seed_n);
  if (warm) {
    warm->n = g.overlap ? 0 : g.simplex_n;  // an overlap's simplex may be a tetrahedron: not kept
    for (int k = 0; k < warm->n; ++k) {
      warm->a[k] = A.R.transpose() * (g.simplex[k].a - A.p - A.shift);
      warm->b[k] = B.R.transpose() * (g.simplex[k].b - B.p - B.shift);
    }
  }
  DistanceResult r;
  r.iterations = g.iterations;
  const double rounding = A.rounding + B.rounding;
  if (!g.overlap) {
    // The certified direction: the final one or the best seen during the iteration,
    // whichever separates more (they differ when rounding tilts the last simplex).
    Eigen::Vector3d n = -g.v / g.dist;
    double lower = separation(A, B, n);
    if (g.best_dir.squaredNorm() > 0.0) {
      const Eigen::Vector3d nb = -g.best_dir;
      const double lb = separation(A, B, nb);
      if (lb > lower) {
        lower = lb;
        n = nb;
      }
    }
    const Eigen::Vector3d m = -g.v / g.dist;  // witness direction
    r.normal = m;
    r.distance = g.dist - rounding;
    r.lower_bound = std::min(lower, r.distance);
    r.point_a = g.a + A.rounding * m;
    r.point_b = g.b - B.rounding * m;
    if (cert) *cert = n;
    return r;
  }
  r.cores_overlap = true;
  if (!penetration) {
    r.distance = -rounding;
    r.lower_bound = -kInf;
    return r;
  }
  const Eigen::Vector3d n = penetrationDirection(A, B, g);
  if (cert) *cert = n;
  r.normal = n;
  r.lower_bound = separation(A, B, n);
  r.distance = r.lower_bound;
  r.point_a = A.support(n) + A.rounding * n;
  r.point_b = B.support(-n) - B.rounding * n;
  return r;
}

DistanceResult refineContact(const Convex& A, const Convex& B, const DistanceResult& coarse,
                             const WarmStart* coarse_simplex) {
  if (coarse.cores_overlap) return coarse;
  const double scale = 1.0 + A.p.norm() + B.p.norm() + A.lever + B.lever;
  // From the coarse GJK's final simplex when there is one (the same poses): it continues
  // that iteration to the tighter tolerance instead of starting over.
  WarmStart seed;
  if (coarse_simplex) seed = *coarse_simplex;
  DistanceResult fine = convexDistance(A, B, -coarse.normal, 1e-15 * scale, 0.0, 256, nullptr, &seed);
  if (fine.cores_overlap || !(fine.distance <= coarse.distance)) return coarse;
  fine.iterations += coarse.iterations;
  return fine;
}

}  // namespace detail
}  // namespace vadop
