// transformShape: a shape moved into another frame keeps its support function exactly (the
// cylinder: within its 24-gon bound, never below), so the broad and narrow phases see the
// same geometry; and a link offset from a turning body's origin, expressed that way, is
// predicted on its true arc (the straight-line extrapolation of its own centre misses).
#include "vadop/error.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>

namespace vadop {
namespace {

Eigen::Isometry3d randomPose(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = Eigen::Vector3d(g(rng), g(rng), g(rng)) * 2.0;
  return pose;
}

TEST(TransformShape, SupportIsThatOfThePlacedShape) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  std::vector<Shape> shapes = {makeSphere(0.3),
                               inflate(makeBox(Eigen::Vector3d(0.4, 1.0, 0.2)), 0.05),
                               makeCapsule(0.2, 1.2),
                               makeCylinder(0.25, 0.8),
                               makeConvex({{0.1, 0, 0}, {0, 0.5, 0}, {0, 0, -0.3}, {0.2, 0.2, 0.2}}),
                               makeMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{{0, 1, 2}}, {{0, 1, 3}}})};
  for (const Shape& s : shapes) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Isometry3d pose = randomPose(rng);
      const Shape t = transformShape(s, pose);
      EXPECT_TRUE(t.type == ShapeType::kConvex || t.type == ShapeType::kMesh) << toString(s.type);
      for (int k = 0; k < 50; ++k) {
        const Eigen::Vector3d d(g(rng), g(rng), g(rng));
        const double exact = support(s, pose.linear().transpose() * d) + d.dot(pose.translation());
        const double got = support(t, d);
        if (s.type == ShapeType::kCylinder) {
          EXPECT_GE(got, exact - 1e-12) << "cylinder support below the exact one";
          EXPECT_LE(got, exact + 0.0087 * s.radius * d.norm()) << "cylinder bound too loose";
        } else {
          EXPECT_NEAR(got, exact, 1e-12 * (1.0 + std::abs(exact))) << toString(s.type);
        }
      }
      EXPECT_LE(t.bounding_radius, s.bounding_radius + pose.translation().norm() + 0.01 * s.bounding_radius + 1e-12);
    }
  }
}

TEST(TransformShape, IdentityKeepsThePrimitiveAndBadPosesThrow) {
  const Shape box = makeBox(Eigen::Vector3d(1, 2, 3));
  const Shape same = transformShape(box, Eigen::Isometry3d::Identity());
  EXPECT_EQ(same.type, ShapeType::kBox);
  EXPECT_EQ(same.half_extents, box.half_extents);
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan.translation().x() = std::nan("");
  EXPECT_THROW(transformShape(box, nan), InvalidArgument);
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 2.0;
  try {
    transformShape(box, scaled);
    FAIL() << "a scaling accepted as a pose";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("rigid"), std::string::npos) << e.what();
  }
}

TEST(TransformShape, ArmOfATurningBodyIsPredictedOnItsArc) {
  // A robot turning in place at 1 rad/s about z with a ball (radius 0.1) on an arm 1 m long;
  // an obstacle ball (radius 0.1) on the arm's circle, 1 rad ahead. Contact when the centres
  // are 0.2 apart along the circle's chord: angle 2 asin(0.1), so at t = 1 - 2 asin(0.1).
  Eigen::Isometry3d arm = Eigen::Isometry3d::Identity();
  arm.translation() = Eigen::Vector3d(1, 0, 0);
  const Shape ball = makeSphere(0.1);
  const Motion robot = makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                                  Eigen::Vector3d(0, 0, 1));
  const Motion obstacle = makeMotion(Eigen::Vector3d(std::cos(1.0), std::sin(1.0), 0), Eigen::Quaterniond::Identity(),
                                     Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const TimeOfImpact hit = timeOfImpact(transformShape(ball, arm), robot, ball, obstacle, 0.0, 2.0);
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.time, 1.0 - 2.0 * std::asin(0.1), 1e-4);
  // The ball's own centre extrapolated along its velocity (1 m/s along y) passes 0.46 m wide.
  const Motion tangent = makeMotion(Eigen::Vector3d(1, 0, 0), Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 1, 0),
                                    Eigen::Vector3d(0, 0, 1));
  EXPECT_FALSE(timeOfImpact(ball, tangent, ball, obstacle, 0.0, 2.0).hit);
}

// Issue 13, defect 10: every dimension, point and the margin within kMaxSize (error.h), in the
// make* functions and validateShape alike; inside and just beyond, the message naming the
// field and the value.
TEST(ShapeRange, EveryDimensionWithinKMaxSize) {
  const double in = kMaxSize, out = kMaxSize * (1.0 + 1e-12);
  auto expectRange = [](const std::function<Shape()>& make, const std::string& field) {
    try {
      make();
      ADD_FAILURE() << field << ": accepted beyond kMaxSize";
    } catch (const InvalidArgument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(field), std::string::npos) << what;
      EXPECT_NE(what.find("is beyond 100000 m"), std::string::npos) << what;
    }
  };
  EXPECT_NO_THROW(makeSphere(in));
  expectRange([&] { return makeSphere(out); }, "sphere radius = 100000.0000001");
  expectRange([&] { return makeSphere(1e149); }, "sphere radius = 1e+149");  // the spheres
  EXPECT_NO_THROW(makeBox(Eigen::Vector3d(in, 1, in)));
  expectRange([&] { return makeBox(Eigen::Vector3d(1, out, 1)); }, "box size[1]");
  EXPECT_NO_THROW(makeCapsule(in, in));
  expectRange([&] { return makeCapsule(out, 1); }, "capsule radius");
  expectRange([&] { return makeCapsule(1, out); }, "capsule length");
  EXPECT_NO_THROW(makeCylinder(in, in));
  expectRange([&] { return makeCylinder(out, 1); }, "cylinder radius");
  expectRange([&] { return makeCylinder(1, out); }, "cylinder length");
  EXPECT_NO_THROW(makeConvex({{0, 0, 0}, {0.6 * in, 0.8 * in, 0}}));
  expectRange([&] { return makeConvex({{0, 0, 0}, {0, 0.6 * out, 0.8 * out}}); }, "|convex points[1]|");
  expectRange([&] { return makeConvex({{1e200, 1e200, 0}}); }, "|convex points[0]| = 1.41421356237309");
  EXPECT_NO_THROW(makeMesh({{0, 0, 0}, {in, 0, 0}, {0, 1, 0}}, {{{0, 1, 2}}}));
  expectRange([&] { return makeMesh({{0, 0, 0}, {1, 0, 0}, {0, 0, -out}}, {{{0, 1, 2}}}); }, "|mesh vertices[2]|");
  EXPECT_NO_THROW(inflate(makeSphere(1), in));
  expectRange([&] { return inflate(makeSphere(1), out); }, "padding");
  // validateShape: the same limits for shapes built by hand (message prefixed).
  Shape box = makeBox(Eigen::Vector3d(1, 1, 1));
  box.half_extents.z() = 0.5 * out;
  expectRange([&] {
    validateShape(box, "body");
    return box;
  }, "body: box size[2]");
  Shape padded = inflate(makeSphere(1), in);
  EXPECT_NO_THROW(validateShape(padded, "body"));
  padded.margin = out;
  expectRange([&] {
    validateShape(padded, "body");
    return padded;
  }, "margin");
  Shape cyl = makeCylinder(1, 1);
  cyl.half_length = out;
  expectRange([&] {
    validateShape(cyl, "c");
    return cyl;
  }, "cylinder length");
}

}  // namespace
}  // namespace vadop
