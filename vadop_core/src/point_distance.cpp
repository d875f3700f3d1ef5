#include "vadop/point_distance.h"

#include "vadop/distance.h"
#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace vadop {
namespace {

// The point is a sphere's core (a point) rounded by this radius; distance() subtracts the
// rounding analytically, so adding it back is exact up to one rounding of a double.
constexpr double kPointRadius = 1e-3;
constexpr double kFineTolerance = 1e-10;  // m: gap()'s

}  // namespace

PointDistance::PointDistance(const Shape& shape)
    : shape_(std::make_shared<const PreparedShape>(shape)),
      point_(std::make_shared<const PreparedShape>(makeSphere(kPointRadius))) {}

const Shape& PointDistance::shape() const { return shape_->shape(); }

void PointDistance::bounds(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double tolerance, double& lower,
                           double& upper) const {
  if (!p.allFinite()) throw InvalidArgument("point is not finite");
  Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
  at.translation() = p;
  DistanceOptions options;
  options.tolerance = tolerance;
  options.relative_tolerance = 0.0;
  const DistanceResult r = distance(*shape_, pose, *point_, at, options);
  upper = r.distance + kPointRadius;
  lower = r.cores_overlap ? -std::numeric_limits<double>::infinity() : r.lower_bound + kPointRadius;
  if (r.cores_overlap) upper = std::min(upper, 0.0);
}

double PointDistance::gap(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p) const {
  double lower = 0.0, upper = 0.0;
  bounds(pose, p, kFineTolerance, lower, upper);
  return upper;
}

bool PointDistance::within(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double margin) const {
  double lower = 0.0, upper = 0.0;
  if (margin > 4.0 * kFineTolerance) {
    bounds(pose, p, 0.25 * margin, lower, upper);
    if (upper <= margin) return true;
    if (lower > margin) return false;
  }
  return gap(pose, p) <= margin;
}

}  // namespace vadop
