// Static distance between two posed shapes, the geometric layer under the time of impact
// (time_of_impact.h). Our own GJK on the shapes' cores, not FCL: every answer carries a
// certified lower bound (a separating plane evaluated with exact support functions), which
// is what makes conservative advancement unable to step over a contact.
//
// Cores and rounding. A sphere is a point core with rounding radius r, a capsule a segment
// core with rounding r; every shape adds its `margin` to the rounding. Box, cylinder and
// convex point set have solid cores; a mesh is a set of triangle cores (a triangle soup,
// treated as a surface: a body wholly inside a closed mesh does not touch it, as in FCL).
// gap = distance between the cores - rounding_a - rounding_b.
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <memory>

namespace vadop {

namespace detail {
struct PreparedShapeData;
}  // namespace detail

// A Shape with what the narrow phase precomputes: the core/rounding split and, for a mesh,
// a sphere tree over its triangles. Build it once per shape and reuse it when the same mesh
// is queried many times (the Shape overloads build one on every call: O(n log n) for a mesh
// of n triangles, negligible for primitives). Immutable; copies share the data.
class PreparedShape {
 public:
  // Validates the shape (validateShape); throws vadop::InvalidArgument.
  explicit PreparedShape(const Shape& shape);

  const Shape& shape() const;
  const detail::PreparedShapeData& data() const { return *data_; }

 private:
  std::shared_ptr<const detail::PreparedShapeData> data_;
};

struct DistanceOptions {
  // The query stops when upper - lower bound of the gap <= max(tolerance, relative_tolerance * gap).
  double tolerance = 1e-9;            // m
  double relative_tolerance = 1e-9;
  int max_iterations = 128;           // GJK iterations (per triangle pair for meshes)
};

struct DistanceResult {
  // Gap between the padded shapes. Separated: |point_b - point_a| up to rounding (an upper
  // bound of the true gap, within the tolerance of it). Cores overlapping: an estimate of minus the penetration
  // depth (a lower bound of the signed distance along `normal`).
  double distance = 0.0;
  // Certified: the true signed gap is >= lower_bound (the separation of the shapes along a
  // direction at most the query's angular accuracy from `normal`, computed with exact
  // support functions).
  double lower_bound = 0.0;
  // The cores intersect: `distance` is then only a penetration estimate.
  bool cores_overlap = false;
  Eigen::Vector3d point_a = Eigen::Vector3d::Zero();  // witness on a's padded surface (fixed frame)
  Eigen::Vector3d point_b = Eigen::Vector3d::Zero();  // witness on b's padded surface
  // Unit, from a to b: the separating direction (or, when overlapping, the estimated
  // direction in which b should move to separate).
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  int iterations = 0;
};

// Throws vadop::InvalidArgument on invalid shapes, non-finite poses or options.
DistanceResult distance(const Shape& a, const Eigen::Isometry3d& pose_a, const Shape& b,
                        const Eigen::Isometry3d& pose_b, const DistanceOptions& options = {});
DistanceResult distance(const PreparedShape& a, const Eigen::Isometry3d& pose_a,
                        const PreparedShape& b, const Eigen::Isometry3d& pose_b,
                        const DistanceOptions& options = {});

namespace detail {

// One step of conservative advancement, used by timeOfImpact. At time t:
//  - touching: the gap at t is <= touch_gap (closest holds the contact);
//  - otherwise `step` in [0, horizon] is certified: gap(t') > advance_gap for every
//    t' in [t, t + step); clear = true when that holds up to t + horizon (inclusive).
// The certificate: for a separating direction n at t (per triangle pair for meshes, after a
// bounding-ball screen), the separation along n -- n fixed in the world, or turning with a,
// or with b -- is bounded below for all later times by concave functions of the elapsed
// time (exact for translation; first order exact and a Taylor remainder bound for rotation)
// and by a linear one (|w x n| times the lever arm); step is where the best bound reaches
// advance_gap. See separationStep in distance.cpp for the formulas.
struct AdvanceStep {
  bool touching = false;
  bool clear = false;
  double step = 0.0;
  DistanceResult closest;  // at t
};

// Requires 0 <= advance_gap < touch_gap. `hint` (may be null) carries a warm-start
// direction from one call to the next for convex pairs.
AdvanceStep advanceStep(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                        const Motion& mb, double t, double horizon, double touch_gap,
                        double advance_gap, Eigen::Vector3d* hint);

// The swept-volume certificate, used by timeOfImpact where rotation limits the steps above.
// Over [ta, tb] (ta <= tb) each body lies in a convex set: a turning body in its revolution
// hull -- the cylinder about the axis of its angular velocity through its pivot at ta, whose
// radius is the largest distance of its core from that axis and whose axial extent is the
// core's support along +-axis (both unchanged by the turning), rounded by the shape's rounding
// radius -- Minkowski-summed with the pivot's displacement over [ta, tb]; a body that does not
// turn in its posed shape (a mesh: the convex hull of its vertices) summed with its
// displacement; a body that turns by at most 0.5 rad over [ta, tb], in its shape posed at ta
// and grown by that angle times its largest distance from the pivot, plus the displacement.
// lower_bound is a certified lower bound of the gap between the two sets (the
// separation along a GJK direction, computed with exact support functions, less a rounding
// allowance), hence of the gap between the bodies at every t in [ta, tb]; -inf when the sets
// overlap. The GJK may stop as soon as the bound exceeds stop_above (+inf: run to accuracy).
struct SweptBound {
  double lower_bound = 0.0;
  int iterations = 0;  // GJK iterations
};
SweptBound sweptLowerBound(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                           const Motion& mb, double ta, double tb, double stop_above);

}  // namespace detail
}  // namespace vadop
