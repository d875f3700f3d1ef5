// GJK (Gilbert-Johnson-Keerthi) on two convex sets given by their support mappings: the
// distance between their cores with the closest points, the best certified lower bound met,
// the final simplex (for the penetration direction and warm starts), or overlap. It does not
// add the roundings nor certify the answer (convex_distance.h, swept_volume.h do, with
// separation() along the directions it finds), and does not handle meshes (mesh_queries.h).
// Internal to the library (not installed).
#pragma once

#include "shape_core.h"

#include <Eigen/Core>

#include <limits>

namespace vadop {
namespace detail {

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

// The GJK's stopping rule: |v| - lower <= max(abs_tol, rel_tol * gap), or max_iter iterations.
struct Tolerances {
  double abs_tol;
  double rel_tol;
  int max_iter;
};

// CA, CB: Convex or Swept (support(d), origin(), p, lever; instantiated for these two in
// gjk.cpp). Stops early once the certified
// lower bound of the core distance exceeds stop_above.
// `seed` (seed_n <= 3 points of A - B, e.g. the last simplex of the pair re-posed): the start
// instead of the support along -guess.
template <class CA, class CB>
Gjk runGjk(const CA& A, const CB& B, Eigen::Vector3d guess, double abs_tol, double rel_tol, int max_iter,
           double stop_above = kInf, const SVert* seed = nullptr, int seed_n = 0);

}  // namespace detail
}  // namespace vadop
