// The convex set a body stays in over a time interval (its swept volume: revolution hull,
// or posed core grown by a small turn, summed with the pivot's displacement), with the
// support mapping the GJK needs and the exact support value the certificate needs. Used by
// sweptLowerBound (declared in advance_step.h, defined in swept_volume.cpp: the GJK on two
// of these sets). Internal to the library (not installed).
#pragma once

#include "shape_core.h"

#include "vadop/motion.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace vadop {
namespace detail {

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

Swept sweptVolume(const PreparedShapeData& d, const Motion& m, double ta, double tb);

}  // namespace detail
}  // namespace vadop
