// Static distance (GJK on cores) and the certified conservative-advancement step.
// See distance.h for the model (cores + rounding, meshes as triangle soups).
#include "vadop/distance.h"
#include "advance_step.h"

#include "vadop/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

namespace vadop {
namespace detail {

enum class CoreKind { kPoint, kSegment, kBox, kCylinder, kPoints, kMesh };

struct Tri {
  Eigen::Vector3d v[3];  // body frame
  double lever = 0.0;    // max |x| over the padded triangle (body origin)
};

struct BvhNode {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // body frame
  double radius = 0.0;  // bounding sphere of the node's padded triangles
  double lever = 0.0;   // max |x| over the node's padded triangles (body origin)
  int left = -1;
  int right = -1;
  int tri = -1;  // leaf: triangle index
};

struct PreparedShapeData {
  Shape shape;
  CoreKind kind = CoreKind::kPoint;
  double rounding = 0.0;  // sphere / capsule radius + margin; margin for the other cores
  double lever = 0.0;     // bounding_radius: max |x| over the padded shape
  double half_length = 0.0;
  double cyl_radius = 0.0;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> points;  // convex
  std::vector<Tri> tris;                // mesh
  std::vector<BvhNode> nodes;
  int root = -1;
};

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// ---------------------------------------------------------------------------------------
// Support mappings

Eigen::Vector3d coreSupportBody(const PreparedShapeData& s, const Eigen::Vector3d& d) {
  switch (s.kind) {
    case CoreKind::kPoint: return Eigen::Vector3d::Zero();
    case CoreKind::kSegment: return Eigen::Vector3d(0.0, 0.0, d.z() >= 0.0 ? s.half_length : -s.half_length);
    case CoreKind::kBox:
      return Eigen::Vector3d(d.x() >= 0.0 ? s.half_extents.x() : -s.half_extents.x(),
                             d.y() >= 0.0 ? s.half_extents.y() : -s.half_extents.y(),
                             d.z() >= 0.0 ? s.half_extents.z() : -s.half_extents.z());
    case CoreKind::kCylinder: {
      Eigen::Vector3d p(0.0, 0.0, d.z() >= 0.0 ? s.half_length : -s.half_length);
      // sqrt, not hypot (several times slower, ~7% of a fleet's cycle): hypot only where the
      // squares would underflow (a search direction nearly along the axis).
      const double r2 = d.x() * d.x() + d.y() * d.y();
      const double r = r2 > 1e-280 ? std::sqrt(r2) : std::hypot(d.x(), d.y());
      if (r > 0.0) {
        p.x() = s.cyl_radius * (d.x() / r);
        p.y() = s.cyl_radius * (d.y() / r);
      }
      return p;
    }
    case CoreKind::kPoints: {
      const Eigen::Vector3d* best = &s.points[0];
      double bv = best->dot(d);
      for (size_t i = 1; i < s.points.size(); ++i) {
        const double v = s.points[i].dot(d);
        if (v > bv) {
          bv = v;
          best = &s.points[i];
        }
      }
      return *best;
    }
    case CoreKind::kMesh: break;  // meshes are queried triangle by triangle
  }
  return Eigen::Vector3d::Zero();
}

// A posed convex core with rounding: a whole primitive or one triangle of a mesh.
struct Convex {
  const PreparedShapeData* shape = nullptr;  // null: the triangle `tri` (world frame)
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // the rotation centre (Motion's pivot)
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // body origin - p
  std::array<Eigen::Vector3d, 3> tri;
  double rounding = 0.0;
  double lever = 0.0;  // max |x - p| over the padded convex

  Eigen::Vector3d origin() const { return p + shift; }
  // A point inside the core: the body origin, or a triangle's centroid (its p is the mesh's).
  Eigen::Vector3d centre() const { return shape ? origin() : Eigen::Vector3d((tri[0] + tri[1] + tri[2]) / 3.0); }

  // Farthest core point along d (world frame; d need not be unit).
  Eigen::Vector3d support(const Eigen::Vector3d& d) const {
    if (shape == nullptr) {
      const double a = tri[0].dot(d), b = tri[1].dot(d), c = tri[2].dot(d);
      if (a >= b && a >= c) return tri[0];
      return b >= c ? tri[1] : tri[2];
    }
    return R * coreSupportBody(*shape, R.transpose() * d) + p + shift;
  }
  // Support value of the padded convex about p: max over x of (x - p).u (u need not be unit).
  // For a primitive, in its body frame: (R c + shift).u = c.(R^T u) + shift.u, one rotation
  // fewer than through support(); the certified steps evaluate it dozens of times per step.
  double h(const Eigen::Vector3d& u) const {
    if (shape == nullptr) return (support(u) - p).dot(u) + rounding * u.norm();
    const Eigen::Vector3d ub = R.transpose() * u;
    return coreSupportBody(*shape, ub).dot(ub) + shift.dot(u) + rounding * u.norm();
  }
};

// p: the rotation centre; shift: the body origin relative to it (Motion::pivot_offset turned).
Convex makeConvex(const PreparedShapeData& s, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
                  const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  Convex c;
  c.shape = &s;
  c.R = R;
  c.p = p;
  c.shift = shift;
  c.rounding = s.rounding;
  c.lever = s.lever + shift.norm();
  return c;
}

Convex makeTriangle(const PreparedShapeData& mesh, int tri, const Eigen::Matrix3d& R,
                    const Eigen::Vector3d& p, const Eigen::Vector3d& shift) {
  Convex c;
  const Tri& t = mesh.tris[tri];
  for (int k = 0; k < 3; ++k) c.tri[k] = R * t.v[k] + p + shift;
  c.p = p;
  c.shift = shift;
  c.rounding = mesh.rounding;
  c.lever = t.lever + shift.norm();
  return c;
}

// ---------------------------------------------------------------------------------------
// GJK (Gilbert-Johnson-Keerthi). The simplex is reduced to the face/edge/vertex holding
// the closest point; that point is computed as a plane projection or a perpendicular (not
// from barycentric weights), so its direction stays accurate when it is tiny compared with
// the simplex, i.e. near contact, where the certified lower bound depends on it. The best
// lower bound seen (support of A - B along -v) is kept with its direction.

struct SVert {
  Eigen::Vector3d w, a, b;  // w = a - b
};

struct Gjk {
  bool overlap = false;    // the cores intersect (origin in the Minkowski difference)
  double dist = 0.0;       // |v|: an upper bound of the core distance
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // a - b
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();
  int iterations = 0;
  // The direction (along a - b) that certified the largest lower bound of the core distance.
  double best_lower = -std::numeric_limits<double>::infinity();
  Eigen::Vector3d best_dir = Eigen::Vector3d::Zero();
  // The final simplex: with overlap, holding the origin (a tetrahedron, or a triangle, a
  // segment or a point passing through it); else the support of the closest point.
  SVert simplex[4];
  int simplex_n = 0;
};

template <class CA, class CB>
SVert makeVert(const CA& A, const CB& B, const Eigen::Vector3d& d) {
  // Support of A - B along d.
  SVert s;
  s.a = A.support(d);
  s.b = B.support(-d);
  s.w = s.a - s.b;
  return s;
}

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

// CA, CB: Convex or Swept (support(d), origin(), p, lever). Stops early once the certified
// lower bound of the core distance exceeds stop_above.
// `seed` (seed_n <= 3 points of A - B, e.g. the last simplex of the pair re-posed): the start
// instead of the support along -guess.
template <class CA, class CB>
Gjk runGjk(const CA& A, const CB& B, Eigen::Vector3d guess, double abs_tol, double rel_tol, int max_iter,
           double stop_above = kInf, const SVert* seed = nullptr, int seed_n = 0) {
  Gjk r;
  if (!(guess.squaredNorm() > 0.0) || !guess.allFinite()) guess = A.origin() - B.origin();
  if (!(guess.squaredNorm() > 0.0)) guess = Eigen::Vector3d::UnitX();
  // Scale for "numerically zero": the size of the coordinates involved.
  const double scale = 1.0 + A.p.norm() + B.p.norm() + A.lever + B.lever;
  const double tiny = 1e-14 * scale;
  const double rounding = A.rounding + B.rounding;

  SVert s[4];
  int n = 1;
  double lambda[4] = {1.0, 0.0, 0.0, 0.0};
  if (seed_n > 0) {
    n = seed_n;
    for (int k = 0; k < n; ++k) s[k] = seed[k];
    closestOnSimplex(s, n, lambda);  // at most a triangle: never "inside"
  } else {
    s[0] = makeVert(A, B, -guess);
  }
  Eigen::Vector3d v = closestPoint(s, n, lambda);
  Eigen::Vector3d pa = Eigen::Vector3d::Zero(), pb = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    pa += lambda[k] * s[k].a;
    pb += lambda[k] * s[k].b;
  }
  // Overlap: the simplex holding the origin, for the penetration direction.
  auto overlapping = [&]() {
    r.overlap = true;
    for (int k = 0; k < n; ++k) r.simplex[k] = s[k];
    r.simplex_n = n;
  };
  int it = 0;
  for (; it < max_iter; ++it) {
    const double vv = v.squaredNorm();
    if (vv <= tiny * tiny) {
      overlapping();  // the origin on the simplex (within rounding): distance 0 or less
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
    bool duplicate = false;
    for (int k = 0; k < n; ++k) {
      if ((s[k].w - w.w).squaredNorm() <= tiny * tiny) duplicate = true;
    }
    if (duplicate) break;
    SVert saved[4];
    const int saved_n = n;
    for (int k = 0; k < n; ++k) saved[k] = s[k];
    s[n++] = w;
    if (!closestOnSimplex(s, n, lambda)) {
      overlapping();  // the origin inside the tetrahedron
      break;
    }
    const Eigen::Vector3d nv = closestPoint(s, n, lambda);
    Eigen::Vector3d na = Eigen::Vector3d::Zero(), nb = Eigen::Vector3d::Zero();
    for (int k = 0; k < n; ++k) {
      na += lambda[k] * s[k].a;
      nb += lambda[k] * s[k].b;
    }
    if (nv.squaredNorm() >= vv) {  // no progress (rounding): keep the previous answer
      n = saved_n;
      for (int k = 0; k < n; ++k) s[k] = saved[k];
      break;
    }
    v = nv;
    pa = na;
    pb = nb;
  }
  r.iterations = it + 1;
  r.v = v;
  r.a = pa;
  r.b = pb;
  r.dist = r.overlap ? 0.0 : v.norm();
  if (!r.overlap) {
    for (int k = 0; k < n; ++k) r.simplex[k] = s[k];
    r.simplex_n = n;
  }
  return r;
}

// Separation of the padded convexes along unit n (from a to b): certified lower bound of
// their signed distance.
template <class CA, class CB>
double separation(const CA& A, const CB& B, const Eigen::Vector3d& n) {
  return n.dot(B.p - A.p) - A.h(n) - B.h(-n);
}

Eigen::Vector3d anyPerpendicular(const Eigen::Vector3d& n) {
  const Eigen::Vector3d t = std::abs(n.x()) < 0.6 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return n.cross(t).normalized();
}

// Unit directions, each tried with both signs.
struct Axes {
  static constexpr int kMax = 32;
  Eigen::Vector3d v[kMax];
  int n = 0;
  void add(const Eigen::Vector3d& d) {
    const double dd = d.squaredNorm();
    if (dd > 0.0 && n < kMax) v[n++] = d / std::sqrt(dd);
  }
};

// The facet normals and edge directions of a polytope core (point, segment, box, triangle),
// world frame; false for a cylinder or a point cloud, whose facets are not at hand.
bool polytopeFeatures(const Convex& c, Axes& faces, Axes& edges) {
  if (c.shape == nullptr) {
    faces.add((c.tri[1] - c.tri[0]).cross(c.tri[2] - c.tri[0]));
    for (int k = 0; k < 3; ++k) edges.add(c.tri[(k + 1) % 3] - c.tri[k]);
    return true;
  }
  switch (c.shape->kind) {
    case CoreKind::kPoint: return true;
    case CoreKind::kSegment:
      edges.add(c.R.col(2));
      // Another point or a parallel segment: their difference is a segment through the
      // origin, whose least separation is 0 along any perpendicular.
      faces.add(anyPerpendicular(c.R.col(2)));
      return true;
    case CoreKind::kBox:
      for (int k = 0; k < 3; ++k) {
        faces.add(c.R.col(k));
        edges.add(c.R.col(k));
      }
      return true;
    default: return false;
  }
}

// Expanding polytope (EPA) on the cores' difference K = A - B, which holds the origin: the
// polytope, inside K, starts as the GJK's final tetrahedron; its face nearest the origin is
// pushed out to K's support along the face's normal n until that support gains at most
// `tol` over the face. The least penetration depth then lies between the face's distance
// and h_K(n), so n is within `tol` of the best separating direction, wherever on K it lies
// (a hill climb only finds the nearest local maximum). False when the polytope degenerates
// (a flat face, the origin outside the start) or the budget runs out; `best` then holds the
// best direction met (when any).
bool expandingPolytope(const Convex& A, const Convex& B, const SVert* tet, double tol, Eigen::Vector3d* best) {
  struct Face {
    Eigen::Vector3d n;  // unit, outward
    double d;           // n.x on the face: its distance from the origin
    int v[3];
  };
  // Each step adds a vertex; a closed triangulation of V vertices has 2V - 4 faces (addFace
  // refuses more, should rounding break the triangulation).
  constexpr int kMaxIterations = 48;
  constexpr int kMaxVertices = 4 + kMaxIterations;
  constexpr int kMaxFaces = 2 * kMaxVertices;
  Eigen::Vector3d w[kMaxVertices];
  int nw = 0;
  for (int k = 0; k < 4; ++k) w[nw++] = tet[k].w;
  Face faces[kMaxFaces];
  int nf = 0;
  auto addFace = [&](int a, int b, int c) {
    const Eigen::Vector3d ab = w[b] - w[a], ac = w[c] - w[a];
    Eigen::Vector3d n = ab.cross(ac);
    const double len = n.norm();
    if (!(len > 1e-12 * ab.norm() * ac.norm()) || !(len > 0.0) || nf == kMaxFaces) return false;
    n /= len;
    faces[nf++] = Face{n, n.dot(w[a]), {a, b, c}};
    return true;
  };
  // The tetrahedron's faces, wound outward.
  const double orient = (w[1] - w[0]).cross(w[2] - w[0]).dot(w[3] - w[0]);
  if (!(std::abs(orient) > 0.0)) return false;
  const int kTet[4][3] = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  for (const auto& t : kTet) {
    if (!(orient < 0.0 ? addFace(t[0], t[1], t[2]) : addFace(t[0], t[2], t[1]))) return false;
  }
  double best_h = kInf;
  const double flat = 1e-12 * (1.0 + A.lever + B.lever + (B.p - A.p).norm());
  std::pair<int, int> horizon[3 * kMaxFaces];  // each removed face gives at most 3 edges
  for (int it = 0; it < kMaxIterations; ++it) {
    int near = 0;
    for (int f = 1; f < nf; ++f) {
      if (faces[f].d < faces[near].d) near = f;
    }
    const Eigen::Vector3d n = faces[near].n;
    const double d = faces[near].d;
    if (d < -tol) return false;  // the origin outside: not a valid start
    const Eigen::Vector3d x = makeVert(A, B, n).w;
    const double h = n.dot(x);
    if (h < best_h) {
      best_h = h;
      *best = n;
    }
    if (h - d <= tol) return true;
    // Faces that see x go; the edges they leave open (the horizon) are joined to x. A face
    // whose plane x lies in (support points on a cylinder's cap, a segment) stays: seen by a
    // rounding error, it would cut the horizon into pieces.
    int nh = 0;
    for (int g = 0; g < nf;) {
      if (faces[g].n.dot(x) - faces[g].d > flat) {
        for (int e = 0; e < 3; ++e) {
          const int a = faces[g].v[e], b = faces[g].v[(e + 1) % 3];
          int twin = 0;
          while (twin < nh && !(horizon[twin].first == b && horizon[twin].second == a)) ++twin;
          if (twin < nh) {
            horizon[twin] = horizon[--nh];
          } else {
            horizon[nh++] = {a, b};
          }
        }
        faces[g] = faces[--nf];
      } else {
        ++g;
      }
    }
    w[nw] = x;
    const int xi = nw++;
    for (int k = 0; k < nh; ++k) {
      if (!addFace(horizon[k].first, horizon[k].second, xi)) return false;
    }
    if (nf == 0) return false;
  }
  return false;
}

// A tetrahedron of support points of A - B holding the origin (inside or on a face), from
// the GJK's final simplex: a triangle through the origin (the supports of a cylinder along
// directions in a plane holding its axis all lie in that plane) gets the support along its
// normal, a segment first the support along a perpendicular. False if none is found.
bool enclosingTetrahedron(const Convex& A, const Convex& B, const Gjk& g, SVert* tet) {
  int n = g.simplex_n;
  for (int k = 0; k < n; ++k) tet[k] = g.simplex[k];
  if (n == 2) {
    const Eigen::Vector3d e = tet[1].w - tet[0].w;
    if (!(e.squaredNorm() > 0.0)) return false;
    tet[n++] = makeVert(A, B, anyPerpendicular(e));
  }
  if (n == 3) {
    const Eigen::Vector3d nrm = (tet[1].w - tet[0].w).cross(tet[2].w - tet[0].w);
    if (!(nrm.squaredNorm() > 0.0)) return false;
    tet[3] = makeVert(A, B, nrm);
    // The origin lies in the triangle's plane, and K beyond it on one side at least.
    if (!(nrm.dot(tet[3].w - tet[0].w) > 0.0)) tet[3] = makeVert(A, B, -nrm);
    n = 4;
  }
  return n == 4;
}

// Overlapping cores: the direction of least penetration, maximising the separation over
// unit directions. When both cores are polytopes the maximum is exact: the separation of
// the padded shapes is the core separation minus the roundings, so it is largest along a
// facet normal of the cores' Minkowski difference (the origin lies inside it), and every
// such normal is a facet normal of one core or the cross product of an edge of each
// (separating axes). A cylinder or a point cloud: the expanding polytope, to 1e-6 of the
// sum of the shapes' bounding radii; where it cannot run (no tetrahedron of supports around
// the origin: the cores touch within rounding) or does not converge, hill climbing from the
// centre lines, the bodies' axes and the polytope's best direction.
Eigen::Vector3d penetrationDirection(const Convex& A, const Convex& B, const Gjk& g) {
  Axes faces, edges_a, edges_b;
  const bool polytope_a = polytopeFeatures(A, faces, edges_a);
  const bool polytope_b = polytopeFeatures(B, faces, edges_b);
  const bool polytopes = polytope_a && polytope_b;
  Eigen::Vector3d expanded = Eigen::Vector3d::Zero();
  SVert tet[4];
  if (!polytopes && enclosingTetrahedron(A, B, g, tet) &&
      expandingPolytope(A, B, tet, 1e-6 * (A.lever + B.lever), &expanded)) {
    return expanded;
  }
  Axes cand = faces;
  for (int i = 0; i < edges_a.n; ++i) {
    for (int j = 0; j < edges_b.n; ++j) cand.add(edges_a.v[i].cross(edges_b.v[j]));
  }
  if (!polytopes) {
    cand.add(expanded);
    cand.add(-g.v);
    cand.add(B.origin() - A.origin());
    cand.add(B.centre() - A.centre());
    for (const Convex* c : {&A, &B}) {
      if (c->shape) {
        for (int k = 0; k < 3; ++k) cand.add(c->R.col(k));
      }
    }
    for (int k = 0; k < 3; ++k) cand.add(Eigen::Vector3d::Unit(k));
  }
  // Two points at the same place: every direction separates them equally.
  Eigen::Vector3d best = cand.n > 0 ? cand.v[0] : Eigen::Vector3d::UnitX();
  double bs = separation(A, B, best);
  for (int i = 0; i < cand.n; ++i) {
    for (const Eigen::Vector3d& c : {cand.v[i], Eigen::Vector3d(-cand.v[i])}) {
      const double s = separation(A, B, c);
      if (s > bs) {
        bs = s;
        best = c;
      }
    }
  }
  if (polytopes) return best;
  // Eight compass directions: a ridge at an angle to the frame is followed, not stalled on.
  constexpr double kDiag = 0.70710678118654752;
  double step = 0.25;
  for (int it = 0; it < 400 && step > 1e-7; ++it) {
    const Eigen::Vector3d e1 = anyPerpendicular(best);
    const Eigen::Vector3d e2 = best.cross(e1);
    const Eigen::Vector3d d1 = kDiag * (e1 + e2), d2 = kDiag * (e1 - e2);
    bool improved = false;
    for (const Eigen::Vector3d& e : {e1, Eigen::Vector3d(-e1), e2, Eigen::Vector3d(-e2), d1, Eigen::Vector3d(-d1), d2,
                                     Eigen::Vector3d(-d2)}) {
      const Eigen::Vector3d c = (best + step * e).normalized();
      const double s = separation(A, B, c);
      if (s > bs) {
        bs = s;
        best = c;
        improved = true;
        break;
      }
    }
    if (!improved) step *= 0.5;
  }
  return best;
}

// Distance between two posed convexes. `cert` receives the unit direction (a to b) along
// which lower_bound was certified; it can differ from the witness normal by the GJK's
// angular accuracy (near contact the witness direction is the better contact normal, the
// certified one the better separating plane).
// `warm` (primitives only, may be null): started from its simplex, re-posed, when it has one;
// the final simplex stored back in the cores' body frames (none after an overlap).
DistanceResult convexDistance(const Convex& A, const Convex& B, const Eigen::Vector3d& guess,
                              double abs_tol, double rel_tol, int max_iter, Eigen::Vector3d* cert,
                              WarmStart* warm = nullptr) {
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
  const Gjk g = runGjk(A, B, guess, abs_tol, rel_tol, max_iter, kInf, seed, seed_n);
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
  const Eigen::Vector3d n = penetrationDirection(A, B, g);
  if (cert) *cert = n;
  r.normal = n;
  r.lower_bound = separation(A, B, n);
  r.distance = r.lower_bound;
  r.point_a = A.support(n) + A.rounding * n;
  r.point_b = B.support(-n) - B.rounding * n;
  return r;
}

// ---------------------------------------------------------------------------------------
// Certified step along a separating direction.

struct Kin {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // linear velocity of the body origin
  Eigen::Vector3d w = Eigen::Vector3d::Zero();  // angular velocity (fixed frame)
};

// Refines a bracket [lo, hi] of the first root of a concave f on [0, horizon] with f(0) > 0,
// f(lo) = flo > 0 and f(hi) = fhi <= 0, and returns the largest certified step found (f > 0
// on [0, step)): any point where f was evaluated > 0 is safe (f > 0 between 0 and it). For
// concave f the chord root never passes the root (f lies above its chords), so plain regula
// falsi only ever moves lo, slowly when f bends sharply (a root far below the horizon); the
// Illinois rule halves the weight of an end kept twice in a row, which brings hi down too.
template <class F>
double refineConcaveRoot(const F& f, double lo, double flo, double hi, double fhi) {
  double wlo = flo, whi = fhi;  // the ends' weights in the secant
  int kept = 0;                 // +1: lo moved last, -1: hi moved last
  for (int k = 0; k < 16; ++k) {
    const double x = lo + (hi - lo) * (wlo / (wlo - whi));
    if (!(x > lo && x < hi)) break;
    const double fx = f(x);
    if (fx > 0.0) {
      lo = x;
      wlo = fx;
      if (kept > 0) whi *= 0.5;
      kept = 1;
    } else {
      hi = x;
      whi = fx;
      if (kept < 0) wlo *= 0.5;
      kept = -1;
    }
    if (hi - lo <= 0.02 * lo) break;
  }
  return lo;
}

// Largest step in [0, horizon] such that the gap of A and B stays > adv, certified by the
// separation along a direction n (unit, a to b) found at the current time; `clear` when
// that holds over the whole horizon. Three certificates, the best step wins (each is a
// lower bound of the gap for all later times, so any of them is safe):
//
// (1) n fixed in the world frame:
//     s(t+D) >= n.(P + D V) - hA(n - D wa x n) - hB(-n + D wb x n)
//                - D^2/2 (ra |wa| |wa x n| + rb |wb| |wb x n|)
//     with P = pb - pa, V = vb - va, hX the support of the padded shape about its origin at
//     time t. Rotating n by -w D differs from its first-order term by at most
//     |w| |w x n| D^2 / 2 and support functions are Lipschitz in the direction with the
//     lever arm r. Exact for translation. Also s(t+D) >= s(t) - D (-n.V + ra|wa x n| + rb|wb x n|).
// (2) n attached to b (it turns with b, like a face normal of b, so b's support along it is
//     constant): with E = exp([w] D), u = Ea^T Eb n (|u - n - D (wb - wa) x n| <=
//     (|wa| + |wb|)^2 D^2 / 2) and Eb n = n + D wb x n + e (|e| <= |wb| |wb x n| D^2 / 2):
//     s(t+D) >= n.P + D ((wb x n).P + n.V) + D^2 min(0, (wb x n).V)
//                - |wb| |wb x n| D^2 (|P| + D |V|) / 2 - hB(-n)
//                - hA(n + D (wb - wa) x n) - ra (|wa| + |wb|)^2 D^2 / 2.
//     This follows a rotating face closely: its first-order term is the true rate.
// (3) n attached to a: the same with the roles of a and b exchanged.
// All three are concave in D.
// `deviation`: for bodies whose motion only stays near the constant twist (v, w) of their
// Kin -- every point within deviation_x D^2 / 2 of where the twist takes it, deviation the sum
// over both bodies -- each bound less deviation D^2 / 2 bounds the true gap (a support
// function moves by at most the largest displacement of a point), still concave.
// `cap`: the caller only needs to know the step up to cap (a mesh's best step so far);
// the refinements stop as soon as a certificate reaches it.
double separationStep(const Convex& A, const Kin& ka, const Convex& B, const Kin& kb,
                      const Eigen::Vector3d& n, double horizon, double adv, double cap, bool* clear,
                      double deviation = 0.0) {
  *clear = false;
  const Eigen::Vector3d ua = ka.w.cross(n), ub = kb.w.cross(n);
  const double kA = ua.norm(), kB = ub.norm();
  const Eigen::Vector3d P = B.p - A.p;
  const Eigen::Vector3d V = kb.v - ka.v;
  const double base = n.dot(P);
  const double hA0 = A.h(n), hB0 = B.h(-n);
  const double f0 = base - hA0 - hB0 - adv;
  if (!(f0 > 0.0)) return 0.0;
  const double closing = -n.dot(V);
  const double mu = closing + A.lever * kA + B.lever * kB;
  // f0 - mu D - deviation D^2 / 2 = 0, cancellation-free (f0 / mu without deviation).
  const double dev = 0.5 * deviation;
  const double step_lin = dev > 0.0 ? 2.0 * f0 / (mu + std::sqrt(mu * mu + 4.0 * dev * f0)) : mu > 0.0 ? f0 / mu : kInf;
  if (step_lin >= horizon) {
    *clear = true;
    return horizon;
  }
  if (kA == 0.0 && kB == 0.0) return step_lin;  // translation: the exact linear law
  if (step_lin >= cap) return step_lin;
  const double wa = ka.w.norm(), wb = kb.w.norm();
  const Eigen::Vector3d rel = (kb.w - ka.w).cross(n);
  const double wsum2 = (wa + wb) * (wa + wb);
  const double Pn = P.norm(), Vn = V.norm();
  const double nV = n.dot(V);
  // (1) fixed axis; (2) attached to b; (3) attached to a (the axis -n turns with a).
  const double q = 0.5 * (A.lever * wa * kA + B.lever * wb * kB);
  const double r1b = ub.dot(P) + nV, r1a = ua.dot(P) + nV;
  const double c2b = std::max(0.0, -ub.dot(V)) + 0.5 * wb * kB * Pn + 0.5 * A.lever * wsum2;
  const double c2a = std::max(0.0, -ua.dot(V)) + 0.5 * wa * kA * Pn + 0.5 * B.lever * wsum2;
  const double c3b = 0.5 * wb * kB * Vn, c3a = 0.5 * wa * kA * Vn;
  auto bound = [&](int which, double D) {
    switch (which) {
      case 0: return base + D * nV - A.h(n - D * ua) - B.h(-n + D * ub) - (q + dev) * D * D - adv;
      case 1: return base + D * r1b - (c2b + dev + c3b * D) * D * D - hB0 - A.h(n + D * rel) - adv;
      default: return base + D * r1a - (c2a + dev + c3a * D) * D * D - hA0 - B.h(-n + D * rel) - adv;
    }
  };
  // Each bound at the horizon: one still positive there certifies it all. Otherwise the bound
  // whose chord from (0, f0) to (horizon, f(horizon)) crosses zero last is refined first (the
  // chord root is where its refinement starts); another is refined only if it is still positive
  // where the best step so far ends (then its root lies beyond; one evaluation rules it out
  // otherwise), instead of refining all three in full.
  struct Candidate {
    int which;
    double at_horizon;
    double chord_root;
  };
  std::array<Candidate, 3> cand;
  int m = 0;
  for (int which = 0; which < 3; ++which) {
    if ((which == 1 && kB == 0.0) || (which == 2 && kA == 0.0)) continue;
    const double fT = bound(which, horizon);
    if (fT > 0.0) {
      *clear = true;
      return horizon;
    }
    cand[m++] = {which, fT, horizon * (f0 / (f0 - fT))};
  }
  for (int i = 1; i < m; ++i) {  // by chord root, largest first (insertion sort of <= 3)
    for (int j = i; j > 0 && cand[j].chord_root > cand[j - 1].chord_root; --j) std::swap(cand[j], cand[j - 1]);
  }
  double best = step_lin;
  for (int k = 0; k < m; ++k) {
    auto f = [&](double D) { return bound(cand[k].which, D); };
    double lo = 0.0, flo = f0;
    if (k > 0) {
      // Positive at the best step: positive up to it (concave), its root lies beyond.
      flo = f(best);
      if (!(flo > 0.0)) continue;
      lo = best;
    }
    best = std::max(best, refineConcaveRoot(f, lo, flo, horizon, cand[k].at_horizon));
    if (best >= cap) return std::min(best, horizon);
  }
  return std::min(best, horizon);
}

// ---------------------------------------------------------------------------------------
// Bounding-volume traversal (meshes), a convex primitive acting as a single leaf.

struct Side {
  const PreparedShapeData* d = nullptr;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      // the rotation centre (Motion's pivot)
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // body origin - p
  Kin kin;  // of p
  bool mesh = false;

  int root() const { return mesh ? d->root : 0; }
  bool leaf(int i) const { return !mesh || d->nodes[i].tri >= 0; }
  Eigen::Vector3d centre(int i) const {
    return mesh ? Eigen::Vector3d(R * d->nodes[i].centre + p + shift) : Eigen::Vector3d(p + shift);
  }
  double radius(int i) const { return mesh ? d->nodes[i].radius : d->lever; }
  Convex convex(int i) const {
    return mesh ? makeTriangle(*d, d->nodes[i].tri, R, p, shift) : makeConvex(*d, R, p, shift);
  }
};

struct Tolerances {
  double abs_tol;
  double rel_tol;
  int max_iter;
};

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

// The reported contact: near touching, the witness direction of a GJK run stopped at a
// gap accuracy delta can be off by about sqrt(2 delta / gap) radians (the closest point
// slides along a flat or ruled patch of the Minkowski difference at second order), so the
// contact that ends the advancement is recomputed to rounding accuracy.
DistanceResult refineContact(const Convex& A, const Convex& B, const DistanceResult& coarse,
                             const WarmStart* coarse_simplex = nullptr) {
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

// Best-first traversal of the pairs of bounding balls, ordered by the step each pair could
// at most limit: the search stops as soon as no remaining pair can shorten the best step.
AdvanceStep meshStep(const Side& A, const Side& B, double horizon, double touch, double adv,
                     const Tolerances& tol) {
  AdvanceStep out;
  out.closest.distance = kInf;
  out.closest.lower_bound = kInf;
  double best_step = horizon;
  int iterations = 0;
  int closest_a = -1, closest_b = -1;
  struct Item {
    double key;  // the pair cannot limit the step below key (-inf: may touch now)
    double D;    // lower bound of the pair's gap now
    int ia, ib;
    bool operator<(const Item& o) const { return key > o.key; }  // min-heap
  };
  auto bound = [&](int ia, int ib) {
    const Eigen::Vector3d ca_w = A.centre(ia), cb_w = B.centre(ib);
    const Eigen::Vector3d dc = cb_w - ca_w;
    const double dcn = dc.norm();
    Item it{-kInf, dcn - A.radius(ia) - B.radius(ib), ia, ib};
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
  };
  std::vector<Item> heap;
  heap.push_back(bound(A.root(), B.root()));
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const Item it = heap.back();
    heap.pop_back();
    if (out.touching) {
      if (it.D >= out.closest.distance) continue;  // looking for the closest contact only
    } else if (it.key >= best_step) {
      break;  // no remaining pair can shorten the step (the heap is ordered by key)
    }
    const int ia = it.ia, ib = it.ib;
    if (A.leaf(ia) && B.leaf(ib)) {
      const Convex ca = A.convex(ia), cb = B.convex(ib);
      const Eigen::Vector3d ga = ca.centre(), gb = cb.centre();
      if (!out.touching && (gb - ga).squaredNorm() > 0.0) {
        // Cheap screen before GJK: the exact separation of the two pieces along their
        // centroid line with the linear motion bound (a valid certificate, only weaker).
        const Eigen::Vector3d u = (gb - ga).normalized();
        const double su = u.dot(cb.p - ca.p) - ca.h(u) - cb.h(-u);
        if (su > touch) {
          const double mu = u.dot(A.kin.v - B.kin.v) + ca.lever * A.kin.w.cross(u).norm() +
                            cb.lever * B.kin.w.cross(u).norm();
          if (mu <= 0.0 || su - adv >= best_step * mu) continue;
        }
      }
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
        continue;
      }
      if (out.touching) continue;
      bool clear = false;
      const double st = separationStep(ca, A.kin, cb, B.kin, cert, horizon, adv, best_step, &clear);
      best_step = std::min(best_step, st);
      continue;
    }
    const bool split_a = !A.leaf(ia) && (B.leaf(ib) || A.radius(ia) >= B.radius(ib));
    if (split_a) {
      heap.push_back(bound(A.d->nodes[ia].left, ib));
      std::push_heap(heap.begin(), heap.end());
      heap.push_back(bound(A.d->nodes[ia].right, ib));
      std::push_heap(heap.begin(), heap.end());
    } else {
      heap.push_back(bound(ia, B.d->nodes[ib].left));
      std::push_heap(heap.begin(), heap.end());
      heap.push_back(bound(ia, B.d->nodes[ib].right));
      std::push_heap(heap.begin(), heap.end());
    }
  }
  out.closest.iterations = iterations;
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

// ---------------------------------------------------------------------------------------
// Preparation

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

Tolerances distanceTolerances(const DistanceOptions& o) { return {o.tolerance, o.relative_tolerance, o.max_iterations}; }

void checkPose(const Eigen::Isometry3d& pose, const char* what) {
  if (!pose.matrix().allFinite()) throw InvalidArgument(std::string(what) + " is not finite");
}

Side makeSide(const PreparedShapeData& d, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
              const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  Side s;
  s.d = &d;
  s.R = R;
  s.p = p;
  s.shift = shift;
  s.mesh = d.kind == CoreKind::kMesh;
  return s;
}

// The side of a body moving with m, at time t: posed, seen from its rotation centre (the pivot;
// the certified steps below bound every point's motion about it), with the pivot's velocity.
Side sideAt(const PreparedShapeData& d, const Motion& m, double t) {
  // One rotation E = exp([w] (t - t_ref)) gives both the orientation (E R(t_ref), as
  // orientationAt) and the origin's offset from the pivot (-E pivot_offset, as positionAt):
  // every advancement step poses both bodies, and each exp costs a sincos.
  const bool turning = m.isRotating();
  const Eigen::Matrix3d E = turning ? m.spin(t) : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d R = turning ? Eigen::Matrix3d(E * m.orientation.normalized().toRotationMatrix())
                                    : m.orientation.toRotationMatrix();
  Side s = m.hasPivot() ? makeSide(d, R, m.pivotAt(t), -(E * m.pivot_offset)) : makeSide(d, R, m.positionAt(t));
  s.kin.v = m.linear_velocity;
  s.kin.w = m.angular_velocity;
  return s;
}

// ---------------------------------------------------------------------------------------
// Swept volumes (sweptLowerBound in distance.h).
//
// A body turning with angular velocity w about a pivot c(t) = c(ta) + v (t - ta): relative to
// the pivot its points turn about the axis w_hat, which keeps each point's axial coordinate
// and its distance from the axis. So over any time interval the core stays in the cylinder
// about w_hat through the pivot whose radius is the core's largest distance from the axis and
// whose axial extent is the core's support along +-w_hat (the "revolution hull"); the padded
// shape in that cylinder rounded by the rounding radius; and the body over [ta, tb] in that
// set summed with the pivot's displacement segment [0, v (tb - ta)]. A body that does not turn:
// its posed core (a mesh: the hull of its vertices) summed with the segment, rounded. A body
// that turns by at most kSmallTurn over [ta, tb]: the same with its pose at ta, the rounding
// grown by turn * lever (a point at distance r from the pivot turned by an angle th moves by
// the chord 2 r sin(th / 2) <= th r), which is tighter than the revolution hull for slow turns.
constexpr double kSmallTurn = 0.5;  // rad
struct Swept {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();    // the pivot (or origin) at ta
  Eigen::Vector3d seg = Eigen::Vector3d::Zero();  // its displacement over [ta, tb]
  bool rotating = false;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // rotating: unit axis
  double rho = 0.0;                                 // rotating: cylinder radius (core)
  double ax_lo = 0.0, ax_hi = 0.0;                  // rotating: axial extent of the core about p
  const PreparedShapeData* d = nullptr;             // not rotating: the core, posed by R ...
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // ... with its origin at p + shift
  double rounding = 0.0;
  double lever = 0.0;  // bound of |x - p| over the set: the scale of the numbers involved

  Eigen::Vector3d origin() const { return p; }
  // A point of the turning or posed core relative to p (the start of the segment), farthest
  // along u up to rounding (u need not be unit): what the GJK needs. The certificate uses h(),
  // never the dot product of this point.
  Eigen::Vector3d core(const Eigen::Vector3d& u) const {
    if (rotating) {
      const double a = u.dot(axis);
      Eigen::Vector3d x = (a >= 0.0 ? ax_hi : ax_lo) * axis;
      // The radial direction, orthogonalised twice: for u (nearly) along the axis the first
      // difference is rounding noise, which must not tilt the point out of the cylinder.
      Eigen::Vector3d perp = u - a * axis;
      perp -= perp.dot(axis) * axis;
      const double pn = perp.norm();
      if (pn > 1e-12 * u.norm()) x += (rho / pn) * perp;
      return x;
    }
    if (d->kind == CoreKind::kMesh) {
      const Eigen::Vector3d ub = R.transpose() * u;
      const Eigen::Vector3d* best = &d->shape.points[0];
      double bv = best->dot(ub);
      for (const Eigen::Vector3d& q : d->shape.points) {
        const double v = q.dot(ub);
        if (v > bv) {
          bv = v;
          best = &q;
        }
      }
      return R * *best + shift;
    }
    return R * coreSupportBody(*d, R.transpose() * u) + shift;
  }
  Eigen::Vector3d rel(const Eigen::Vector3d& u) const {
    return (u.dot(seg) > 0.0 ? seg : Eigen::Vector3d::Zero()) + core(u);
  }
  Eigen::Vector3d support(const Eigen::Vector3d& u) const { return p + rel(u); }
  // Support value of the padded set about p: an upper bound (to rounding) of max (x - p).u.
  double h(const Eigen::Vector3d& u) const {
    const double un = u.norm();
    double v = std::max(0.0, u.dot(seg)) + rounding * un;
    if (rotating) {
      // Over the cylinder: the axial end times u.axis plus rho times |u's radial part| (its
      // computed norm is within a few ulps of |u| of the exact one: allowed for).
      const double a = u.dot(axis);
      v += (a >= 0.0 ? ax_hi : ax_lo) * a + rho * ((u - a * axis).norm() + 4.0 * kEps * un);
    } else {
      v += core(u).dot(u);  // the posed core's exact support point
    }
    return v;
  }
};

Swept sweptVolume(const PreparedShapeData& d, const Motion& m, double ta, double tb) {
  Swept s;
  s.rounding = d.rounding;
  s.seg = m.linear_velocity * (tb - ta);
  if (!m.isRotating()) {
    s.p = m.positionAt(ta);
    s.d = &d;
    s.R = m.orientation.toRotationMatrix();
    s.lever = d.lever + s.seg.norm();
    return s;
  }
  const Eigen::Matrix3d R = m.orientationAt(ta).toRotationMatrix();
  s.p = m.centreAt(ta);
  const Eigen::Vector3d shift = m.hasPivot() ? Eigen::Vector3d(m.positionAt(ta) - s.p) : Eigen::Vector3d::Zero();
  const double turn = m.angular_velocity.norm() * (tb - ta);
  if (turn <= kSmallTurn) {
    const double arm = d.lever + shift.norm();  // max |x - p| over the padded shape
    s.d = &d;
    s.R = R;
    s.shift = shift;
    s.rounding += turn * arm * (1.0 + 4.0 * kEps);
    s.lever = arm + turn * arm + s.seg.norm();
    return s;
  }
  s.rotating = true;
  s.axis = m.angular_velocity.normalized();
  // The core's points that bound it (a cylinder's end centres, with its radius added).
  double hi = -kInf, lo = kInf, rho = 0.0, extra = 0.0;
  auto visit = [&](const Eigen::Vector3d& body) {
    const Eigen::Vector3d y = R * body + shift;
    const double a = y.dot(s.axis);
    hi = std::max(hi, a);
    lo = std::min(lo, a);
    rho = std::max(rho, (y - a * s.axis).norm());
  };
  switch (d.kind) {
    case CoreKind::kPoint: visit(Eigen::Vector3d::Zero()); break;
    case CoreKind::kSegment:
    case CoreKind::kCylinder:
      visit(Eigen::Vector3d(0, 0, d.half_length));
      visit(Eigen::Vector3d(0, 0, -d.half_length));
      if (d.kind == CoreKind::kCylinder) {
        // The rim circles: radius bounded by the end centre's plus the cylinder's radius (a
        // vector of the disk moves a point by at most its length); the axial extent exactly.
        extra = d.cyl_radius;
        const Eigen::Vector3d ab = R.transpose() * s.axis;
        const double ax = R.col(2).dot(s.axis);
        const double rim = d.cyl_radius * std::sqrt(std::max(0.0, ab.squaredNorm() - ax * ax));
        hi += rim;
        lo -= rim;
      }
      break;
    case CoreKind::kBox:
      for (int k = 0; k < 8; ++k) {
        visit(Eigen::Vector3d((k & 1) ? d.half_extents.x() : -d.half_extents.x(),
                              (k & 2) ? d.half_extents.y() : -d.half_extents.y(),
                              (k & 4) ? d.half_extents.z() : -d.half_extents.z()));
      }
      break;
    case CoreKind::kPoints:
      for (const Eigen::Vector3d& q : d.points) visit(q);
      break;
    case CoreKind::kMesh:
      for (const Eigen::Vector3d& q : d.shape.points) visit(q);
      break;
  }
  s.rho = rho + extra;
  s.ax_hi = hi;
  s.ax_lo = lo;
  s.lever = s.rho + std::max(std::abs(hi), std::abs(lo)) + s.seg.norm() + s.rounding;
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------

namespace {

// GJK accuracy of the steps: a small fraction of the band between the advance target and the
// touch threshold, so that the loop always reaches "touching" after landing on the target;
// and, farther out, a small fraction of the gap (relative to the gap, not to the cores'
// distance): the step is certified by the exact separation along the direction found, so a
// direction a little off only shortens the step by about as much, while the last iterations
// of a curved shape cost as much as the first ones. At the touch threshold the relative part
// (4e-3 of the threshold) stays below the absolute one (1/200 of it).
Tolerances stepTolerances(double touch_gap, double advance_gap) { return {0.01 * (touch_gap - advance_gap), 4e-3, 128}; }

// advanceStep for two convex sides (kin set), with the deviation of separationStep.
AdvanceStep convexStep(const Side& A, const Side& B, double deviation, double horizon, double touch_gap,
                       double advance_gap, WarmStart* warm) {
  const Tolerances tol = stepTolerances(touch_gap, advance_gap);
  AdvanceStep out;
  const Convex ca = A.convex(0), cb = B.convex(0);
  const Eigen::Vector3d guess = (warm && warm->dir.squaredNorm() > 0.0) ? warm->dir : Eigen::Vector3d(ca.origin() - cb.origin());
  Eigen::Vector3d cert;
  out.closest = convexDistance(ca, cb, guess, tol.abs_tol, tol.rel_tol, tol.max_iter, &cert, warm);
  if (warm) warm->dir = -out.closest.normal;
  if (out.closest.cores_overlap || out.closest.distance <= touch_gap) {
    out.touching = true;
    out.closest = refineContact(ca, cb, out.closest, warm);
    return out;
  }
  out.step = separationStep(ca, A.kin, cb, B.kin, cert, horizon, advance_gap, horizon, &out.clear, deviation);
  return out;
}

}  // namespace

AdvanceStep advanceStep(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                        const Motion& mb, double t, double horizon, double touch_gap,
                        double advance_gap, WarmStart* warm) {
  const Side A = sideAt(a.data(), ma, t);
  const Side B = sideAt(b.data(), mb, t);
  if (A.mesh || B.mesh) return meshStep(A, B, horizon, touch_gap, advance_gap, stepTolerances(touch_gap, advance_gap));
  return convexStep(A, B, 0.0, horizon, touch_gap, advance_gap, warm);
}

AdvanceStep advanceStepNearTwist(const PreparedShape& a, const PosedTwist& ta, const PreparedShape& b,
                                 const PosedTwist& tb, double deviation, double horizon, double touch_gap,
                                 double advance_gap, WarmStart* warm) {
  Side A = makeSide(a.data(), ta.pose.linear(), ta.pose.translation());
  Side B = makeSide(b.data(), tb.pose.linear(), tb.pose.translation());
  if (A.mesh || B.mesh) throw InvalidArgument("advanceStepNearTwist: convex shapes only, not meshes");
  A.kin = {ta.velocity, ta.angular_velocity};
  B.kin = {tb.velocity, tb.angular_velocity};
  return convexStep(A, B, deviation, horizon, touch_gap, advance_gap, warm);
}

SweptBound sweptLowerBound(const PreparedShape& a, const Motion& ma, const PreparedShape& b, const Motion& mb,
                           double ta, double tb, double stop_above) {
  const Swept A = sweptVolume(a.data(), ma, ta, tb);
  const Swept B = sweptVolume(b.data(), mb, ta, tb);
  // Rounding allowance: the separation below is computed with exact support functions but in
  // floating point, from coordinates of size `scale` (a few ulps of it each).
  const double scale = A.p.norm() + B.p.norm() + A.lever + B.lever;
  const double slack = 1e-15 * scale;
  const double rounding = A.rounding + B.rounding;
  Eigen::Vector3d guess = A.p - B.p;
  const Gjk g = runGjk(A, B, guess, 1e-9, 1e-9, 64, stop_above + rounding + slack);
  SweptBound out;
  out.iterations = g.iterations;
  if (g.overlap) {
    out.lower_bound = -kInf;
    return out;
  }
  double lower = separation(A, B, Eigen::Vector3d(-g.v / g.dist));
  if (g.best_dir.squaredNorm() > 0.0) lower = std::max(lower, separation(A, B, Eigen::Vector3d(-g.best_dir)));
  out.lower_bound = lower - slack;
  return out;
}

}  // namespace detail

PreparedShape::PreparedShape(const Shape& shape) {
  validateShape(shape, "shape");
  auto d = std::make_shared<detail::PreparedShapeData>();
  d->shape = shape;
  d->lever = shape.bounding_radius;
  d->rounding = shape.margin;
  switch (shape.type) {
    case ShapeType::kSphere:
      d->kind = detail::CoreKind::kPoint;
      d->rounding += shape.radius;
      break;
    case ShapeType::kCapsule:
      d->kind = detail::CoreKind::kSegment;
      d->half_length = shape.half_length;
      d->rounding += shape.radius;
      break;
    case ShapeType::kBox:
      d->kind = detail::CoreKind::kBox;
      d->half_extents = shape.half_extents;
      break;
    case ShapeType::kCylinder:
      d->kind = detail::CoreKind::kCylinder;
      d->half_length = shape.half_length;
      d->cyl_radius = shape.radius;
      break;
    case ShapeType::kConvex:
      d->kind = detail::CoreKind::kPoints;
      d->points = shape.points;
      break;
    case ShapeType::kMesh: {
      // validateShape checks the vertices; the triangles are checked here, before use.
      if (shape.triangles.empty()) throw InvalidArgument("shape: mesh triangles must not be empty");
      const int nv = static_cast<int>(shape.points.size());
      for (size_t t = 0; t < shape.triangles.size(); ++t) {
        for (int c = 0; c < 3; ++c) {
          const int idx = shape.triangles[t][c];
          if (idx < 0 || idx >= nv) {
            throw InvalidArgument("shape: mesh triangles[" + std::to_string(t) + "][" + std::to_string(c) +
                                  "] = " + std::to_string(idx) + " is out of range [0, " + std::to_string(nv) + ")");
          }
        }
      }
      d->kind = detail::CoreKind::kMesh;
      detail::buildBvh(*d);
      break;
    }
  }
  data_ = std::move(d);
}

const Shape& PreparedShape::shape() const { return data_->shape; }

DistanceResult distance(const PreparedShape& a, const Eigen::Isometry3d& pose_a,
                        const PreparedShape& b, const Eigen::Isometry3d& pose_b,
                        const DistanceOptions& options) {
  detail::checkPose(pose_a, "pose_a");
  detail::checkPose(pose_b, "pose_b");
  if (!(std::isfinite(options.tolerance) && options.tolerance > 0.0) ||
      !(std::isfinite(options.relative_tolerance) && options.relative_tolerance >= 0.0) ||
      options.max_iterations <= 0) {
    throw InvalidArgument("distance options: tolerance must be finite and > 0, relative_tolerance >= 0, max_iterations > 0");
  }
  const detail::Tolerances tol = detail::distanceTolerances(options);
  const detail::Side A = detail::makeSide(a.data(), pose_a.linear(), pose_a.translation());
  const detail::Side B = detail::makeSide(b.data(), pose_b.linear(), pose_b.translation());
  if (A.mesh || B.mesh) return detail::meshDistance(A, B, tol);
  const detail::Convex ca = detail::makeConvex(a.data(), A.R, A.p);
  const detail::Convex cb = detail::makeConvex(b.data(), B.R, B.p);
  return detail::convexDistance(ca, cb, ca.p - cb.p, tol.abs_tol, tol.rel_tol, tol.max_iter, nullptr);
}

DistanceResult distance(const Shape& a, const Eigen::Isometry3d& pose_a, const Shape& b,
                        const Eigen::Isometry3d& pose_b, const DistanceOptions& options) {
  return distance(PreparedShape(a), pose_a, PreparedShape(b), pose_b, options);
}

}  // namespace vadop
