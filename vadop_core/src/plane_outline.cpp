// Convex outlines in a plane: hull, clipping, centroid. See plane_outline.h.
#include "plane_outline.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace vadop {
namespace detail {

namespace {

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

double signedArea(const Outline& p) {
  double a = 0.0;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
  return 0.5 * a;
}

// The two points farthest apart (a degenerate outline's segment), first and second.
std::pair<Vec2, Vec2> extremes(const Outline& p) {
  std::pair<Vec2, Vec2> best{p.front(), p.front()};
  double far = -1.0;
  for (size_t i = 0; i < p.size(); ++i) {
    for (size_t j = i; j < p.size(); ++j) {
      const double d = (p[i] - p[j]).squaredNorm();
      if (d > far) {
        far = d;
        best = {p[i], p[j]};
      }
    }
  }
  return best;
}

// An outline with area: more than a sliver of width tol.
bool hasArea(const Outline& p, double tol) {
  if (p.size() < 3) return false;
  const auto [a, b] = extremes(p);
  return std::abs(signedArea(p)) > tol * (a - b).norm();
}

// Sutherland-Hodgman: the subject (any outline: a point or a segment clips as a closed polygon
// of one or two vertices) clipped by the half-planes of the convex counter-clockwise clipper's
// edges, each moved out by tol.
Outline clip(Outline subject, const Outline& clipper, double tol) {
  for (size_t i = 0; i < clipper.size() && !subject.empty(); ++i) {
    const Vec2& a = clipper[i];
    const Vec2 e = clipper[(i + 1) % clipper.size()] - a;
    const double len = e.norm();
    if (!(len > 0.0)) continue;
    auto inside = [&](const Vec2& x) { return (e.x() * (x.y() - a.y()) - e.y() * (x.x() - a.x())) / len + tol; };
    Outline out;
    for (size_t j = 0; j < subject.size(); ++j) {
      const Vec2& prev = subject[(j + subject.size() - 1) % subject.size()];
      const Vec2& cur = subject[j];
      const double dp = inside(prev), dc = inside(cur);
      if ((dc >= 0.0) != (dp >= 0.0)) out.push_back(prev + (cur - prev) * (dp / (dp - dc)));
      if (dc >= 0.0) out.push_back(cur);
    }
    subject = std::move(out);
  }
  return subject;
}

// Where two degenerate outlines (points or segments) meet, within tol: the middle of their
// common stretch when collinear, else their crossing.
bool meetDegenerate(const Outline& P, const Outline& Q, double tol, Vec2& c) {
  auto [p0, p1] = extremes(P);
  auto [q0, q1] = extremes(Q);
  if ((q1 - q0).squaredNorm() > (p1 - p0).squaredNorm()) {
    std::swap(p0, q0);
    std::swap(p1, q1);
  }
  const double len = (p1 - p0).norm();
  if (len <= tol) {
    if ((q0 - p0).norm() > 2.0 * tol) return false;
    c = 0.5 * (p0 + q0);
    return true;
  }
  const Vec2 e = (p1 - p0) / len, m(-e.y(), e.x());
  const double o0 = m.dot(q0 - p0), o1 = m.dot(q1 - p0);
  if (std::abs(o0) <= tol && std::abs(o1) <= tol) {
    const double s0 = e.dot(q0 - p0), s1 = e.dot(q1 - p0);
    const double lo = std::max(0.0, std::min(s0, s1)), hi = std::min(len, std::max(s0, s1));
    if (lo > hi + 2.0 * tol) return false;
    c = p0 + e * (0.5 * (lo + hi));
    return true;
  }
  if ((o0 > tol && o1 > tol) || (o0 < -tol && o1 < -tol)) return false;
  const Vec2 x = q0 + (q1 - q0) * (o0 / (o0 - o1));
  const double s = e.dot(x - p0);
  if (s < -tol || s > len + tol) return false;
  c = x;
  return true;
}

}  // namespace

// The convex hull (monotone chain), counter-clockwise; the two extremes of collinear points.
Outline convexHull(Outline p) {
  std::sort(p.begin(), p.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  Outline h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0.0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(h[k - 2], h[k - 1], p[i]) <= 0.0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h;
}

// The centroid of the intersection of two outlines, its area (0 unless both have area) and the
// intersection itself (its centroid alone when both are degenerate).
bool meet(const Outline& P, const Outline& Q, double tol, Vec2& c, double& area, Outline& region) {
  area = 0.0;
  const bool ap = hasArea(P, tol), aq = hasArea(Q, tol);
  if (!ap && !aq) {
    if (!meetDegenerate(P, Q, tol, c)) return false;
    region.assign(1, c);
    return true;
  }
  // Exactly first (a tolerance would move a face's edges out, and the centroid with them), then
  // within tol (a point or an edge on the other's boundary).
  region = clip(aq ? P : Q, aq ? Q : P, 0.0);
  if (region.empty()) region = clip(aq ? P : Q, aq ? Q : P, tol);
  if (region.empty()) return false;
  if (ap && aq && hasArea(region, tol)) {
    const double a = signedArea(region);
    Vec2 sum = Vec2::Zero();
    for (size_t i = 0, j = region.size() - 1; i < region.size(); j = i++) {
      sum += (region[j] + region[i]) * (region[j].x() * region[i].y() - region[i].x() * region[j].y());
    }
    c = sum / (6.0 * a);
    area = std::abs(a);
    return true;
  }
  const auto [a, b] = extremes(region);
  c = 0.5 * (a + b);
  return true;
}

}  // namespace detail
}  // namespace vadop
