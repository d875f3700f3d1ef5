#include "vadop/point_distance.h"

#include "vadop/distance.h"
#include "vadop/error.h"

#include <cmath>
#include <string>

namespace vadop {
namespace {

// The point is a sphere's core (a point) rounded by this radius; distance() subtracts the
// rounding analytically, so adding it back is exact up to one rounding of a double.
constexpr double kPointRadius = 1e-3;

}  // namespace

PointDistance::PointDistance(const Shape& shape)
    : shape_(std::make_shared<const PreparedShape>(shape)),
      point_(std::make_shared<const PreparedShape>(makeSphere(kPointRadius))) {}

const Shape& PointDistance::shape() const { return shape_->shape(); }

double PointDistance::gap(const Eigen::Isometry3d& pose, const Eigen::Vector3d& p) const {
  if (!p.allFinite()) throw InvalidArgument("point is not finite");
  Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
  at.translation() = p;
  DistanceOptions options;
  options.tolerance = 1e-10;
  options.relative_tolerance = 0.0;
  return distance(*shape_, pose, *point_, at, options).distance + kPointRadius;
}

}  // namespace vadop
