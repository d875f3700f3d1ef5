// Independent ground truth for the continuous narrow phase (test helper).
//
// Nothing here calls the code under test (distance.h, time_of_impact.h) nor the shapes'
// support functions or Motion::poseAt: it reads the Shape and Motion fields and builds its
// own geometry.
//
//  * Poses: Rodrigues' formula for exp([w] dt), applied to the reference orientation.
//  * Geometry: every shape is a set of convex pieces given by explicit body-frame vertices
//    plus a rounding radius (sphere = 1 point, capsule = 2, box = 8, convex = its points,
//    mesh = one piece per triangle). A cylinder is sandwiched between an inscribed and a
//    circumscribed regular 2^20-gon prism (Hausdorff gap r * 4.5e-12).
//  * Static distance of two pieces: a min-norm-point iteration on the Minkowski difference
//    whose inner step enumerates every subset of the (at most 4) current points and solves
//    the affine least-squares problem (no Voronoi-region logic). The answer is certified, not
//    trusted: hi = |sum l_i (a_i - b_i)| for an explicit convex combination of vertices, lo =
//    the separation along the final direction computed by scanning the vertices.
//  * Time: a left-first bisection over [t0, t1] that certifies each sub-interval [a, b] free
//    of gap <= theta for EVERY piece pair, either by the pieces' bounding spheres (Lipschitz
//    with the true motion bound, both ends) or, along the pair's separating direction n found
//    at a or at b, by  s_n(t) >= min(s_n(a), s_n(b)) - (b - a)^2 / 8 * (|wa|^2 ra + |wb|^2 rb)
//    (each vertex's projection n.R(t)x has second derivative <= |w|^2 |x|; the translation
//    part is linear and the max over vertices of linear interpolants is convex, so the
//    interpolated lower bound is concave and attains its minimum at an end point).
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

namespace toi_truth {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 6.283185307179586476925286766559;
constexpr int kPolygon = 1 << 20;  // sides of the cylinder sandwich polygons

// ---------------------------------------------------------------------------------------
// Poses

struct Pose {
  Matrix3d R = Matrix3d::Identity();
  Vector3d p = Vector3d::Zero();
};

inline Matrix3d rodrigues(const Vector3d& rv) {
  const double th = rv.norm();
  if (th == 0.0) return Matrix3d::Identity();
  const Vector3d k = rv / th;
  Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return Matrix3d::Identity() + std::sin(th) * K + (1.0 - std::cos(th)) * K * K;
}

inline Pose poseAt(const vadop::Motion& m, double t) {
  const double dt = t - m.t_ref;
  const Matrix3d turn = rodrigues(m.angular_velocity * dt);
  Pose P;
  P.R = turn * m.orientation.normalized().toRotationMatrix();
  // The body turns about its pivot, which moves in a straight line (motion.h).
  const Vector3d pivot = m.position + m.pivot_offset + m.linear_velocity * dt;
  P.p = pivot - turn * m.pivot_offset;
  return P;
}

// How far the pivot may be from any body point beyond the point's distance to the origin.
inline double pivotLever(const vadop::Motion& m) { return m.pivot_offset.norm(); }

// ---------------------------------------------------------------------------------------
// Pieces

struct Piece {
  bool cylinder = false;
  std::vector<Vector3d> pts;  // body frame (polytope pieces)
  double cyl_r = 0.0, cyl_h = 0.0;
  double rounding = 0.0;
  Vector3d centre = Vector3d::Zero();  // body-frame bounding sphere of the padded piece
  double radius = 0.0;
  double lever = 0.0;  // max |x| over the core's vertices (outer prism for a cylinder)
};

struct Body {
  std::vector<Piece> pieces;
};

inline void finishPiece(Piece& pc) {
  if (pc.cylinder) {
    const double ro = pc.cyl_r / std::cos(kTwoPi / 2 / kPolygon);
    pc.centre = Vector3d::Zero();
    pc.lever = std::hypot(ro, pc.cyl_h);
    pc.radius = pc.lever + pc.rounding;
    return;
  }
  Vector3d lo = pc.pts[0], hi = pc.pts[0];
  for (const auto& x : pc.pts) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  pc.centre = 0.5 * (lo + hi);
  double r = 0.0, lev = 0.0;
  for (const auto& x : pc.pts) {
    r = std::max(r, (x - pc.centre).norm());
    lev = std::max(lev, x.norm());
  }
  pc.radius = r + pc.rounding;
  pc.lever = lev;
}

inline Body makeBody(const vadop::Shape& s) {
  Body b;
  const double m = s.margin;
  auto add = [&](Piece pc) {
    finishPiece(pc);
    b.pieces.push_back(std::move(pc));
  };
  switch (s.type) {
    case vadop::ShapeType::kSphere: {
      Piece pc;
      pc.pts = {Vector3d::Zero()};
      pc.rounding = s.radius + m;
      add(pc);
      break;
    }
    case vadop::ShapeType::kCapsule: {
      Piece pc;
      pc.pts = {Vector3d(0, 0, -s.half_length), Vector3d(0, 0, s.half_length)};
      pc.rounding = s.radius + m;
      add(pc);
      break;
    }
    case vadop::ShapeType::kBox: {
      Piece pc;
      for (int i = 0; i < 8; ++i) {
        pc.pts.emplace_back((i & 1) ? s.half_extents.x() : -s.half_extents.x(),
                            (i & 2) ? s.half_extents.y() : -s.half_extents.y(),
                            (i & 4) ? s.half_extents.z() : -s.half_extents.z());
      }
      pc.rounding = m;
      add(pc);
      break;
    }
    case vadop::ShapeType::kCylinder: {
      Piece pc;
      pc.cylinder = true;
      pc.cyl_r = s.radius;
      pc.cyl_h = s.half_length;
      pc.rounding = m;
      add(pc);
      break;
    }
    case vadop::ShapeType::kConvex: {
      Piece pc;
      pc.pts = s.points;
      pc.rounding = m;
      add(pc);
      break;
    }
    case vadop::ShapeType::kMesh: {
      for (const auto& t : s.triangles) {
        Piece pc;
        pc.pts = {s.points[t[0]], s.points[t[1]], s.points[t[2]]};
        pc.rounding = m;
        add(pc);
      }
      break;
    }
  }
  return b;
}

// Lever arm of the whole padded shape about its body origin (independent of bounding_radius).
inline double bodyLever(const Body& b) {
  double r = 0.0;
  for (const auto& pc : b.pieces) r = std::max(r, pc.lever + pc.rounding);
  return r;
}

// Support of a posed piece core: the vertex maximising d (world). outer selects the
// circumscribed polygon for cylinders (inner: inscribed).
inline Vector3d supportPiece(const Piece& pc, const Pose& P, const Vector3d& d, bool outer) {
  const Vector3d db = P.R.transpose() * d;
  Vector3d x;
  if (pc.cylinder) {
    const double z = db.z() >= 0.0 ? pc.cyl_h : -pc.cyl_h;
    const double phi = std::atan2(db.y(), db.x());  // (0,0) -> 0: any vertex is maximal
    const double K = static_cast<double>(kPolygon);
    double ang;
    double rho;
    if (outer) {
      const double j = std::round(phi * K / kTwoPi - 0.5);
      ang = (j + 0.5) * kTwoPi / K;
      rho = pc.cyl_r / std::cos(kTwoPi / 2 / K);
    } else {
      const double j = std::round(phi * K / kTwoPi);
      ang = j * kTwoPi / K;
      rho = pc.cyl_r;
    }
    x = Vector3d(rho * std::cos(ang), rho * std::sin(ang), z);
  } else {
    const Vector3d* best = &pc.pts[0];
    double bv = best->dot(db);
    for (size_t i = 1; i < pc.pts.size(); ++i) {
      const double v = pc.pts[i].dot(db);
      if (v > bv) {
        bv = v;
        best = &pc.pts[i];
      }
    }
    x = *best;
  }
  return P.R * x + P.p;
}

// Separation of the two cores along unit n (a to b): min_B n.y - max_A n.x, using the
// circumscribed polygons (a certified lower bound of the core distance when positive).
inline double coreSeparation(const Piece& A, const Pose& PA, const Piece& B, const Pose& PB,
                             const Vector3d& n) {
  return n.dot(supportPiece(B, PB, -n, true)) - n.dot(supportPiece(A, PA, n, true));
}

// ---------------------------------------------------------------------------------------
// Static distance of two pieces' cores.

struct CoreDist {
  double lo = 0.0;  // certified: core distance >= lo
  double hi = kInf; // certified: core distance <= hi (explicit points)
  Vector3d n = Vector3d::UnitX();  // a to b, the direction certifying lo (valid if lo > 0)
  Vector3d pa = Vector3d::Zero(), pb = Vector3d::Zero();  // witnesses realising hi
  bool overlap = false;
  int iterations = 0;
};

struct MinNorm {
  Vector3d x = Vector3d::Zero();
  double lambda[4] = {0, 0, 0, 0};
  int idx[4] = {0, 0, 0, 0};
  int k = 0;
};

// Min-norm point of conv(p[0..n)) by enumerating every subset and taking, among the
// subsets whose affine minimiser lies inside them, the one of least norm. The minimiser is
// computed geometrically (a perpendicular for a pair, a plane projection for a triple, the
// origin for a tetrahedron containing it) and the coordinates as signed lengths, areas and
// volumes, which keeps the point's direction accurate even when it is tiny compared with the
// simplex (a Gram-matrix solve would square the conditioning).
inline MinNorm minNormBrute(const Vector3d* p, int n) {
  MinNorm best;
  double best_norm = kInf;
  for (int mask = 1; mask < (1 << n); ++mask) {
    int id[4];
    int k = 0;
    for (int i = 0; i < n; ++i) {
      if (mask & (1 << i)) id[k++] = i;
    }
    double lam[4] = {1, 0, 0, 0};
    Vector3d x = p[id[0]];
    if (k == 2) {
      const Vector3d ab = p[id[1]] - p[id[0]];
      const double aa = ab.squaredNorm();
      if (!(aa > 0.0)) continue;
      const double t = -p[id[0]].dot(ab) / aa;
      if (t < 0.0 || t > 1.0) continue;
      lam[0] = 1.0 - t;
      lam[1] = t;
      x = p[id[0]] - ab * (p[id[0]].dot(ab) / aa);
    } else if (k == 3) {
      const Vector3d& a = p[id[0]];
      const Vector3d& b = p[id[1]];
      const Vector3d& c = p[id[2]];
      const Vector3d nrm = (b - a).cross(c - a);
      const double nn = nrm.squaredNorm();
      if (!(nn > 1e-28 * (b - a).squaredNorm() * (c - a).squaredNorm()) || !(nn > 0.0)) continue;
      x = nrm * (nrm.dot(a) / nn);
      lam[0] = nrm.dot((b - x).cross(c - x)) / nn;
      lam[1] = nrm.dot((c - x).cross(a - x)) / nn;
      lam[2] = nrm.dot((a - x).cross(b - x)) / nn;
      if (lam[0] < 0.0 || lam[1] < 0.0 || lam[2] < 0.0) continue;
    } else if (k == 4) {
      const Vector3d& a = p[id[0]];
      const Vector3d& b = p[id[1]];
      const Vector3d& c = p[id[2]];
      const Vector3d& d = p[id[3]];
      const double vol = (b - a).dot((c - a).cross(d - a));
      if (!(std::abs(vol) > 0.0)) continue;
      lam[0] = b.dot(c.cross(d)) / vol;  // volume (O, b, c, d) / (a, b, c, d)
      lam[1] = -a.dot(c.cross(d)) / vol;
      lam[2] = a.dot(b.cross(d)) / vol;
      lam[3] = -a.dot(b.cross(c)) / vol;
      bool inside = true;
      for (int j = 0; j < 4; ++j) inside = inside && lam[j] >= 0.0;
      if (!inside) continue;
      x = Vector3d::Zero();
    }
    double sum = 0.0;
    for (int j = 0; j < k; ++j) sum += lam[j];
    const double nx = x.norm();
    if (nx < best_norm) {
      best_norm = nx;
      best.x = x;
      best.k = k;
      for (int j = 0; j < k; ++j) {
        best.idx[j] = id[j];
        best.lambda[j] = lam[j] / sum;
      }
    }
  }
  return best;
}

// One min-norm run with a fixed polygon mode for cylinders.
inline CoreDist coreDistanceMode(const Piece& A, const Pose& PA, const Piece& B, const Pose& PB,
                                 bool outer, Vector3d guess) {
  CoreDist r;
  Vector3d pa[4], pb[4], w[4];
  int n = 0;
  if (!(guess.squaredNorm() > 0.0)) guess = Vector3d::UnitX();
  auto add = [&](const Vector3d& d) {  // support of A - B along d
    pa[n] = supportPiece(A, PA, d, outer);
    pb[n] = supportPiece(B, PB, -d, outer);
    w[n] = pa[n] - pb[n];
    ++n;
  };
  add(-guess);
  Vector3d x = w[0], xa = pa[0], xb = pb[0];
  const double scale = 1.0 + PA.p.norm() + PB.p.norm() + A.radius + B.radius;
  int it = 0;
  for (; it < 400; ++it) {
    const double nx = x.norm();
    if (nx <= 1e-15 * scale) {
      r.overlap = true;
      break;
    }
    const Vector3d sa = supportPiece(A, PA, -x, outer), sb = supportPiece(B, PB, x, outer);
    const Vector3d sw = sa - sb;
    if (nx - x.dot(sw) / nx <= 2e-14 * scale) break;
    bool dup = false;
    for (int i = 0; i < n; ++i) dup = dup || (w[i] - sw).squaredNorm() <= 1e-30 * scale * scale;
    if (dup) break;
    pa[n] = sa;
    pb[n] = sb;
    w[n] = sw;
    ++n;
    const MinNorm mn = minNormBrute(w, n);
    if (mn.k == 0) break;
    Vector3d nxa = Vector3d::Zero(), nxb = Vector3d::Zero();
    Vector3d npa[4], npb[4], nw[4];
    for (int j = 0; j < mn.k; ++j) {
      nxa += mn.lambda[j] * pa[mn.idx[j]];
      nxb += mn.lambda[j] * pb[mn.idx[j]];
      npa[j] = pa[mn.idx[j]];
      npb[j] = pb[mn.idx[j]];
      nw[j] = w[mn.idx[j]];
    }
    const Vector3d nxv = mn.x;  // the accurate min-norm point (direction), a - b
    if (nxv.norm() >= nx) {  // no progress: keep the previous certified answer
      --n;
      break;
    }
    n = mn.k;
    for (int j = 0; j < n; ++j) {
      pa[j] = npa[j];
      pb[j] = npb[j];
      w[j] = nw[j];
    }
    x = nxv;
    xa = nxa;
    xb = nxb;
    if (n == 4) {  // the origin is inside the tetrahedron (up to rounding)
      r.overlap = true;
      break;
    }
  }
  r.iterations = it + 1;
  r.pa = xa;
  r.pb = xb;
  r.hi = (xb - xa).norm();
  if (r.overlap || !(r.hi > 0.0)) {
    r.overlap = true;
    r.lo = 0.0;
    r.n = (PB.p - PA.p).squaredNorm() > 0 ? Vector3d((PB.p - PA.p).normalized()) : Vector3d::UnitX();
    return r;
  }
  r.n = -x / x.norm();  // from the min-norm point (accurate direction); hi from real points
  r.lo = std::max(0.0, coreSeparation(A, PA, B, PB, r.n));
  return r;
}

// A run that stalls (rounding in a degenerate simplex) is restarted from its answer with a
// fresh simplex; the bounds of all runs are valid, so the best of each is kept.
inline CoreDist coreDistanceRestarted(const Piece& A, const Pose& PA, const Piece& B, const Pose& PB,
                                      bool outer, const Vector3d& guess) {
  CoreDist r = coreDistanceMode(A, PA, B, PB, outer, guess);
  for (int k = 0; k < 4 && !r.overlap && r.hi - r.lo > 1e-12 * (1.0 + r.hi); ++k) {
    const CoreDist q = coreDistanceMode(A, PA, B, PB, outer, r.pa - r.pb);
    if (q.overlap) break;
    r.iterations += q.iterations;
    if (q.hi < r.hi) {
      r.hi = q.hi;
      r.pa = q.pa;
      r.pb = q.pb;
    }
    if (q.lo > r.lo) {
      r.lo = q.lo;
      r.n = q.n;
    }
  }
  return r;
}

inline CoreDist coreDistance(const Piece& A, const Pose& PA, const Piece& B, const Pose& PB) {
  const Vector3d guess = (PA.R * A.centre + PA.p) - (PB.R * B.centre + PB.p);
  if (!A.cylinder && !B.cylinder) return coreDistanceRestarted(A, PA, B, PB, false, guess);
  const CoreDist in = coreDistanceRestarted(A, PA, B, PB, false, guess);
  CoreDist out = coreDistanceRestarted(A, PA, B, PB, true, in.overlap ? guess : Vector3d(in.pa - in.pb));
  out.hi = in.hi;  // inscribed prisms: realised points inside the cylinders
  out.pa = in.pa;
  out.pb = in.pb;
  out.overlap = in.overlap;
  out.lo = std::min(out.lo, out.hi);
  out.iterations += in.iterations;
  return out;
}

// ---------------------------------------------------------------------------------------
// Gap of two moving shapes at one time, lazily per piece pair.

struct Scene {
  vadop::Shape shape_a, shape_b;
  vadop::Motion ma, mb;
  double t0 = 0.0, t1 = 1.0;
};

struct PairRec {
  bool done = false;
  double lo = 0.0, hi = 0.0;  // gap bounds (rounding subtracted)
  Vector3d n = Vector3d::UnitX();
  Vector3d pa = Vector3d::Zero(), pb = Vector3d::Zero();  // padded-surface witnesses
  bool overlap = false;
};

struct Eval {
  double t = 0.0;
  Pose pa, pb;
  std::vector<double> sgap;  // per pair: bounding-sphere gap (a lower bound of its gap)
  std::vector<PairRec> rec;
  double lo = kInf, hi = kInf;  // overall gap bounds
  int best = -1;                // pair realising hi
};

class Truth {
 public:
  explicit Truth(const Scene& s) : s_(s), A_(makeBody(s.shape_a)), B_(makeBody(s.shape_b)) {
    na_ = static_cast<int>(A_.pieces.size());
    nb_ = static_cast<int>(B_.pieces.size());
    vrel_ = (s.mb.linear_velocity - s.ma.linear_velocity).norm();
    wa_ = s.ma.angular_velocity.norm();
    wb_ = s.mb.angular_velocity.norm();
    pa_ = pivotLever(s.ma);
    pb_ = pivotLever(s.mb);
    lever_ = wa_ * (bodyLever(A_) + pa_) + wb_ * (bodyLever(B_) + pb_);
  }

  int pairs() const { return na_ * nb_; }
  const Body& bodyA() const { return A_; }
  const Body& bodyB() const { return B_; }
  long evaluations() const { return evaluations_; }
  long pairEvaluations() const { return pair_evaluations_; }
  double worstBracket() const { return worst_bracket_; }  // max hi - lo seen on computed pairs
  // Where the worst bracket was seen: time, core distance, min-norm iterations.
  void worstInfo(double* t, double* hi, int* iterations) const {
    *t = worst_at_;
    *hi = worst_hi_;
    *iterations = worst_iterations_;
  }

  // Overall Lipschitz bound of the gap (every point's relative speed).
  double lipschitz() const { return vrel_ + lever_; }

  std::shared_ptr<Eval> eval(double t) {
    ++evaluations_;
    auto e = std::make_shared<Eval>();
    e->t = t;
    e->pa = poseAt(s_.ma, t);
    e->pb = poseAt(s_.mb, t);
    const int np = pairs();
    e->sgap.resize(np);
    e->rec.resize(np);
    std::vector<Vector3d> ca(na_), cb(nb_);
    for (int i = 0; i < na_; ++i) ca[i] = e->pa.R * A_.pieces[i].centre + e->pa.p;
    for (int j = 0; j < nb_; ++j) cb[j] = e->pb.R * B_.pieces[j].centre + e->pb.p;
    for (int i = 0; i < na_; ++i) {
      for (int j = 0; j < nb_; ++j) {
        e->sgap[i * nb_ + j] = (ca[i] - cb[j]).norm() - A_.pieces[i].radius - B_.pieces[j].radius;
      }
    }
    std::vector<int> order(np);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int x, int y) { return e->sgap[x] < e->sgap[y]; });
    double lo = kInf;
    for (int k : order) {
      if (e->sgap[k] >= e->hi) {
        lo = std::min(lo, e->sgap[k]);
        break;  // sorted: every remaining pair is at least this far
      }
      const PairRec& r = pair(*e, k);
      lo = std::min(lo, r.lo);
      if (r.hi < e->hi) {
        e->hi = r.hi;
        e->best = k;
      }
    }
    e->lo = std::min(lo, e->hi);
    return e;
  }

  const PairRec& pair(Eval& e, int k) {
    PairRec& r = e.rec[k];
    if (r.done) return r;
    ++pair_evaluations_;
    const Piece& A = A_.pieces[k / nb_];
    const Piece& B = B_.pieces[k % nb_];
    const CoreDist c = coreDistance(A, e.pa, B, e.pb);
    const double rnd = A.rounding + B.rounding;
    r.done = true;
    r.overlap = c.overlap;
    r.lo = c.lo - rnd;
    r.hi = c.hi - rnd;
    r.n = c.n;
    r.pa = c.pa + A.rounding * c.n;
    r.pb = c.pb - B.rounding * c.n;
    // Precision record, where decisions at the tolerance are made (gap above 2e-7 m). Below
    // that the separating direction, hence the lower bound, is ill-conditioned (its error is
    // the point's error over the gap); there the bracket only blurs contact versus a graze
    // closer than ~1e-7 m, far inside the tolerance/2 within which a hit is required anyway.
    if (!c.overlap && c.hi > 2e-7 && c.hi - c.lo > worst_bracket_) {
      worst_bracket_ = c.hi - c.lo;
      worst_at_ = e.t;
      worst_hi_ = c.hi;
      worst_iterations_ = c.iterations;
    }
    return r;
  }

  // Certifies gap > theta on [a.t, b.t] for every piece pair.
  bool certify(Eval& a, Eval& b, double theta) {
    const double h = b.t - a.t;
    const Vector3d dv = s_.mb.linear_velocity - s_.ma.linear_velocity;
    (void)dv;
    for (int k = 0; k < pairs(); ++k) {
      const Piece& A = A_.pieces[k / nb_];
      const Piece& B = B_.pieces[k % nb_];
      // Bounding spheres, Lipschitz in time with the speed bound of their centres.
      const double Ls = vrel_ + wa_ * (A.centre.norm() + pa_) + wb_ * (B.centre.norm() + pb_);
      if (0.5 * (a.sgap[k] + b.sgap[k] - Ls * h) > theta) continue;
      const PairRec& ra = pair(a, k);
      const PairRec& rb = pair(b, k);
      if (ra.lo <= theta || rb.lo <= theta || ra.overlap || rb.overlap) return false;
      const double rnd = A.rounding + B.rounding;
      // Exact pair gap, Lipschitz with the pair's speed bound.
      const double Lp = vrel_ + wa_ * (A.lever + A.rounding + pa_) + wb_ * (B.lever + B.rounding + pb_);
      if (0.5 * (ra.lo + rb.lo - Lp * h) > theta) continue;
      // Second-order bound along the separating directions found at either end.
      const double M = wa_ * wa_ * (A.lever + pa_) + wb_ * wb_ * (B.lever + pb_);
      const double q = M * h * h / 8.0;
      const double s_ab = coreSeparation(A, b.pa, B, b.pb, ra.n) - rnd;  // n from a, at b
      const double s_ba = coreSeparation(A, a.pa, B, a.pb, rb.n) - rnd;  // n from b, at a
      const double bound = std::max(std::min(ra.lo, s_ab), std::min(rb.lo, s_ba)) - q;
      if (bound > theta) continue;
      return false;
    }
    return true;
  }

  struct First {
    bool found = false;
    double t = 0.0;
  };

  // First time in (a.t, b.t] at which the gap is <= theta (resolution eps), given that the
  // gap at a.t is certified > theta; none when [a.t, b.t] is certified above theta.
  First first(const std::shared_ptr<Eval>& a, const std::shared_ptr<Eval>& b, double theta, double eps,
              int depth = 0) {
    if (certify(*a, *b, theta)) return {};
    if (b->t - a->t <= eps || depth > 200) return {true, b->t};
    const double tm = 0.5 * (a->t + b->t);
    auto m = eval(tm);
    if (m->lo <= theta) {
      const First r = first(a, m, theta, eps, depth + 1);
      if (r.found) return r;
      return {true, tm};
    }
    const First r = first(a, m, theta, eps, depth + 1);
    if (r.found) return r;
    return first(m, b, theta, eps, depth + 1);
  }

 private:
  Scene s_;
  Body A_, B_;
  int na_ = 0, nb_ = 0;
  double vrel_ = 0.0, wa_ = 0.0, wb_ = 0.0, lever_ = 0.0, pa_ = 0.0, pb_ = 0.0;
  long evaluations_ = 0;
  long pair_evaluations_ = 0;
  double worst_bracket_ = 0.0;
  double worst_at_ = 0.0, worst_hi_ = 0.0;
  int worst_iterations_ = 0;
};

// Classification of one scene against a tolerance.
enum class Verdict { kClear, kGraze, kContact };

struct Answer {
  Verdict verdict = Verdict::kClear;
  double t_tol = 0.0;   // first time gap <= tol (graze and contact)
  double t_star = 0.0;  // first time gap <= 0 (contact)
  bool initial = false; // contact at t0
  double closing = 0.0; // -d gap / dt just before t_star (contact, t_star > t0)
};

inline Answer classify(Truth& tr, const Scene& s, double tol, double eps) {
  Answer out;
  auto e0 = tr.eval(s.t0);
  if (e0->lo <= 0.0) {
    out.verdict = Verdict::kContact;
    out.initial = true;
    out.t_tol = out.t_star = s.t0;
    return out;
  }
  auto e1 = tr.eval(s.t1);
  double t_tol = s.t0;
  if (e0->lo > tol) {
    const Truth::First f = tr.first(e0, e1, tol, eps);
    if (!f.found) return out;  // clear
    t_tol = f.t;
  }
  out.t_tol = t_tol;
  // Everything before t_tol is certified above tol > 0: look for the contact from there.
  auto et = tr.eval(t_tol);
  if (et->lo <= 0.0) {
    out.verdict = Verdict::kContact;
    out.t_star = t_tol;
  } else {
    const Truth::First f = tr.first(et, e1, 0.0, eps);
    if (!f.found) {
      out.verdict = Verdict::kGraze;
      return out;
    }
    out.verdict = Verdict::kContact;
    out.t_star = f.t;
  }
  const double dt = std::min(1e-5, out.t_star - s.t0);
  if (dt > 0.0) {
    auto before = tr.eval(out.t_star - dt);
    auto at = tr.eval(out.t_star);
    out.closing = (before->hi - at->hi) / dt;
  }
  return out;
}

}  // namespace toi_truth
