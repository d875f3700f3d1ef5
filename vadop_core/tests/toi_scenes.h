// Random scenes for the ground-truth comparison of the continuous narrow phase (test helper).
// Sizes from 1 cm to 1 m (log-uniform), thin plates, offset convex/mesh bodies, padded
// shapes, velocities aimed so that about half the cases touch, and constructed grazes:
// after the scene is built, the truth's closest approach over the window is found and b is
// shifted along that normal so that it passes within a few tolerances of touching.
#pragma once

#include "toi_truth.h"

#include "vadop/motion.h"
#include "vadop/shapes.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace toi_scenes {

using Eigen::Quaterniond;
using Eigen::Vector3d;

struct Rng {
  explicit Rng(uint64_t seed) : g(seed) {}
  std::mt19937_64 g;
  double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(g); }
  double logu(double a, double b) { return std::exp(uni(std::log(a), std::log(b))); }
  int integer(int a, int b) { return std::uniform_int_distribution<int>(a, b)(g); }
  bool chance(double p) { return uni(0.0, 1.0) < p; }
  Vector3d unit() {
    std::normal_distribution<double> n(0.0, 1.0);
    Vector3d v;
    do {
      v = Vector3d(n(g), n(g), n(g));
    } while (v.norm() < 1e-6);
    return v.normalized();
  }
  Vector3d inBox(double h) { return Vector3d(uni(-h, h), uni(-h, h), uni(-h, h)); }
  Quaterniond quat() {
    std::normal_distribution<double> n(0.0, 1.0);
    Quaterniond q(n(g), n(g), n(g), n(g));
    return q.normalized();
  }
};

inline vadop::Shape randomMesh(Rng& r) {
  std::vector<Vector3d> v;
  std::vector<std::array<int, 3>> t;
  const double R = r.logu(0.05, 0.6);
  const int kind = r.integer(0, 2);
  if (kind == 0) {
    // Star-shaped, non-convex closed surface: a UV sphere with random radii per vertex.
    const int rings = r.integer(2, 4), segs = r.integer(4, 7);
    v.emplace_back(0, 0, R * r.uni(0.55, 1.0));
    v.emplace_back(0, 0, -R * r.uni(0.55, 1.0));
    for (int i = 1; i <= rings; ++i) {
      const double th = M_PI * i / (rings + 1);
      for (int j = 0; j < segs; ++j) {
        const double ph = 2 * M_PI * j / segs;
        const double rr = R * r.uni(0.55, 1.0);
        v.emplace_back(rr * std::sin(th) * std::cos(ph), rr * std::sin(th) * std::sin(ph), rr * std::cos(th));
      }
    }
    auto id = [&](int ring, int seg) { return 2 + (ring - 1) * segs + (seg % segs); };
    for (int j = 0; j < segs; ++j) {
      t.push_back({0, id(1, j), id(1, j + 1)});
      t.push_back({1, id(rings, j + 1), id(rings, j)});
      for (int i = 1; i < rings; ++i) {
        t.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        t.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  } else if (kind == 1) {
    // Triangle soup.
    const int k = r.integer(2, 10);
    for (int i = 0; i < k; ++i) {
      const Vector3d c = r.inBox(R);
      const double s = R * r.uni(0.2, 0.8);
      for (int c3 = 0; c3 < 3; ++c3) v.push_back(c + s * r.unit());
      t.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
  } else {
    // Open height field.
    const int g = r.integer(3, 5);
    for (int i = 0; i < g; ++i) {
      for (int j = 0; j < g; ++j) {
        v.emplace_back(R * (2.0 * i / (g - 1) - 1.0), R * (2.0 * j / (g - 1) - 1.0), R * r.uni(-0.3, 0.3));
      }
    }
    for (int i = 0; i + 1 < g; ++i) {
      for (int j = 0; j + 1 < g; ++j) {
        const int a = i * g + j, b = (i + 1) * g + j, c = (i + 1) * g + j + 1, d = i * g + j + 1;
        t.push_back({a, b, c});
        t.push_back({a, c, d});
      }
    }
  }
  const Vector3d off = r.chance(0.5) ? Vector3d(r.inBox(0.3 * R)) : Vector3d::Zero();
  for (auto& x : v) x += off;
  return vadop::makeMesh(v, t);
}

inline vadop::Shape randomShape(vadop::ShapeType type, Rng& r) {
  vadop::Shape s;
  switch (type) {
    case vadop::ShapeType::kSphere: s = vadop::makeSphere(r.logu(0.01, 0.5)); break;
    case vadop::ShapeType::kBox: {
      Vector3d size(r.logu(0.01, 1.0), r.logu(0.01, 1.0), r.logu(0.01, 1.0));
      if (r.chance(0.15)) size[r.integer(0, 2)] = r.logu(0.001, 0.005);  // thin plate
      s = vadop::makeBox(size);
      break;
    }
    case vadop::ShapeType::kCapsule:
      s = vadop::makeCapsule(r.logu(0.01, 0.3), r.chance(0.1) ? 0.0 : r.logu(0.01, 1.0));
      break;
    case vadop::ShapeType::kCylinder: s = vadop::makeCylinder(r.logu(0.01, 0.5), r.logu(0.005, 1.0)); break;
    case vadop::ShapeType::kConvex: {
      const Vector3d axes(r.logu(0.02, 0.5), r.logu(0.02, 0.5), r.logu(0.02, 0.5));
      const Quaterniond q = r.quat();
      std::vector<Vector3d> pts;
      const int n = r.integer(4, 14);
      for (int i = 0; i < n; ++i) pts.push_back(q * r.unit().cwiseProduct(axes));
      const int interior = r.integer(0, 3);
      for (int i = 0; i < interior; ++i) pts.push_back(q * (r.uni(0.0, 0.9) * r.unit().cwiseProduct(axes)));
      const Vector3d off = r.chance(0.5) ? Vector3d(r.inBox(0.5 * axes.maxCoeff())) : Vector3d::Zero();
      for (auto& p : pts) p += off;
      s = vadop::makeConvex(pts);
      break;
    }
    case vadop::ShapeType::kMesh: s = randomMesh(r); break;
  }
  if (r.chance(0.3)) s = vadop::inflate(s, r.logu(0.001, 0.1));
  return s;
}

struct Options {
  bool rotating = false;
  double tolerance = 1e-6;
  double graze_fraction = 0.35;
};

// Closest approach of the scene over its window, by the truth: sampled then refined by
// golden section (a construction aid only; the verdicts come from Truth::classify).
inline void closestApproach(const toi_truth::Scene& sc, double* t_min, double* gap, Vector3d* normal) {
  toi_truth::Truth tr(sc);
  const int N = 48;
  double best = toi_truth::kInf;
  int bi = 0;
  for (int i = 0; i <= N; ++i) {
    const double t = sc.t0 + (sc.t1 - sc.t0) * i / N;
    const double h = tr.eval(t)->hi;
    if (h < best) {
      best = h;
      bi = i;
    }
  }
  double a = sc.t0 + (sc.t1 - sc.t0) * std::max(0, bi - 1) / N;
  double b = sc.t0 + (sc.t1 - sc.t0) * std::min(N, bi + 1) / N;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = tr.eval(c)->hi, fd = tr.eval(d)->hi;
  for (int it = 0; it < 40; ++it) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = tr.eval(c)->hi;
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = tr.eval(d)->hi;
    }
  }
  *t_min = 0.5 * (a + b);
  auto e = tr.eval(*t_min);
  *gap = e->hi;
  *normal = e->best >= 0 ? e->rec[e->best].n : Vector3d::UnitX();
}

inline toi_truth::Scene randomScene(vadop::ShapeType ta, vadop::ShapeType tb, const Options& o, Rng& r) {
  toi_truth::Scene sc;
  sc.shape_a = randomShape(ta, r);
  sc.shape_b = randomShape(tb, r);
  const double la = sc.shape_a.bounding_radius, lb = sc.shape_b.bounding_radius;
  sc.t0 = r.uni(-1.0, 1.0);
  const double T = r.chance(0.05) ? r.logu(1e-3, 0.05) : r.uni(0.2, 2.0);
  sc.t1 = sc.t0 + T;
  // Positions at t0: b at a distance from a along a random direction.
  const Vector3d pa0 = r.inBox(1.0);
  const Vector3d dir = r.unit();
  const double D = r.chance(0.05) ? r.uni(0.0, 1.0) * (la + lb) : (la + lb) * r.uni(1.02, 3.0) + r.uni(0.0, 1.0);
  const Vector3d pb0 = pa0 + D * dir;
  // Relative velocity: b's origin passes a's origin at an impact parameter, at a time in
  // (or after) the window.
  Vector3d perp = dir.cross(r.unit());
  perp = perp.norm() > 1e-9 ? Vector3d(perp.normalized()) : Vector3d(dir.unitOrthogonal());
  const double impact = (la + lb) * r.uni(0.0, 1.3);
  // The pass at most 5 km/s fast (the library refuses speeds beyond 10 km/s: a millisecond
  // window with bodies metres apart asked for 14 km/s once in 2,000 cases).
  const Vector3d offset = (impact * perp) - D * dir;
  const double when = std::max(T * r.uni(0.2, 1.4), offset.norm() / 5000.0);
  const Vector3d vrel = offset / when;
  const Vector3d va = r.unit() * r.uni(0.0, 2.0);
  const Vector3d vb = va + vrel;
  Vector3d wa = Vector3d::Zero(), wb = Vector3d::Zero();
  if (o.rotating) {
    wa = r.chance(0.1) ? Vector3d::Zero() : Vector3d(r.unit() * r.logu(0.05, 8.0));
    wb = r.chance(0.1) ? Vector3d::Zero() : Vector3d(r.unit() * r.logu(0.05, 8.0));
  }
  const double ta_ref = r.uni(sc.t0 - 1.0, sc.t1 + 1.0);
  const double tb_ref = r.chance(0.5) ? ta_ref : r.uni(sc.t0 - 1.0, sc.t1 + 1.0);
  sc.ma = vadop::makeMotion(pa0 - va * (sc.t0 - ta_ref), r.quat(), va, wa, ta_ref);
  sc.mb = vadop::makeMotion(pb0 - vb * (sc.t0 - tb_ref), r.quat(), vb, wb, tb_ref);
  if (o.rotating) {
    // Some bodies turn about a pivot off their origin (a link of a turning robot, a vehicle on
    // a curve): their origins move on arcs.
    if (r.chance(0.3)) sc.ma.pivot_offset = r.unit() * r.uni(0.0, 2.0);
    if (r.chance(0.3)) sc.mb.pivot_offset = r.unit() * r.uni(0.0, 2.0);
  }
  if (r.chance(o.graze_fraction)) {
    double tm = 0.0, g = 0.0;
    Vector3d n;
    closestApproach(sc, &tm, &g, &n);
    if (g > 0.0 && std::isfinite(g)) {
      const double tol = o.tolerance;
      double eps;
      const int k = r.integer(0, 4);
      if (k == 0) eps = 0.0;
      else if (k == 1) eps = r.uni(-2.0 * tol, 3.0 * tol);
      else if (k == 2) eps = r.uni(0.3 * tol, 1.2 * tol);
      else if (k == 3) eps = -r.logu(1e-9, 1e-3);
      else eps = r.logu(1e-9, 1e-3);
      sc.mb.position -= (g - eps) * n;
    }
  }
  return sc;
}

}  // namespace toi_scenes
