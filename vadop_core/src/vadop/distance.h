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
  // Validates the shape (validateShape); throws vadop::InvalidArgument. A large mesh's or point
  // set's tree is built on up to `threads` threads (0: one per hardware thread).
  explicit PreparedShape(const Shape& shape, int threads = 1);

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

}  // namespace vadop
