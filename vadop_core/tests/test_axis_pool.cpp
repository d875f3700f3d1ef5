// Tests of the axis pool and of the exact covering radius. The covering radius is checked
// against analytic configurations, against an independent brute force that is exact (every
// Voronoi vertex is the circumcentre of some three points), against dense random sampling
// (which can only underestimate), and against Fejes Toth's lower bound, which no covering
// can beat. Pool quality is compared with the golden-angle baseline and the hexagonal bound.

#include "vadop/axis_pool.h"
#include "fibonacci_axes.h"  // internal (vadop_core/src)

#include "vadop/error.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace {

using vadop::AxisPool;
using vadop::coveringRadius;
using vadop::fibonacciAxes;
using Vec3 = Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

double degrees(double radians) { return radians * 180.0 / kPi; }

// Angle from direction d (unit) to the nearest of +-axes (unit).
double angleToNearestAxis(const Vec3& d, const std::vector<Vec3>& unitAxes) {
  double best = 0.0;
  for (const Vec3& a : unitAxes) best = std::max(best, std::fabs(d.dot(a)));
  return std::acos(std::min(1.0, best));
}

std::vector<Vec3> normalised(const std::vector<Vec3>& axes) {
  std::vector<Vec3> unit;
  for (const Vec3& a : axes) unit.push_back(a.normalized());
  return unit;
}

// Exact by brute force, independently of the hull: the farthest direction from a point set is
// a Voronoi vertex, i.e. the circumcentre of three of the points; every candidate's distance to
// its nearest point is at most the covering radius, so the largest one is the covering radius.
double bruteForceCoveringRadius(const std::vector<Vec3>& axes) {
  std::vector<Vec3> unit = normalised(axes);
  std::vector<Vec3> points;
  for (const Vec3& a : unit) {
    points.push_back(a);
    points.push_back(-a);
  }
  double rho = 0.0;
  const size_t n = points.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      for (size_t k = j + 1; k < n; ++k) {
        Vec3 c = (points[j] - points[i]).cross(points[k] - points[i]);
        if (c.norm() < 1e-12) continue;  // a point and its antipode twice, or duplicates
        c.normalize();
        rho = std::max(rho, angleToNearestAxis(c, unit));  // the antipode -c gives the same
      }
  return rho;
}

// Rigorous lower bound on the covering radius of N points on the sphere (L. Fejes Toth):
// cos(rho) <= cot(N pi / (6 (N - 2))) / sqrt(3). Tight for N = 6 and N = 12.
double fejesTothBound(int points) {
  const double n = points;
  return std::acos(1.0 / std::tan(n * kPi / (6.0 * (n - 2.0))) / std::sqrt(3.0));
}

// The covering radius m axes would have if each of the 2m points owned a regular hexagon of
// the sphere's area (planar hexagonal covering; the asymptotic optimum for large m).
double hexagonalBound(int m) {
  return std::sqrt((4.0 * kPi / (2.0 * m)) / (3.0 * std::sqrt(3.0) / 2.0));
}

std::vector<Vec3> icosahedronAxes() {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  return {Vec3(0, 1, phi), Vec3(0, -1, phi), Vec3(1, phi, 0),
          Vec3(-1, phi, 0), Vec3(phi, 0, 1), Vec3(phi, 0, -1)};
}

std::vector<Vec3> randomAxes(int m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<Vec3> axes(m);
  for (Vec3& a : axes) a = Vec3(normal(rng), normal(rng), normal(rng));
  return axes;
}

bool upperHalfRule(const Vec3& a) {
  return a.z() > 0.0 || (a.z() == 0.0 && (a.y() > 0.0 || (a.y() == 0.0 && a.x() > 0.0)));
}

std::vector<int> spreadOfSizes() {
  std::vector<int> sizes;
  for (int m = 3; m <= 40; ++m) sizes.push_back(m);
  for (int m : {50, 64, 100, 130, 200, 500, 1000, 2000}) sizes.push_back(m);
  return sizes;
}

// Pools are built once per size and shared by the tests (the large ones take a while).
const AxisPool& pool(int m) {
  static std::map<int, AxisPool> built;
  auto found = built.find(m);
  if (found == built.end()) found = built.emplace(m, AxisPool(m)).first;
  return found->second;
}

template <typename F>
std::string invalidArgumentMessage(F&& f) {
  try {
    f();
  } catch (const vadop::InvalidArgument& e) {
    return e.what();
  }
  return "<no vadop::InvalidArgument thrown>";
}

// --- coveringRadius ----------------------------------------------------------------------

TEST(CoveringRadius, CoordinateAxesAreTheOctahedron) {
  const std::vector<Vec3> axes = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  EXPECT_NEAR(coveringRadius(axes), std::acos(1.0 / std::sqrt(3.0)), 1e-12);
}

TEST(CoveringRadius, IcosahedronIsVertexToFaceCentreAngle) {
  // 6 axes through the 12 vertices. The deepest holes are the 20 face centres; face
  // (0, 1, phi), (0, -1, phi), (phi, 0, 1) has centroid direction (phi, 0, 2 phi + 1).
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  const Vec3 vertex(0, 1, phi), centroid(phi, 0, 2 * phi + 1);
  const double expected = std::acos(vertex.normalized().dot(centroid.normalized()));
  EXPECT_NEAR(expected, std::acos(std::sqrt((5.0 + 2.0 * std::sqrt(5.0)) / 15.0)), 1e-14);
  EXPECT_NEAR(degrees(expected), 37.3774, 1e-4);
  const double rho = coveringRadius(icosahedronAxes());
  EXPECT_NEAR(rho, expected, 1e-12);
  EXPECT_NEAR(rho, fejesTothBound(12), 1e-12);  // the icosahedron is the optimal 12-covering
}

TEST(CoveringRadius, CubeDiagonalsReachFaceCentresAt54Degrees) {
  // The 8 cube vertices are 4 axes; every face is 4 cocircular points (a tie the hull must
  // handle), and its centre direction (1, 0, 0) is acos(1/sqrt 3) from the nearest diagonal.
  const std::vector<Vec3> axes = {Vec3(1, 1, 1), Vec3(-1, 1, 1), Vec3(1, -1, 1), Vec3(-1, -1, 1)};
  const double expected = std::acos(Vec3(1, 1, 1).normalized().dot(Vec3::UnitX()));
  EXPECT_NEAR(degrees(expected), 54.7356, 1e-4);
  EXPECT_NEAR(coveringRadius(axes), expected, 1e-12);
}

TEST(CoveringRadius, HexagonalBipyramid) {
  // The z axis and three equatorial axes 60 degrees apart: the hole above the middle of two
  // neighbouring equatorial points at elevation e is equidistant from the pole (90 - e) and
  // from them (cos d = cos e cos 30), so tan e = cos 30.
  const std::vector<Vec3> axes = {Vec3::UnitZ(), Vec3(1, 0, 0), Vec3(0.5, std::sqrt(3.0) / 2, 0),
                                  Vec3(-0.5, std::sqrt(3.0) / 2, 0)};
  EXPECT_NEAR(coveringRadius(axes), kPi / 2 - std::atan(std::cos(kPi / 6)), 1e-12);
}

TEST(CoveringRadius, IndependentOfScaleSignOrderRotationAndDuplicates) {
  const std::vector<Vec3> base = icosahedronAxes();
  const double rho = coveringRadius(base);
  std::vector<Vec3> changed;
  for (size_t k = 0; k < base.size(); ++k) changed.push_back((k % 2 ? -3.5 : 1e-3) * base[k]);
  std::reverse(changed.begin(), changed.end());
  changed.push_back(-7.0 * base[2]);  // the same axis again
  changed.push_back(base[4]);
  EXPECT_NEAR(coveringRadius(changed), rho, 1e-12);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Vec3(0.3, -1.0, 2.0).normalized()).toRotationMatrix();
  std::vector<Vec3> rotated;
  for (const Vec3& a : base) rotated.push_back(rotation * a);
  EXPECT_NEAR(coveringRadius(rotated), rho, 1e-12);
}

TEST(CoveringRadius, AxesOnOneGreatCircleGiveNinetyDegrees) {
  // The hull is flat; the normal of the circle is 90 degrees from every axis.
  std::vector<Vec3> axes;
  for (int k = 0; k < 7; ++k) axes.push_back(Vec3(std::cos(0.4 * k), std::sin(0.4 * k), 0.0));
  EXPECT_DOUBLE_EQ(coveringRadius(axes), kPi / 2);
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(0.9, Vec3(1, 1, 0).normalized()).toRotationMatrix();
  for (Vec3& a : axes) a = tilt * a;
  EXPECT_NEAR(coveringRadius(axes), kPi / 2, 1e-12);
  // Three axes, two of them the same: only two distinct axes.
  EXPECT_DOUBLE_EQ(coveringRadius({Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitX()}), kPi / 2);
}

TEST(CoveringRadius, MatchesExactBruteForce) {
  std::vector<std::vector<Vec3>> sets;
  for (int m : {3, 4, 5, 7, 10, 13, 20, 30}) {
    sets.push_back(fibonacciAxes(m));
    sets.push_back(randomAxes(m, 1000 + m));
  }
  for (int m : {4, 6, 9, 17, 25}) sets.push_back(pool(m).axes());
  for (const std::vector<Vec3>& axes : sets) {
    SCOPED_TRACE("m = " + std::to_string(axes.size()));
    EXPECT_NEAR(coveringRadius(axes), bruteForceCoveringRadius(axes), 1e-12);
  }
}

TEST(CoveringRadius, BoundsDenseRandomSampling) {
  // n uniform samples: the chance that none falls within delta of the farthest direction is
  // exp(-n (1 - cos delta) / 2) <= 1e-12 for the delta below, and the distance to the nearest
  // axis changes by at most the angle moved, so the sampled maximum lies in
  // [rho - delta, rho]. The upper side is the sharp check: sampling can never exceed rho.
  const int n = 200000;
  const double delta = std::acos(1.0 - 2.0 * std::log(1e12) / n);
  std::mt19937_64 rng(20080601);
  std::normal_distribution<double> normal;
  std::vector<Vec3> samples(n);
  for (Vec3& s : samples) s = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
  for (const std::vector<Vec3>& axes :
       {pool(200).axes(), fibonacciAxes(50), normalised(randomAxes(40, 7))}) {
    const double rho = coveringRadius(axes);
    double sampled = 0.0;
    for (const Vec3& s : samples) sampled = std::max(sampled, angleToNearestAxis(s, axes));
    SCOPED_TRACE("m = " + std::to_string(axes.size()));
    EXPECT_LE(sampled, rho + 1e-9);
    EXPECT_GE(sampled, rho - delta);
  }
}

TEST(CoveringRadius, NeverBelowFejesTothBound) {
  for (int m : {3, 4, 5, 8, 12, 20, 40, 90}) {
    EXPECT_GE(coveringRadius(fibonacciAxes(m)), fejesTothBound(2 * m)) << "m = " << m;
    EXPECT_GE(coveringRadius(randomAxes(m, 99 + m)), fejesTothBound(2 * m)) << "m = " << m;
  }
}

TEST(CoveringRadius, RejectsBadInput) {
  const std::vector<Vec3> good = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  EXPECT_NE(invalidArgumentMessage([&] { coveringRadius({Vec3::UnitX(), Vec3::UnitY()}); })
                .find("got 2"),
            std::string::npos);
  EXPECT_NE(invalidArgumentMessage([&] { coveringRadius({}); }).find("got 0"), std::string::npos);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Vec3& bad : {Vec3(nan, 0, 1), Vec3(0, inf, 0), Vec3(-inf, 1, 1)}) {
    std::vector<Vec3> axes = good;
    axes.insert(axes.begin() + 1, bad);
    const std::string what = invalidArgumentMessage([&] { coveringRadius(axes); });
    EXPECT_NE(what.find("axis 1 is not finite"), std::string::npos) << what;
  }
  std::vector<Vec3> withZero = good;
  withZero.push_back(Vec3::Zero());
  const std::string what = invalidArgumentMessage([&] { coveringRadius(withZero); });
  EXPECT_NE(what.find("axis 3 is the zero vector"), std::string::npos) << what;
  // Tiny and huge axes are fine: only the direction counts.
  EXPECT_NEAR(coveringRadius({1e-300 * Vec3::UnitX(), 1e300 * Vec3::UnitY(), Vec3::UnitZ()}),
              std::acos(1.0 / std::sqrt(3.0)), 1e-12);
}

// --- fibonacciAxes -------------------------------------------------------------------------

TEST(FibonacciAxes, UnitUpperHemisphere) {
  for (int m : {1, 3, 10, 257}) {
    const std::vector<Vec3> axes = fibonacciAxes(m);
    ASSERT_EQ(static_cast<int>(axes.size()), m);
    for (const Vec3& a : axes) {
      EXPECT_NEAR(a.norm(), 1.0, 1e-12);
      EXPECT_TRUE(upperHalfRule(a));
    }
  }
  EXPECT_THROW(fibonacciAxes(0), vadop::InvalidArgument);
}

// --- AxisPool -------------------------------------------------------------------------------

TEST(AxisPool, ThreeAxesAreTheCoordinateAxes) {
  const AxisPool& three = pool(3);
  ASSERT_EQ(three.size(), 3);
  EXPECT_EQ(three.axis(0), Vec3::UnitX());
  EXPECT_EQ(three.axis(1), Vec3::UnitY());
  EXPECT_EQ(three.axis(2), Vec3::UnitZ());
  EXPECT_NEAR(three.coveringRadius(), std::acos(1.0 / std::sqrt(3.0)), 1e-9);
}

TEST(AxisPool, SixAxesFindTheIcosahedron) {
  // Fejes Toth's bound is attained for 12 points, by the icosahedron only.
  EXPECT_NEAR(pool(6).coveringRadius(), fejesTothBound(12), 1e-9);
}

TEST(AxisPool, FourAxesMatchTheHexagonalBipyramid) {
  EXPECT_LE(pool(4).coveringRadius(), kPi / 2 - std::atan(std::cos(kPi / 6)) + 1e-9);
}

TEST(AxisPool, ValidDeterministicAndNoWorseThanBaselineAcrossSizes) {
  for (int m : spreadOfSizes()) {
    SCOPED_TRACE("m = " + std::to_string(m));
    const AxisPool& built = pool(m);
    ASSERT_EQ(built.size(), m);
    const double rho = built.coveringRadius();
    EXPECT_EQ(rho, coveringRadius(built.axes()));  // the stored value is the exact one
    EXPECT_LE(rho, coveringRadius(fibonacciAxes(m)));
    EXPECT_GE(rho, fejesTothBound(2 * m));
    double closest = kPi;
    for (int i = 0; i < m; ++i) {
      const Vec3& a = built.axis(i);
      EXPECT_NEAR(a.norm(), 1.0, 1e-12);
      EXPECT_TRUE(upperHalfRule(a)) << a.transpose();
      for (int j = i + 1; j < m; ++j)
        closest = std::min(closest, std::acos(std::min(1.0, std::fabs(a.dot(built.axis(j))))));
    }
    // Distinct as axes; a covering this close to optimal keeps its axes well apart.
    EXPECT_GT(closest, 0.5 * rho);
    const AxisPool again(m);
    EXPECT_EQ(again.axes(), built.axes());
    EXPECT_EQ(again.coveringRadius(), rho);
  }
}

TEST(AxisPool, CloseToTheHexagonalBound) {
  // Measured ratios rho / hexagonal bound are 1.01-1.05 for m >= 50 (the golden-angle
  // baseline: 1.29-1.39); 1.06 leaves a margin but fails if the relaxation stops working.
  for (int m : {50, 64, 100, 130, 200, 500, 1000, 2000}) {
    const double rho = pool(m).coveringRadius();
    const double ratio = rho / hexagonalBound(m);
    const double baseline = coveringRadius(fibonacciAxes(m)) / hexagonalBound(m);
    std::cout << "  m = " << m << ": rho = " << degrees(rho) << " deg, rho / hexagonal bound = "
              << ratio << " (golden-angle baseline " << baseline << ")\n";
    EXPECT_LE(ratio, 1.06) << "m = " << m;
  }
  // Small pools against the Fejes Toth bound (the hexagonal bound means little there). For
  // m = 5 antipodal symmetry is costly: 300 random starts relaxed found nothing below the
  // 45.97 degrees the pool reaches (1.116 times the bound).
  for (int m = 4; m <= 40; ++m)
    EXPECT_LE(pool(m).coveringRadius(), (m == 5 ? 1.12 : 1.07) * fejesTothBound(2 * m))
        << "m = " << m;
}

TEST(AxisPool, LargestSizeBuilds) {
  const AxisPool& largest = pool(AxisPool::kMaxAxes);
  EXPECT_EQ(largest.size(), AxisPool::kMaxAxes);
  EXPECT_LE(largest.coveringRadius(), 1.06 * hexagonalBound(AxisPool::kMaxAxes));
}

TEST(AxisPool, RejectsSizesOutsideTheRange) {
  for (int m : {2, 0, -1, 5000, 4097}) {
    const std::string what = invalidArgumentMessage([&] { AxisPool rejected(m); });
    EXPECT_NE(what.find("m = " + std::to_string(m)), std::string::npos) << what;
    EXPECT_NE(what.find("[3, 4096]"), std::string::npos) << what;
  }
}

}  // namespace
