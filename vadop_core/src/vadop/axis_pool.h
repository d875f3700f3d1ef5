// The pool of projection axes shared by every VADOP: m unit directions spread over the
// sphere so that the worst-covered direction (the covering radius rho) is as close to the
// axis as the best known coverings allow. Antipodal directions are one axis. It does not
// choose which axes a body uses: see vadop.h.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace vadop {

class AxisPool {
 public:
  // Deterministic for a given m. m = 3 gives the coordinate axes (rho = 54.7356 degrees).
  // Throws vadop::InvalidArgument when m < 3 or m > kMaxAxes.
  explicit AxisPool(int m);

  static constexpr int kMaxAxes = 4096;

  int size() const { return static_cast<int>(axes_.size()); }
  const Eigen::Vector3d& axis(int k) const { return axes_[k]; }
  const std::vector<Eigen::Vector3d>& axes() const { return axes_; }

  // Covering radius in radians: the largest angle from any unit direction to its nearest
  // pool axis (or that axis' antipode). Computed exactly from the spherical Delaunay
  // triangulation (convex hull) of the 2m points +-a_k.
  double coveringRadius() const { return rho_; }

 private:
  std::vector<Eigen::Vector3d> axes_;  // unit, each in the upper half-space (z > 0, or on its rim)
  double rho_ = 0.0;
};

// Exact covering radius (radians) of an arbitrary set of axes, antipodes included.
// Throws vadop::InvalidArgument when fewer than 3 axes are given, any is not finite or zero.
double coveringRadius(const std::vector<Eigen::Vector3d>& axes);

}  // namespace vadop
