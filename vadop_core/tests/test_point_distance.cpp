// PointDistance (the gap from a point to a posed shape) against an independent brute force:
// closed forms for the sphere, box, capsule and cylinder, the minimum over the balls for a
// point set, each under random poses, margins and points around and inside the shape (gap() and
// within(), and within() of the shape placed once; inside a sphere, capsule or box the gap is
// minus the exact depth); and the margin's boundary (within(): in at margin - 1e-6, out at
// margin + 1e-6).
#include "vadop/error.h"
#include "vadop/point_distance.h"
#include "vadop/shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;

// The exact gap in the shape's own frame (outside: > 0; inside a solid shape: <= 0), margin included.
double truthGap(const vadop::Shape& s, const Vector3d& q) {
  double core = 0.0;
  switch (s.type) {
    case vadop::ShapeType::kSphere: core = q.norm() - s.radius; break;
    case vadop::ShapeType::kBox: {
      const Vector3d d = q.cwiseAbs() - s.half_extents;
      core = d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
      break;
    }
    case vadop::ShapeType::kCapsule: {
      const double z = std::clamp(q.z(), -s.half_length, s.half_length);
      core = (q - Vector3d(0, 0, z)).norm() - s.radius;
      break;
    }
    case vadop::ShapeType::kCylinder: {
      const double dr = std::hypot(q.x(), q.y()) - s.radius, dz = std::abs(q.z()) - s.half_length;
      core = std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
      break;
    }
    default: {  // a point set: balls about its points (triangles (i, i, i))
      core = 1e300;
      for (const Vector3d& p : s.points) core = std::min(core, (q - p).norm());
      core -= s.radius;
      break;
    }
  }
  return core - s.margin;
}

Isometry3d randomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Isometry3d pose = Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng) + 1e-3).normalized().toRotationMatrix();
  pose.translation() = Vector3d(u(rng), u(rng), u(rng)) * 5.0;
  return pose;
}

std::vector<vadop::Shape> shapes(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vector3d> pts;
  for (int i = 0; i < 300; ++i) pts.push_back(Vector3d(u(rng), u(rng), 0.3 * u(rng)));
  return {vadop::makeSphere(0.4),
          vadop::makeBox(Vector3d(0.8, 0.5, 0.3)),
          vadop::makeCapsule(0.2, 0.6),
          vadop::makeCylinder(0.3, 0.5),
          vadop::makePointSet(pts, 0.02),
          vadop::inflate(vadop::makeBox(Vector3d(0.4, 0.4, 0.4)), 0.1)};
}

TEST(PointDistance, MatchesTheClosedFormsAndTheBruteForceOverPoints) {
  std::mt19937 rng(49);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int outside = 0, inside = 0;
  for (const vadop::Shape& s : shapes(rng)) {
    const vadop::PointDistance query(s);
    for (int i = 0; i < 400; ++i) {
      const Isometry3d pose = randomPose(rng);
      const double reach = i % 2 ? s.bounding_radius + 0.5 : 0.6 * s.bounding_radius;
      const Vector3d local = Vector3d(u(rng), u(rng), u(rng)) * reach;
      const double truth = truthGap(s, local);
      const double got = query.gap(pose, pose * local);
      SCOPED_TRACE(std::string(vadop::toString(s.type)) + " point " + std::to_string(i));
      // within() (decided at a coarse tolerance first) against the truth, away from the boundary.
      const double margin = 0.3 * (0.5 + 0.5 * u(rng));
      if (std::abs(truth - margin) > 1e-6) {
        EXPECT_EQ(query.within(pose, pose * local, margin), truth <= margin);
        // The shape placed once (the sensors' filter): the same answer.
        EXPECT_EQ(query.place(pose).within(pose * local, margin), truth <= margin);
      }
      if (truth > 0.0) {
        EXPECT_NEAR(got, truth, 1e-6);
        ++outside;
      } else if (s.type != vadop::ShapeType::kMesh) {  // a point set is a surface: a point in a ball is near it
        EXPECT_LE(got, 1e-9);
        // Spheres, capsules, boxes and cylinders are answered in closed form: minus the exact depth.
        EXPECT_NEAR(got, truth, 1e-9);
        ++inside;
      } else {
        EXPECT_LE(got, 1e-6);
      }
    }
  }
  EXPECT_GT(outside, 1000);
  EXPECT_GT(inside, 100);
}

TEST(PointDistance, WithinTheMarginIsExactTo1e6) {
  std::mt19937 rng(7);
  const double margin = 0.1;
  for (const vadop::Shape& s : {vadop::makeBox(Vector3d(1.0, 0.6, 0.4)), vadop::makeCylinder(0.3, 0.5)}) {
    const vadop::PointDistance query(s);
    for (int i = 0; i < 50; ++i) {
      const Isometry3d pose = randomPose(rng);
      // Beside the +x face (box: a face point; cylinder: its side), the margin away.
      const double face = s.type == vadop::ShapeType::kBox ? s.half_extents.x() : s.radius;
      const Vector3d in = pose * Vector3d(face + margin - 1e-6, 0.0, 0.05);
      const Vector3d out = pose * Vector3d(face + margin + 1e-6, 0.0, 0.05);
      EXPECT_TRUE(query.within(pose, in, margin)) << vadop::toString(s.type);
      EXPECT_FALSE(query.within(pose, out, margin)) << vadop::toString(s.type);
      const vadop::PointDistance::Placed placed = query.place(pose);
      EXPECT_TRUE(placed.within(in, margin)) << vadop::toString(s.type);
      EXPECT_FALSE(placed.within(out, margin)) << vadop::toString(s.type);
    }
  }
}

TEST(PointDistance, RefusesANonFinitePoint) {
  const vadop::PointDistance query(vadop::makeSphere(1.0));
  EXPECT_THROW(query.gap(Isometry3d::Identity(), Vector3d(NAN, 0, 0)), vadop::InvalidArgument);
  EXPECT_NEAR(query.gap(Isometry3d::Identity(), Vector3d(3, 0, 0)), 2.0, 1e-9);
  EXPECT_THROW(query.place(Isometry3d::Identity()).within(Vector3d(0, NAN, 0), 0.1), vadop::InvalidArgument);
  Isometry3d bad = Isometry3d::Identity();
  bad.translation().x() = INFINITY;
  EXPECT_THROW(query.place(bad), vadop::InvalidArgument);
}

}  // namespace
