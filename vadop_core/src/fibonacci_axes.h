// The baseline the axis-pool tests compare with: m axes from a plain Fibonacci (golden-angle)
// lattice on the upper hemisphere, unoptimised. Internal (not installed); defined in
// axis_pool.cpp, whose optimised pools start from it.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace vadop {

// Throws vadop::InvalidArgument for m <= 0.
std::vector<Eigen::Vector3d> fibonacciAxes(int m);

}  // namespace vadop
