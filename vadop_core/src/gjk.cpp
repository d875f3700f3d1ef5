// GJK on support mappings: the simplex reductions and the iteration. See gjk.h.
#include "gjk.h"

#include "posed_convex.h"
#include "swept_volume.h"

#include <algorithm>
#include <cmath>

namespace vadop {
namespace detail {

namespace {

// Closest point to the origin on segment s[0]s[1]; reduces the simplex. Returns weights.
void closestSegment(SVert* s, int& n, double* lambda) {
  const Eigen::Vector3d ab = s[1].w - s[0].w;
  const double t = -s[0].w.dot(ab);
  const double denom = ab.squaredNorm();
  if (t <= 0.0 || denom <= 0.0) {
    n = 1;
    lambda[0] = 1.0;
    return;
  }
  if (t >= denom) {
    s[0] = s[1];
    n = 1;
    lambda[0] = 1.0;
    return;
  }
  lambda[1] = t / denom;
  lambda[0] = 1.0 - lambda[1];
  n = 2;
}

// Closest point to the origin on a triangle. The origin is projected onto the triangle's
// plane (n (n.A) / n.n, accurate in direction even when the closest point is tiny compared
// with the triangle) and its barycentric coordinates are signed areas measured along n
// (no squared conditioning); when the projection falls outside, the closest point lies on
// an edge facing it. Writes the reduced simplex to out[0..m) with weights.
void closestTriangle(const SVert& A, const SVert& B, const SVert& C, SVert* out, int& m,
                     double* lambda) {
  const Eigen::Vector3d ab = B.w - A.w, ac = C.w - A.w;
  const Eigen::Vector3d n = ab.cross(ac);
  const double nn = n.squaredNorm();
  const SVert* v3[3] = {&A, &B, &C};
  // The closest point over the edges opposite the vertices k with use[k].
  auto closestEdge = [&](const bool use[3]) {
    double best = kInf;
    for (int k = 0; k < 3; ++k) {
      if (!use[k]) continue;
      SVert s[2] = {*v3[(k + 1) % 3], *v3[(k + 2) % 3]};
      int ns = 2;
      double ls[2];
      closestSegment(s, ns, ls);
      Eigen::Vector3d v = ls[0] * s[0].w;
      if (ns == 2) v += ls[1] * s[1].w;
      if (v.squaredNorm() < best) {
        best = v.squaredNorm();
        m = ns;
        for (int q = 0; q < ns; ++q) { out[q] = s[q]; lambda[q] = ls[q]; }
      }
    }
  };
  if (nn > 1e-28 * ab.squaredNorm() * ac.squaredNorm() && nn > 0.0) {
    const Eigen::Vector3d p = n * (n.dot(A.w) / nn);
    double l[3];
    l[0] = n.dot((B.w - p).cross(C.w - p)) / nn;
    l[1] = n.dot((C.w - p).cross(A.w - p)) / nn;
    l[2] = n.dot((A.w - p).cross(B.w - p)) / nn;
    if (l[0] >= 0.0 && l[1] >= 0.0 && l[2] >= 0.0) {
      const double sum = l[0] + l[1] + l[2];
      out[0] = A; out[1] = B; out[2] = C; m = 3;
      for (int k = 0; k < 3; ++k) lambda[k] = l[k] / sum;
      return;
    }
    // Edges opposite a negative coordinate face the projection.
    const bool facing[3] = {l[0] < 0.0, l[1] < 0.0, l[2] < 0.0};
    closestEdge(facing);
    return;
  }
  // Degenerate (collinear) triangle: the closest of its edges.
  const bool all[3] = {true, true, true};
  closestEdge(all);
}

// The closest point itself, computed from the reduced simplex in the most accurate form:
// a plane projection for a triangle, a perpendicular for a segment.
Eigen::Vector3d closestPoint(const SVert* s, int n, const double* lambda) {
  if (n == 3) {
    const Eigen::Vector3d nrm = (s[1].w - s[0].w).cross(s[2].w - s[0].w);
    const double nn = nrm.squaredNorm();
    if (nn > 0.0) return nrm * (nrm.dot(s[0].w) / nn);
  }
  if (n == 2) {
    const Eigen::Vector3d ab = s[1].w - s[0].w;
    const double aa = ab.squaredNorm();
    if (aa > 0.0) return s[0].w - ab * (s[0].w.dot(ab) / aa);
  }
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) v += lambda[k] * s[k].w;
  return v;
}

// Reduces the simplex to the support of the closest point; false when the origin lies
// inside the tetrahedron (overlap).
bool closestOnSimplex(SVert* s, int& n, double* lambda) {
  if (n == 1) {
    lambda[0] = 1.0;
    return true;
  }
  if (n == 2) {
    closestSegment(s, n, lambda);
    return true;
  }
  if (n == 3) {
    SVert out[3];
    int m = 0;
    closestTriangle(s[0], s[1], s[2], out, m, lambda);
    for (int k = 0; k < m; ++k) s[k] = out[k];
    n = m;
    return true;
  }
  // Tetrahedron: faces with the origin outside (or a degenerate, flat tetrahedron).
  static const int faces[4][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 3, 2, 0}};
  double best = kInf;
  SVert best_s[3];
  double best_l[3] = {0, 0, 0};
  int best_m = 0;
  bool any_outside = false;
  for (const auto& f : faces) {
    const Eigen::Vector3d& q0 = s[f[0]].w;
    const Eigen::Vector3d nrm = (s[f[1]].w - q0).cross(s[f[2]].w - q0);
    const Eigen::Vector3d x = s[f[3]].w - q0;
    const double side_o = -q0.dot(nrm);
    const double side_x = x.dot(nrm);
    const bool degenerate = std::abs(side_x) <= 1e-12 * nrm.norm() * x.norm();
    if (!(degenerate || side_o * side_x < 0.0)) continue;
    any_outside = true;
    SVert out[3];
    int m = 0;
    double l[3];
    closestTriangle(s[f[0]], s[f[1]], s[f[2]], out, m, l);
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (int k = 0; k < m; ++k) v += l[k] * out[k].w;
    const double d = v.squaredNorm();
    if (d < best) {
      best = d;
      best_m = m;
      for (int k = 0; k < m; ++k) { best_s[k] = out[k]; best_l[k] = l[k]; }
    }
  }
  if (!any_outside) return false;
  n = best_m;
  for (int k = 0; k < n; ++k) { s[k] = best_s[k]; lambda[k] = best_l[k]; }
  return true;
}

// The lambda-weighted witness points on A and B of the closest point of the simplex.
inline void witnessPoints(const SVert* s, int n, const double* lambda, Eigen::Vector3d& pa, Eigen::Vector3d& pb) {
  pa = Eigen::Vector3d::Zero();
  pb = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    pa += lambda[k] * s[k].a;
    pb += lambda[k] * s[k].b;
  }
}

// True when w repeats a vertex of the simplex (within tiny): the iteration cannot progress.
inline bool repeatsVertex(const SVert* s, int n, const SVert& w, double tiny) {
  for (int k = 0; k < n; ++k) {
    if ((s[k].w - w.w).squaredNorm() <= tiny * tiny) return true;
  }
  return false;
}

// The result's final simplex.
inline void keepSimplex(Gjk& r, const SVert* s, int n) {
  for (int k = 0; k < n; ++k) r.simplex[k] = s[k];
  r.simplex_n = n;
}

// The first search direction: the caller's guess, else the centre line, else +x.
template <class CA, class CB>
Eigen::Vector3d startDirection(const CA& A, const CB& B, Eigen::Vector3d guess) {
  if (!(guess.squaredNorm() > 0.0) || !guess.allFinite()) guess = A.origin() - B.origin();
  if (!(guess.squaredNorm() > 0.0)) guess = Eigen::Vector3d::UnitX();
  return guess;
}

// The start simplex s[0..n) with the weights of its closest point: the seed reduced to its
// closest point (at most a triangle: never "inside"), else the support along -guess.
template <class CA, class CB>
void startSimplex(const CA& A, const CB& B, const Eigen::Vector3d& guess, const SVert* seed, int seed_n, SVert* s,
                  int& n, double* lambda) {
  if (seed_n > 0) {
    n = seed_n;
    for (int k = 0; k < n; ++k) s[k] = seed[k];
    closestOnSimplex(s, n, lambda);
  } else {
    s[0] = makeVert(A, B, -guess);
  }
}

}  // namespace

template <class CA, class CB>
Gjk runGjk(const CA& A, const CB& B, Eigen::Vector3d guess, double abs_tol, double rel_tol, int max_iter,
           double stop_above, const SVert* seed, int seed_n) {
  Gjk r;
  guess = startDirection(A, B, guess);
  // Scale for "numerically zero": the size of the coordinates involved.
  const double scale = 1.0 + A.p.norm() + B.p.norm() + A.lever + B.lever;
  const double tiny = 1e-14 * scale;
  const double rounding = A.rounding + B.rounding;

  SVert s[4];
  int n = 1;
  double lambda[4] = {1.0, 0.0, 0.0, 0.0};
  startSimplex(A, B, guess, seed, seed_n, s, n, lambda);
  Eigen::Vector3d v = closestPoint(s, n, lambda);
  Eigen::Vector3d pa, pb;
  witnessPoints(s, n, lambda, pa, pb);
  int it = 0;
  for (; it < max_iter; ++it) {
    const double vv = v.squaredNorm();
    if (vv <= tiny * tiny) {
      r.overlap = true;  // the origin on the simplex (within rounding): distance 0 or less
      break;
    }
    const SVert w = makeVert(A, B, -v);
    const double vn = std::sqrt(vv);
    const double lower = v.dot(w.w) / vn;  // distance >= lower (separating plane)
    if (lower > r.best_lower) {
      r.best_lower = lower;
      r.best_dir = v / vn;
    }
    // Relative to the gap of the padded shapes (the core distance less the roundings), the
    // quantity callers ask about: relative to the core distance, a large rounding would let
    // the estimate of a near-contact gap stay off by far more than that gap.
    if (vn - lower <= std::max(abs_tol, rel_tol * (vn - rounding)) || lower > stop_above) break;
    if (repeatsVertex(s, n, w, tiny)) break;
    SVert saved[4];
    const int saved_n = n;
    for (int k = 0; k < n; ++k) saved[k] = s[k];
    s[n++] = w;
    if (!closestOnSimplex(s, n, lambda)) {
      r.overlap = true;  // the origin inside the tetrahedron
      break;
    }
    const Eigen::Vector3d nv = closestPoint(s, n, lambda);
    if (nv.squaredNorm() >= vv) {  // no progress (rounding): keep the previous answer
      n = saved_n;
      for (int k = 0; k < n; ++k) s[k] = saved[k];
      break;
    }
    v = nv;
    witnessPoints(s, n, lambda, pa, pb);
  }
  r.iterations = it + 1;
  r.v = v;
  r.a = pa;
  r.b = pb;
  r.dist = r.overlap ? 0.0 : v.norm();
  // With overlap the simplex holding the origin, for the penetration direction; else the
  // support of the closest point.
  keepSimplex(r, s, n);
  return r;
}

// The two kinds of convex sets the library runs GJK on: posed cores and swept volumes.
template Gjk runGjk<Convex, Convex>(const Convex&, const Convex&, Eigen::Vector3d, double, double, int, double,
                                    const SVert*, int);
template Gjk runGjk<Swept, Swept>(const Swept&, const Swept&, Eigen::Vector3d, double, double, int, double,
                                  const SVert*, int);

}  // namespace detail
}  // namespace vadop
