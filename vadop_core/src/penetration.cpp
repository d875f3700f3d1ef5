// Penetration direction of overlapping convex cores: separating axes, expanding polytope (EPA),
// hill climbing. See penetration.h.
#include "penetration.h"

#include <cmath>
#include <utility>

namespace vadop {
namespace detail {

namespace {

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

}  // namespace

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

}  // namespace detail
}  // namespace vadop
