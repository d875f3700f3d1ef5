// The contact patch's centroid: support features, their outlines clipped in the contact plane.
// See contact_patch.h.
#include "contact_patch.h"

#include "convex_distance.h"
#include "gjk.h"
#include "plane_outline.h"

#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace vadop {
namespace detail {

namespace {

using Points = std::vector<Eigen::Vector3d>;

// A feature holds the core's points within this share of its size below its support along the
// normal: a face stays a face under the normal's rounding error (a polytope's normal is exact to
// rounding, a touching pair's to the distance query's accuracy), yet the point stays within this
// of each shape.
constexpr double kFeatureShare = 1e-7;
constexpr int kCapSides = 32;  // a cylinder's cap as the polygon inscribed in its rim
// A mesh pair whose bodies meet over many triangles: the patch of the first ones met is enough
// for a point inside both (each triangle's patch is), and keeps the cost bounded.
constexpr int kMaxLeafPairs = 1024;

// The feature tolerance of a core: its share of the core's size, and the rounding of its
// coordinates far from the origin.
double featureTolerance(const Convex& c) {
  const Eigen::Vector3d m = c.centre();
  double size = 0.0;
  if (c.shape) {
    size = c.shape->lever;
  } else {
    for (const Eigen::Vector3d& v : c.tri) size = std::max(size, (v - m).norm());
    size += c.rounding;
  }
  return kFeatureShare * size + 1e-13 * m.norm();
}

// Keeps the points within eps of the highest along d.
void keepHighest(Points& pts, const Eigen::Vector3d& d, double eps) {
  double top = -kInf;
  for (const Eigen::Vector3d& x : pts) top = std::max(top, d.dot(x));
  pts.erase(std::remove_if(pts.begin(), pts.end(), [&](const Eigen::Vector3d& x) { return d.dot(x) < top - eps; }),
            pts.end());
}

// A cylinder's feature along the unit db (body frame): its cap when the cap's rim lies within eps
// of the support, a side line when that line does, else the rim point; the side line's and the
// rim point's place around the axis from dg (see supportFeature).
void cylinderFeature(const PreparedShapeData& s, const Eigen::Vector3d& db, const Eigen::Vector3d& dg, double eps,
                     Points& out) {
  const double hl = s.half_length, rc = s.cyl_radius;
  const double z = db.z() >= 0.0 ? hl : -hl;
  if (2.0 * rc * std::hypot(db.x(), db.y()) <= eps) {
    constexpr double kTwoPi = 6.283185307179586;
    for (int k = 0; k < kCapSides; ++k) {
      const double a = kTwoPi * k / kCapSides;
      out.emplace_back(rc * std::cos(a), rc * std::sin(a), z);
    }
    return;
  }
  const double r = std::hypot(dg.x(), dg.y());
  const Eigen::Vector3d e = r > 0.0 ? Eigen::Vector3d(rc * dg.x() / r, rc * dg.y() / r, 0.0)
                                    : Eigen::Vector3d(rc * db.x(), rc * db.y(), 0.0).normalized() * rc;
  if (2.0 * hl * std::abs(db.z()) <= eps) {
    out.push_back(e - Eigen::Vector3d(0.0, 0.0, hl));
    out.push_back(e + Eigen::Vector3d(0.0, 0.0, hl));
    return;
  }
  out.push_back(e + Eigen::Vector3d(0.0, 0.0, z));
}

// The core's points (world frame) within eps of its support along the unit d. Heights are
// compared in the body frame, where coordinates are small. A round core's feature that depends
// on the direction (a cylinder's side line or rim point) lies along `along` when given: the
// contact's own normal, so that the point and that normal agree (a body turning about its axis
// slides, exactly, at its surface point along the normal).
Points supportFeature(const Convex& c, const Eigen::Vector3d& d, double eps, const Eigen::Vector3d* along = nullptr) {
  Points pts;
  if (c.shape == nullptr) {
    pts.assign(c.tri.begin(), c.tri.end());
    keepHighest(pts, d, eps);
    return pts;
  }
  const PreparedShapeData& s = *c.shape;
  const Eigen::Vector3d db = c.R.transpose() * d;
  switch (s.kind) {
    case CoreKind::kPoint: pts.emplace_back(Eigen::Vector3d::Zero()); break;
    case CoreKind::kSegment:
      pts.emplace_back(0.0, 0.0, -s.half_length);
      pts.emplace_back(0.0, 0.0, s.half_length);
      break;
    case CoreKind::kBox:
      for (int k = 0; k < 8; ++k) {
        pts.emplace_back((k & 1 ? 1.0 : -1.0) * s.half_extents.x(), (k & 2 ? 1.0 : -1.0) * s.half_extents.y(),
                         (k & 4 ? 1.0 : -1.0) * s.half_extents.z());
      }
      break;
    case CoreKind::kCylinder:
      cylinderFeature(s, db, along ? Eigen::Vector3d(c.R.transpose() * *along) : db, eps, pts);
      break;
    case CoreKind::kPoints: pts = s.points; break;
    case CoreKind::kMesh: break;  // meshes come triangle by triangle
  }
  if (s.kind != CoreKind::kCylinder) keepHighest(pts, db, eps);
  for (Eigen::Vector3d& x : pts) x = c.R * x + c.p + c.shift;
  return pts;
}

// A round core's feature: a sphere's centre, a capsule's segment or end, a cylinder's side line
// or rim point (its cap is a face).
bool roundFeature(const Convex& c, const Points& f) {
  if (c.shape == nullptr) return false;
  const CoreKind k = c.shape->kind;
  return k == CoreKind::kPoint || k == CoreKind::kSegment || (k == CoreKind::kCylinder && f.size() < 3);
}

// The point of a round feature (one or two points) whose projection along the plane's axes u, v
// is nearest c.
Eigen::Vector3d onFeature(const Points& f, const Vec2& c, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  if (f.size() < 2) return f.front();
  const Vec2 q0(u.dot(f[0]), v.dot(f[0])), q1(u.dot(f[1]), v.dot(f[1]));
  const double qq = (q1 - q0).squaredNorm();
  const double t = qq > 0.0 ? std::clamp((c - q0).dot(q1 - q0) / qq, 0.0, 1.0) : 0.5;
  return f[0] + t * (f[1] - f[0]);
}

Eigen::Vector3d anyPerpendicular(const Eigen::Vector3d& n) {
  const Eigen::Vector3d t = std::abs(n.x()) < 0.6 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return n.cross(t).normalized();
}

// The normal of a planar feature (at least three points not on a line, all within eps of one
// plane), oriented along n; zero when the feature is not planar.
Eigen::Vector3d planeNormal(const Points& f, const Eigen::Vector3d& n, double eps) {
  if (f.size() < 3) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d& o = f.front();
  size_t i1 = 0, i2 = 0;
  for (size_t i = 1; i < f.size(); ++i) {
    if ((f[i] - o).squaredNorm() > (f[i1] - o).squaredNorm()) i1 = i;
  }
  const Eigen::Vector3d e = f[i1] - o;
  for (size_t i = 1; i < f.size(); ++i) {
    if (e.cross(f[i] - o).squaredNorm() > e.cross(f[i2] - o).squaredNorm()) i2 = i;
  }
  Eigen::Vector3d m = e.cross(f[i2] - o);
  if (!(m.norm() > eps * e.norm())) return Eigen::Vector3d::Zero();
  m.normalize();
  for (const Eigen::Vector3d& x : f) {
    if (std::abs(m.dot(x - o)) > eps) return Eigen::Vector3d::Zero();
  }
  return m.dot(n) >= 0.0 ? m : Eigen::Vector3d(-m);
}

// The normal the patch is built on: the exact normal of a face of either core within kSnapAngle
// of n (the face most aligned with it), else n. A touching pair's normal comes from closest
// points a rounding error apart, a cylinder's or a point cloud's overlap normal from a search
// to 1e-6: off by far more than a face's tolerance, so the face would break into a corner.
constexpr double kSnapAngle = 1e-3;  // rad, as physics engines pick a reference face

Eigen::Vector3d snapNormal(const Convex& A, const Convex& B, const Eigen::Vector3d& n, double ea, double eb) {
  Eigen::Vector3d best = n;
  double best_cos = std::cos(kSnapAngle);
  const double sa = ea / kFeatureShare, sb = eb / kFeatureShare;  // the cores' sizes, about
  for (const Eigen::Vector3d& m : {planeNormal(supportFeature(A, n, ea + kSnapAngle * sa), n, ea),
                                   planeNormal(supportFeature(B, -n, eb + kSnapAngle * sb), n, eb)}) {
    if (m.dot(n) > best_cos) {
      best_cos = m.dot(n);
      best = m;
    }
  }
  return best;
}

struct Patch {
  bool found = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // the plane it lies in
  std::vector<Eigen::Vector3d> region;                // its outline on that plane (convex)
  double area = 0.0;
  double separation = 0.0;  // along its normal
  double tolerance = 0.0;   // of its features
};

// The patch's centroid from the features within eps of the supports along n: their common
// outline in the plane normal to n, placed midway between the padded shapes' supports. With a
// round feature (`along`: the contact's normal, see supportFeature), the point on it moved along
// that normal to the midway plane.
bool meetAlong(const Convex& A, const Convex& B, const Eigen::Vector3d& n, double ea, double eb,
               const Eigen::Vector3d& along, Patch& p) {
  const Eigen::Vector3d back = -along;
  const Points fa = supportFeature(A, n, ea, &along), fb = supportFeature(B, -n, eb, &back);
  const Eigen::Vector3d u = anyPerpendicular(n), v = n.cross(u);
  auto outline = [&](const Points& f) {
    Outline o;
    o.reserve(f.size());
    for (const Eigen::Vector3d& x : f) o.emplace_back(u.dot(x), v.dot(x));
    return convexHull(std::move(o));
  };
  Vec2 c;
  Outline region;
  if (fa.empty() || fb.empty() || !meet(outline(fa), outline(fb), ea + eb, c, p.area, region)) return false;
  const double top_a = n.dot(A.support(n)) + A.rounding;
  const double low_b = n.dot(B.support(-n)) - B.rounding;
  const double mid = 0.5 * (top_a + low_b);
  p.found = true;
  p.point = c.x() * u + c.y() * v + mid * n;
  const bool round_a = roundFeature(A, fa);
  if ((round_a || roundFeature(B, fb)) && n.dot(along) > 0.5) {
    const Eigen::Vector3d x = onFeature(round_a ? fa : fb, c, u, v);
    p.point = x + ((mid - n.dot(x)) / n.dot(along)) * along;
  }
  p.normal = n;
  p.region.clear();
  for (const Vec2& x : region) p.region.push_back(x.x() * u + x.y() * v + mid * n);
  p.separation = low_b - top_a;
  p.tolerance = ea + eb;
  return true;
}

// A point of both cores when the GJK found them overlapping: its final simplex holds the origin,
// o = sum l_i (a_i - b_i) with weights l_i >= 0 summing to 1, so sum l_i a_i = sum l_i b_i lies in
// both (each a convex combination of its own core's points).
Eigen::Vector3d commonPoint(const Gjk& g) {
  const SVert* s = g.simplex;
  const int n = std::clamp(g.simplex_n, 1, 4);
  if (n == 1) return 0.5 * (s[0].a + s[0].b);
  Eigen::Matrix<double, 3, Eigen::Dynamic> E(3, n - 1);
  for (int k = 1; k < n; ++k) E.col(k - 1) = s[k].w - s[0].w;
  const Eigen::VectorXd mu = E.colPivHouseholderQr().solve(Eigen::Vector3d(-s[0].w));
  Eigen::Vector3d x = s[0].a;
  for (int k = 1; k < n; ++k) x += mu(k - 1) * (s[k].a - s[0].a);
  return x;
}

Convex shifted(Convex c, const Eigen::Vector3d& d) {
  c.p += d;
  if (c.shape == nullptr) {
    for (Eigen::Vector3d& v : c.tri) v += d;
  }
  return c;
}

// One pair of convex cores. Touching (apart, or overlapping within the features' tolerance):
// the closest points of the pair held a little apart along n, to rounding accuracy, give the
// normal (closest points a rounding error apart give a direction good to no better than that
// error over their distance), and their midpoint the point when no face or line meets the
// other's. Overlapping: the contact's normal, and features as tight as will meet (a normal
// found by search can part two rim points or split a side line), from 1e-7 to 1e-3 of the
// cores' sizes. Both on the snapped normal.
Patch pairPatch(const Convex& A, const Convex& B, const Eigen::Vector3d& n) {
  const double ea = featureTolerance(A), eb = featureTolerance(B);
  const double sep = separation(A, B, n);
  Patch p;
  if (sep > -(ea + eb)) {
    const double apart = ea + eb - std::min(sep, 0.0);
    const double scale = 1.0 + A.p.norm() + B.p.norm() + A.lever + B.lever;
    const DistanceResult r = convexDistance(A, shifted(B, apart * n), -n, 1e-15 * scale, 0.0, 256, nullptr);
    if (!r.cores_overlap) {
      if (meetAlong(A, B, snapNormal(A, B, r.normal, ea, eb), ea, eb, n, p)) return p;
      p.found = true;
      p.point = 0.5 * (r.point_a + r.point_b - apart * n);
      p.normal = r.normal;
      p.region.assign(1, p.point);
      p.separation = r.distance - apart;  // the pair's own gap: a pair side by side is far
      p.tolerance = ea + eb;
      return p;
    }
  }
  const Eigen::Vector3d m = snapNormal(A, B, n, ea, eb);
  // Looser features stay within a quarter of the depth of each shape.
  const double loosest = std::max(1.0, 0.25 * -sep / std::max(ea, eb));
  for (double loose = 1.0; loose <= std::min(loosest, 1e4); loose *= 10.0) {
    if (meetAlong(A, B, m, loose * ea, loose * eb, n, p)) return p;
  }
  const double scale = 1.0 + A.p.norm() + B.p.norm() + A.lever + B.lever;
  const Gjk g = runGjk(A, B, -n, 1e-15 * scale, 0.0, 256);
  if (g.overlap) {
    p.found = true;
    p.point = commonPoint(g);
    p.normal = n;
    p.region.assign(1, p.point);
    p.separation = sep;
    p.tolerance = ea + eb;
  }
  return p;
}

// Whether x lies within tol of the convex polygon (or segment, or point) `poly`, all three in
// the plane normal to n.
bool nearRegion(const Eigen::Vector3d& x, const std::vector<Eigen::Vector3d>& poly, const Eigen::Vector3d& n,
                double tol) {
  if (poly.size() < 3) {
    const Eigen::Vector3d a = poly.front(), e = poly.back() - a;
    const double ee = e.squaredNorm();
    const double s = ee > 0.0 ? std::clamp((x - a).dot(e) / ee, 0.0, 1.0) : 0.0;
    return (x - a - s * e).norm() <= tol;
  }
  bool pos = true, neg = true;  // inside every edge for one of the two orientations
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector3d e = poly[i] - poly[j];
    const double len = e.norm();
    if (!(len > 0.0)) continue;
    const double side = n.dot(e.cross(x - poly[j])) / len;
    pos = pos && side >= -tol;
    neg = neg && side <= tol;
  }
  return pos || neg;
}

bool adjoin(const Patch& a, const Patch& b, double tol) {
  for (const Eigen::Vector3d& x : a.region) {
    if (nearRegion(x, b.region, b.normal, tol)) return true;
  }
  for (const Eigen::Vector3d& x : b.region) {
    if (nearRegion(x, a.region, a.normal, tol)) return true;
  }
  return false;
}

// The deepest patches (within their features' tolerance): the one with the largest area and
// those joined to it on its plane, edge to edge (a face split into triangles), area-weighted;
// else the one nearest the witness points; their midpoint when there is none. Patches on
// other planes or apart (a table's feet) are left out: their common centroid could lie in
// neither body.
Eigen::Vector3d combinePatches(const std::vector<Patch>& patches, const Eigen::Vector3d& witness) {
  double deepest = kInf;
  for (const Patch& p : patches) deepest = std::min(deepest, p.separation + p.tolerance);
  std::vector<const Patch*> deep;
  for (const Patch& p : patches) {
    if (p.separation - p.tolerance <= deepest) deep.push_back(&p);
  }
  if (deep.empty()) return witness;
  auto nearer = [&](const Patch* a, const Patch* b) {
    if (a->area != b->area) return a->area > b->area;
    return (a->point - witness).squaredNorm() < (b->point - witness).squaredNorm();
  };
  std::sort(deep.begin(), deep.end(), nearer);
  const Patch& ref = *deep.front();
  if (!(ref.area > 0.0)) return ref.point;
  std::vector<const Patch*> group{&ref};
  std::vector<bool> taken(deep.size(), false);
  taken[0] = true;
  for (size_t g = 0; g < group.size(); ++g) {
    for (size_t k = 1; k < deep.size(); ++k) {
      const Patch& p = *deep[k];
      const double tol = p.tolerance + ref.tolerance;
      if (taken[k] || !(p.area > 0.0) || std::abs(ref.normal.dot(p.point - ref.point)) > tol) continue;
      if (!adjoin(*group[g], p, tol)) continue;
      taken[k] = true;
      group.push_back(&p);
    }
  }
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  double area = 0.0;
  for (const Patch* p : group) {
    area += p->area;
    weighted += p->area * p->point;
  }
  return weighted / area;
}

// A mesh on either side: the leaf pairs within reach of the contact, about as deep along n as
// it, whose features meet; of those, the deepest along their own normals.
Eigen::Vector3d meshPatchPoint(const Side& A, const Side& B, const DistanceResult& contact,
                               const Eigen::Vector3d& witness) {
  const Eigen::Vector3d& n = contact.normal;
  const double reach = std::max(contact.distance, 0.0);
  std::vector<Patch> patches;
  int leaves = 0;
  std::vector<std::pair<int, int>> stack{{A.root(), B.root()}};
  while (!stack.empty() && leaves < kMaxLeafPairs) {
    const auto [ia, ib] = stack.back();
    stack.pop_back();
    const double D = (A.centre(ia) - B.centre(ib)).norm() - A.radius(ia) - B.radius(ib);
    if (D > reach + kSnapAngle * (A.radius(ia) + B.radius(ib))) continue;
    if (A.leaf(ia) && B.leaf(ib)) {
      ++leaves;
      const Convex ca = A.convex(ia), cb = B.convex(ib);
      const double tol = (kSnapAngle / kFeatureShare) * (featureTolerance(ca) + featureTolerance(cb));
      if (std::abs(separation(ca, cb, n) - contact.distance) > tol) continue;
      const Patch p = pairPatch(ca, cb, n);
      if (p.found) patches.push_back(p);
      continue;
    }
    const bool split_a = !A.leaf(ia) && (B.leaf(ib) || A.radius(ia) >= B.radius(ib));
    if (split_a) {
      stack.emplace_back(A.d->nodes[ia].left, ib);
      stack.emplace_back(A.d->nodes[ia].right, ib);
    } else {
      stack.emplace_back(ia, B.d->nodes[ib].left);
      stack.emplace_back(ia, B.d->nodes[ib].right);
    }
  }
  return combinePatches(patches, witness);
}

}  // namespace

Eigen::Vector3d contactPatchPoint(const Side& A, const Side& B, const DistanceResult& contact) {
  const Eigen::Vector3d witness = 0.5 * (contact.point_a + contact.point_b);
  const Eigen::Vector3d& n = contact.normal;
  if (!(n.allFinite() && std::abs(n.squaredNorm() - 1.0) < 1e-9 && std::isfinite(contact.distance))) return witness;
  if (A.mesh || B.mesh) return meshPatchPoint(A, B, contact, witness);
  const Patch p = pairPatch(A.convex(0), B.convex(0), n);
  return p.found ? p.point : witness;
}

}  // namespace detail
}  // namespace vadop
