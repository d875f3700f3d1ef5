// The VADOP of one body: analytic swept intervals (linear and rotating), their soundness
// against densely sampled poses for every shape type, and the axis-selection rules.
#include "vadop/error.h"
#include "vadop/vadop.h"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <iterator>
#include <random>

namespace vadop {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The box of `s` moved by `m` at time t (lo x y z, hi x y z): the truth the swept boxes hold.
void boxAt(const Shape& s, const Motion& m, double t, double* box) {
  const Eigen::Matrix3d R = m.orientationAt(t).toRotationMatrix();
  const Eigen::Vector3d o = m.positionAt(t);
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d a = R.transpose() * Eigen::Vector3d::Unit(c);
    box[c] = o[c] - support(s, -a);
    box[3 + c] = o[c] + support(s, a);
  }
}

Motion linear(const Eigen::Vector3d& p, const Eigen::Vector3d& v) {
  return makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero());
}

TEST(SweptInterval, SphereMovingAlongAnAxis) {
  const Shape s = makeSphere(0.5);
  const Motion m = linear(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(4, 0, 0));
  const Interval x = sweptInterval(s, m, 0.0, 0.5, Eigen::Vector3d::UnitX());
  EXPECT_NEAR(x.lo, 0.5, 1e-9);
  EXPECT_NEAR(x.hi, 3.5, 1e-9);
  const Interval y = sweptInterval(s, m, 0.0, 0.5, Eigen::Vector3d::UnitY());
  EXPECT_NEAR(y.lo, 1.5, 1e-9);  // orthogonal to the motion: just the sphere
  EXPECT_NEAR(y.hi, 2.5, 1e-9);
  // Moving backwards gives the same hull of the two end positions.
  const Interval back = sweptInterval(s, linear(Eigen::Vector3d(3, 2, 3), Eigen::Vector3d(-4, 0, 0)), 0.0, 0.5,
                                      Eigen::Vector3d::UnitX());
  EXPECT_NEAR(back.lo, 0.5, 1e-9);
  EXPECT_NEAR(back.hi, 3.5, 1e-9);
}

TEST(SweptInterval, BoxAndCapsuleSupportsAreExact) {
  const Shape box = makeBox(Eigen::Vector3d(2, 4, 6));
  const Eigen::Vector3d d = Eigen::Vector3d(1, 1, 0).normalized();
  const Interval iv = sweptInterval(box, linear(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 0, 1, d);
  EXPECT_NEAR(iv.hi, (1 + 2) / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(iv.lo, -(1 + 2) / std::sqrt(2.0), 1e-9);
  const Shape capsule = makeCapsule(0.5, 2.0);  // segment from z = -1 to 1
  const Interval z = sweptInterval(capsule, linear(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 0, 1,
                                   Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(z.hi, 1.5, 1e-9);
  EXPECT_NEAR(z.lo, -1.5, 1e-9);
  const Shape padded = inflate(capsule, 0.25);
  EXPECT_NEAR(sweptInterval(padded, linear(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 0, 1,
                            Eigen::Vector3d::UnitZ()).hi,
              1.75, 1e-9);
}

TEST(SweptInterval, SpinningBarIsBoundedAndNotGrosslyLoose) {
  // A 2 m bar along x spinning a quarter turn about z over the frame: on the y axis its
  // true reach is [-1, 1] (it passes through 45 degrees to 90); the bound must contain that.
  const Shape bar = makeBox(Eigen::Vector3d(2.0, 0.02, 0.02));
  const Motion m = makeMotion(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d(0, 0, kPi / 2));
  const Interval y = sweptInterval(bar, m, 0.0, 1.0, Eigen::Vector3d::UnitY());
  EXPECT_GE(y.hi, 1.0);
  EXPECT_LE(y.lo, -0.02);
  EXPECT_LE(y.hi, 1.0 + 0.8);  // the chord bound: not wildly larger than the reach
  // The spin axis itself sees no rotation: z interval is just the half-thickness.
  const Interval z = sweptInterval(bar, m, 0.0, 1.0, Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(z.hi, 0.01, 1e-9);
}

TEST(SweptInterval, BoundsSampledPosesOfEveryShape) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  auto unit = [&] { return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized(); };
  std::vector<Shape> shapes = {makeSphere(0.3), makeBox(Eigen::Vector3d(0.2, 0.5, 1.1)), makeCapsule(0.2, 0.9),
                               makeCylinder(0.4, 0.3),
                               makeConvex({Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(0, 0.7, 0.1),
                                           Eigen::Vector3d(0.1, 0.2, 0.9), Eigen::Vector3d(-0.3, -0.3, -0.2)}),
                               makeMesh({Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1),
                                         Eigen::Vector3d(0.2, 0.2, 0.2)},
                                        {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}})};
  for (const Shape& base : shapes) {
    const Shape s = inflate(base, 0.05);
    for (int trial = 0; trial < 300; ++trial) {
      const Motion m = makeMotion(Eigen::Vector3d::Random(), Eigen::Quaterniond(Eigen::AngleAxisd(3.0 * g(rng), unit())),
                                  unit() * 5.0 * std::abs(g(rng)), unit() * 20.0 * std::abs(g(rng)));
      const double t0 = 0.3, t1 = 0.3 + 0.1 * std::abs(g(rng));
      const Eigen::Vector3d a = unit();
      const Interval iv = sweptInterval(s, m, t0, t1, a);
      for (int k = 0; k <= 64; ++k) {
        const double t = t0 + (t1 - t0) * k / 64.0;
        const Eigen::Matrix3d R = m.orientationAt(t).toRotationMatrix();
        const double c = a.dot(m.positionAt(t));
        ASSERT_LE(c + support(s, R.transpose() * a), iv.hi) << toString(s.type) << " trial " << trial;
        ASSERT_GE(c - support(s, -(R.transpose() * a)), iv.lo) << toString(s.type) << " trial " << trial;
      }
    }
  }
}

// SweptBody::partBoxes (the world's time-slice cull) against densely sampled poses, over long
// windows, fast spins (more than half a turn per part), pivots off the origin and counts of
// parts from 1 to 64; and, where a part turns by more than kEndsMaxTurn, against one SweptBody
// per part (the same bounds up to rounding; its box() equal to project() on the unit axes).
TEST(SweptInterval, PartBoxesBoundSampledPosesAndMatchOneSweptBodyPerPart) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto unit = [&] { return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized(); };
  const std::vector<Shape> shapes = {
      makeSphere(0.3), makeBox(Eigen::Vector3d(0.2, 0.5, 1.1)), makeCapsule(0.2, 0.9), makeCylinder(0.4, 0.3),
      makeConvex({Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(0, 0.7, 0.1), Eigen::Vector3d(0.1, 0.2, 0.9),
                  Eigen::Vector3d(-0.3, -0.3, -0.2)})};
  const int part_counts[] = {1, 2, 3, 8, 64};
  size_t samples = 0, from_ends_parts = 0;
  for (const Shape& base : shapes) {
    const Shape s = inflate(base, 0.05);
    for (int trial = 0; trial < 200; ++trial) {
      Motion m = makeMotion(Eigen::Vector3d::Random() * 10.0,
                            Eigen::Quaterniond(Eigen::AngleAxisd(3.0 * g(rng), unit())),
                            unit() * 3.0 * std::abs(g(rng)), unit() * 8.0 * std::abs(g(rng)), 0.5 * g(rng));
      if (trial % 2 == 1) m.pivot_offset = Eigen::Vector3d::Random() * 1.5;
      if (trial % 7 == 3) m.angular_velocity.setZero();
      const double t0 = 4.0 * u(rng) - 1.0, t1 = t0 + 3.0 * u(rng);
      const int parts = part_counts[trial % 5];
      std::vector<double> boxes(6 * parts);
      SweptBody::partBoxes(s, m, t0, t1, parts, boxes.data());
      double start = t0;
      for (int k = 0; k < parts; ++k) {
        const double end = k + 1 == parts ? t1 : t0 + (t1 - t0) * (k + 1) / parts;
        const double* b = &boxes[6 * k];
        double one[6];
        const SweptBody body(s, m, start, end);
        body.box(one);
        for (int c = 0; c < 3; ++c) {  // box() is project() on the unit axes, to the bit
          const Interval iv = body.project(Eigen::Vector3d::Unit(c));
          ASSERT_EQ(one[c], iv.lo);
          ASSERT_EQ(one[3 + c], iv.hi);
        }
        const bool from_ends = m.isRotating() && m.angular_velocity.norm() * (t1 - t0) / parts <= SweptBody::kEndsMaxTurn;
        from_ends_parts += from_ends;
        for (int c = 0; c < 6 && !from_ends; ++c) {
          ASSERT_NEAR(b[c], one[c], 1e-9 * (1.0 + std::abs(one[c]))) << toString(s.type) << " trial " << trial << " part " << k;
        }
        for (int j = 0; j <= 16; ++j) {
          double at[6];
          boxAt(s, m, start + (end - start) * j / 16.0, at);
          for (int c = 0; c < 3; ++c) {
            ASSERT_LE(at[3 + c], b[3 + c]) << toString(s.type) << " trial " << trial << " part " << k;
            ASSERT_GE(at[c], b[c]) << toString(s.type) << " trial " << trial << " part " << k;
          }
          ++samples;
        }
        start = end;
      }
    }
  }
  EXPECT_GT(samples, 50000u);
  EXPECT_GT(from_ends_parts, 5000u);  // both ways taken
  EXPECT_LT(from_ends_parts, samples / 17 - 1000u);
}

// A robot turning on a circle (1 m/s, 0.5 rad/s: the pivot 2 m to its left), its 2 s window in
// the world's 8 time slices: each part's box is the true extent of the body over the part
// (dense samples) to within 1 cm (the curvature over a quarter second is 5 mm), where the
// chord bound of one SweptBody per part adds about 16 cm on every side.
TEST(SweptInterval, PartBoxesOfATurningRobotAreTight) {
  for (const Shape& base : {makeBox(Eigen::Vector3d(0.6, 0.4, 0.3)), makeSphere(0.3), makeCylinder(0.3, 0.4)}) {
    const Shape s = inflate(base, 0.05);
    for (const double heading : {0.0, 0.4, 1.3}) {
      Motion m = makeMotion(Eigen::Vector3d(3, -2, 0.15), Eigen::Quaterniond(Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ())),
                            Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 0.5), 10.0);
      m.pivot_offset = Eigen::Vector3d(-2.0 * std::sin(heading), 2.0 * std::cos(heading), 0.0);  // 2 m to its left
      const int parts = 8;
      double boxes[6 * parts];
      SweptBody::partBoxes(s, m, 10.0, 12.0, parts, boxes);
      double worst = 0.0, start = 10.0;
      for (int k = 0; k < parts; ++k) {
        const double end = SweptBody::partEnd(10.0, 12.0, k, parts);
        double truth[6] = {1e9, 1e9, 1e9, -1e9, -1e9, -1e9};
        for (int j = 0; j <= 2000; ++j) {
          double at[6];
          boxAt(s, m, start + (end - start) * j / 2000.0, at);
          for (int c = 0; c < 3; ++c) {
            truth[c] = std::min(truth[c], at[c]);
            truth[3 + c] = std::max(truth[3 + c], at[3 + c]);
          }
        }
        const double* b = &boxes[6 * k];
        for (int c = 0; c < 3; ++c) {
          ASSERT_LE(b[c], truth[c]);
          ASSERT_GE(b[3 + c], truth[3 + c]);
          worst = std::max({worst, truth[c] - b[c], b[3 + c] - truth[3 + c]});
        }
        start = end;
      }
      EXPECT_LT(worst, 0.01) << toString(s.type) << " heading " << heading;
    }
  }
}

TEST(AxisSelection, ZoneHysteresisAndSlowRules) {
  const AxisPool pool(32);
  VadopConfig c;  // m = 32, phi = 25 deg
  const double phi = validateVadopConfig(c, pool);
  EXPECT_NEAR(phi, 25.0 * kPi / 180.0, 1e-12);
  const Motion fast = linear(Eigen::Vector3d::Zero(), Eigen::Vector3d(3, 1, 0));
  const auto axes = selectAxes(fast, 0.5, 1.0 / 30, pool, c, phi);
  ASSERT_FALSE(axes.empty());
  const Eigen::Vector3d u = fast.linear_velocity.normalized();
  for (int k = 0; k < pool.size(); ++k) {
    const bool used = std::binary_search(axes.begin(), axes.end(), static_cast<uint32_t>(k));
    // A fresh set: the zone widened by half the hysteresis.
    EXPECT_EQ(used, std::abs(u.dot(pool.axis(k))) <= std::sin(phi + 0.5 * c.hysteresis_deg * kPi / 180) + 1e-12) << k;
  }
  // A slight turn keeps the set as it is.
  const Motion turned = linear(Eigen::Vector3d::Zero(), Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()) * fast.linear_velocity);
  EXPECT_EQ(selectAxes(turned, 0.5, 1.0 / 30, pool, c, phi, axes), axes);
  // A large turn gives a fresh set that again holds the whole zone.
  const Motion across = linear(Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1));
  const auto fresh = selectAxes(across, 0.5, 1.0 / 30, pool, c, phi, axes);
  EXPECT_NE(fresh, axes);
  for (int k = 0; k < pool.size(); ++k) {
    if (std::abs(pool.axis(k).z()) <= std::sin(phi)) {
      EXPECT_TRUE(std::binary_search(fresh.begin(), fresh.end(), static_cast<uint32_t>(k))) << k;
    }
  }
  // Turning steadily by a degree a step, the set changes far less often than once a step.
  std::vector<uint32_t> current = axes;
  int changes = 0;
  for (int step = 1; step <= 90; ++step) {
    const Motion m = linear(Eigen::Vector3d::Zero(), Eigen::AngleAxisd(step * kPi / 180, Eigen::Vector3d::UnitZ()) *
                                                         fast.linear_velocity);
    auto next = selectAxes(m, 0.5, 1.0 / 30, pool, c, phi, current);
    if (next != current) ++changes;
    current = next;
  }
  EXPECT_LE(changes, 90 / 4);
  // Slow bodies: the fixed zone orthogonal to z, or every axis.
  const Motion still = linear(Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-4, 0, 0));
  const auto zone = selectAxes(still, 0.5, 1.0 / 30, pool, c, phi);
  for (uint32_t k : zone) {
    EXPECT_LE(std::abs(pool.axis(static_cast<int>(k)).z()), std::sin(phi + 0.5 * c.hysteresis_deg * kPi / 180) + 1e-12);
  }
  c.slow_rule = SlowAxisRule::kAllAxes;
  EXPECT_EQ(selectAxes(still, 0.5, 1.0 / 30, pool, c, phi).size(), 32u);
}

TEST(AxisSelection, AnyTwoDirectionsShareAnAxisWhenPhiIsRho) {
  // The guarantee behind the configuration check, tested directly at its tightest.
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g;
  for (int m : {3, 7, 20, 64, 300}) {
    const AxisPool pool(m);
    VadopConfig c;
    c.axes = m;
    c.phi_deg = 0;  // phi = rho
    c.hysteresis_deg = 0;
    const double phi = validateVadopConfig(c, pool);
    for (int trial = 0; trial < 2000; ++trial) {
      const Motion a = linear(Eigen::Vector3d::Zero(), Eigen::Vector3d(g(rng), g(rng), g(rng)));
      const Motion b = linear(Eigen::Vector3d::Zero(), Eigen::Vector3d(g(rng), g(rng), g(rng)));
      const auto sa = selectAxes(a, 1e-3, 1.0, pool, c, phi);
      const auto sb = selectAxes(b, 1e-3, 1.0, pool, c, phi);
      std::vector<uint32_t> shared;
      std::set_intersection(sa.begin(), sa.end(), sb.begin(), sb.end(), std::back_inserter(shared));
      ASSERT_FALSE(shared.empty()) << "m = " << m << " trial " << trial;
    }
  }
}

}  // namespace
}  // namespace vadop
