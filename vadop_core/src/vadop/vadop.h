// The velocity-aligned discrete oriented polytope of one body over one frame: which pool
// axes the body uses (those nearly orthogonal to its velocity) and, on each, an interval
// bounding the projection of everything the body occupies during [t0, t1].
// It does not sort or pair anything: see sweep_prune.h.
#pragma once

#include "vadop/axis_pool.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/world.h"  // VadopConfig, SlowAxisRule: the public configuration

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

namespace vadop {

struct Interval {
  double lo = 0.0;
  double hi = 0.0;
};

// Validates the configuration against the pool. Throws vadop::InvalidArgument when a field is
// out of range or phi < rho (two bodies' zones could then share no axis, and the broad phase
// would have to pair them blindly). Returns phi in radians (rho when phi_deg == 0).
double validateVadopConfig(const VadopConfig& config, const AxisPool& pool);

// The pool of `axes` axes, for the engines built on it. Throws vadop::InvalidArgument
// ("axes must be in [3, 4096], got ...") when the count is out of range.
std::unique_ptr<AxisPool> makeAxisPool(int axes);

// Axis selection for the body's direction u (its velocity, or slow_direction when slow):
// `previous` itself while it contains every pool axis a with |u . a| <= sin(phi) and none
// beyond phi + hysteresis; else the axes within phi + hysteresis / 2. Sorted ascending.
// Every set returned contains the full phi zone of u, hence (rho <= phi) any two bodies
// share an axis close to u1 x u2.
std::vector<uint32_t> selectAxes(const Motion& motion, double bounding_radius, double frame_length,
                                 const AxisPool& pool, const VadopConfig& config, double phi_rad,
                                 const std::vector<uint32_t>& previous = {});
// The direction a body's axes are chosen about: its velocity's, or for a slow body
// slow_direction (zero under SlowAxisRule::kAllAxes: every axis). The set updateAxes returns
// for a direction is the one it keeps for that same direction (it holds the zone and nothing
// beyond the hysteresis), so a caller may skip bodies whose direction did not change.
Eigen::Vector3d axisSelectionDirection(const Motion& motion, double bounding_radius, double frame_length,
                              const VadopConfig& config);
// The same in place, for the per-frame loops: `axes` holds the previous set and receives the
// new one (its storage reused); returns whether it changed. `zones` = axisZones(config, phi).
struct AxisZones {
  double in_zone, keep_zone, fresh_zone;  // sines of phi, phi + hysteresis, phi + hysteresis / 2
};
AxisZones axisZones(const VadopConfig& config, double phi_rad);
bool updateAxes(const Motion& motion, double bounding_radius, double frame_length, const AxisPool& pool,
                const VadopConfig& config, const AxisZones& zones, std::vector<uint32_t>& axes);

// Interval on a unit axis bounding the projection of the shape moving with `motion` over
// [t0, t1]: the support along the axis at the mid-frame orientation, plus the linear
// displacement, plus a bound on how far rotation moves any point along the axis. Slightly
// widened for rounding, so that it is conservative in floating point.
Interval sweptInterval(const Shape& shape, const Motion& motion, double t0, double t1,
                       const Eigen::Vector3d& axis);

// The same, with the per-body work (mid-frame rotation, end positions) done once for the
// many axes of one body.
class SweptBody {
 public:
  SweptBody(const Shape& shape, const Motion& motion, double t0, double t1);
  Interval project(const Eigen::Vector3d& axis) const {
    // A sphere that only translates (the common case of the broad phase's per-frame pass):
    // the general formula below with zero shift and rotation terms, inline.
    if (translating_sphere_) return widened(std::min(axis.dot(p0_), axis.dot(p1_)) - radius_,
                                            std::max(axis.dot(p0_), axis.dot(p1_)) + radius_);
    return projectGeneral(axis);
  }
  // The boxes of `parts` consecutive parts of [t0, t1] (part k ends at t0 + (t1 - t0) (k + 1) /
  // parts, the last at t1), 6 doubles each as box(): the bounds of one SweptBody per part, the
  // parts' mid-frame rotations stepped by one turn increment instead of evaluated one by one;
  // for a body turning by at most kEndsMaxTurn a part, the boxes of its shape at the parts'
  // ends grown by its curvature (partBoxesFromEnds: tighter for a vehicle over a time slice).
  static void partBoxes(const Shape& shape, const Motion& motion, double t0, double t1, int parts, double* out);
  // Up to this turn a part (rad), the end boxes' growth |w|^2 rho h^2 / 8 stays under a quarter
  // of the chord bound's |w| rho h / 2.
  static constexpr double kEndsMaxTurn = 1.0;
  // Where part k (from 0) of those parts ends.
  static double partEnd(double t0, double t1, int k, int parts) {
    return k + 1 == parts ? t1 : t0 + (t1 - t0) * (k + 1) / parts;
  }
  // Its axis-aligned box: the intervals on x, y, z as (lo x y z, hi x y z).
  void box(double* out) const {
    if (!translating_sphere_) return boxGeneral(out);
    for (int k = 0; k < 3; ++k) {
      const Interval iv = project(Eigen::Vector3d::Unit(k));
      out[k] = iv.lo;
      out[3 + k] = iv.hi;
    }
  }

  // Relative widening of every interval: the support and dot products are accurate to a few
  // ulps of the magnitudes involved; 1e-12 of them is far above that and far below any length
  // a user cares about.
  static constexpr double kRoundingWiden = 1e-12;

 private:
  static Interval widened(double lo, double hi) {
    const double widen = kRoundingWiden * (1.0 + std::max(std::abs(lo), std::abs(hi)));
    return Interval{lo - widen, hi + widen};
  }
  // The interval on one axis: the pivot's ends c0, c1 on it, the shape's support up and down
  // from the pivot at mid-frame, and `rot`, how far rotation moves a point along it.
  static Interval axisBounds(double c0, double c1, double up, double down, double rot) {
    return widened(std::min(c0, c1) - down - rot, std::max(c0, c1) + up + rot);
  }
  // `rot` on the coordinate axis e_k: |e_k x w_hat| is the norm of the spin axis's other two
  // components.
  static double rotationReach(double core_radius, double chord, const Eigen::Vector3d& spin_axis, int k) {
    if (!(chord > 0.0)) return 0.0;
    const double i = spin_axis[(k + 1) % 3], j = spin_axis[(k + 2) % 3];
    return core_radius * chord * std::sqrt(i * i + j * j);
  }
  Interval projectGeneral(const Eigen::Vector3d& axis) const;
  // projectGeneral on x, y and z, the products with the unit axes written out (the same values).
  void boxGeneral(double* out) const;
  // The box of a shape whose extents along the coordinate axes are up[k], down[k] (axisExtents
  // in vadop.cpp: the shape turned by R(t_mid)), its pivot going from p0 to p1, `shift` =
  // origin - pivot at mid-frame, rot[k] = rotation's reach along axis k: boxGeneral's and each
  // part's of partBoxes.
  static void boxOf(const double* up, const double* down, const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                    const Eigen::Vector3d& shift, const double* rot, double* out);
  // partBoxes for a turning body (|w| > 0) from its boxes at the parts' ends.
  static void partBoxesFromEnds(const Shape& shape, const Motion& motion, double t0, double t1, int parts, double* out);
  // The fields that do not depend on the window (shape, radii, spin axis); returns |w|.
  double setBody(const Shape& shape, const Motion& motion);

  bool translating_sphere_ = false;  // sphere, no pivot, no rotation
  double radius_ = 0.0;              // radius + margin, when translating_sphere_
  const Shape* shape_ = nullptr;
  Eigen::Matrix3d rotation_mid_t_;  // R(t_mid)^T: fixed frame -> body frame
  Eigen::Vector3d p0_, p1_;         // pivot (the body origin unless Motion::pivot_offset) at t0, t1
  Eigen::Vector3d shift_mid_;       // body origin - pivot at t_mid
  Eigen::Vector3d spin_axis_;       // unit angular velocity direction (zero if not rotating)
  double chord_ = 0.0;              // bound on how far a point at unit radius moves, from t_mid
  double core_radius_ = 0.0;        // farthest core point from the pivot (margin excluded)
};

inline bool overlaps(const Interval& a, const Interval& b) { return a.lo <= b.hi && b.lo <= a.hi; }

}  // namespace vadop
