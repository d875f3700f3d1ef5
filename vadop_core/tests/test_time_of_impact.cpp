// Analytic cases for the continuous narrow phase (time_of_impact.h) and its distance layer.
// Every expected value below is derived by hand from the scene, never from the code under
// test. The contract checked throughout (tol = ToiOptions::tolerance):
//   hit  => t* - tol / closing <= time <= t*   (never late; early by at most the tolerance gap)
//   gap(time) <= tol, normal from a to b, point between the two surfaces.
#include "vadop/distance.h"
#include "vadop/error.h"
#include "vadop/time_of_impact.h"
#include "advance_step.h"  // internal (vadop_core/src): the swept-volume certificate

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

using Eigen::AngleAxisd;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using vadop::TimeOfImpact;
using vadop::Motion;
using vadop::Shape;
using vadop::ToiOptions;

constexpr double kTol = 1e-6;  // the default ToiOptions::tolerance
constexpr double kPi = 3.14159265358979323846;

Motion motion(const Vector3d& p, const Vector3d& v = Vector3d::Zero(),
              const Vector3d& w = Vector3d::Zero(),
              const Quaterniond& q = Quaterniond::Identity(), double t_ref = 0.0) {
  return vadop::makeMotion(p, q, v, w, t_ref);
}

double angleDeg(const Vector3d& a, const Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / kPi;
}

// The reported time lies in [t_star - tol / closing - 1e-12, t_star + 1e-12].
void expectTime(const TimeOfImpact& imp, double t_star, double closing, double tol = kTol) {
  ASSERT_TRUE(imp.hit);
  EXPECT_LE(imp.time, t_star + 1e-12);
  EXPECT_GE(imp.time, t_star - tol / closing - 1e-12);
  EXPECT_FALSE(imp.undecided);
}

void expectNormal(const TimeOfImpact& imp, const Vector3d& n, double max_deg = 1e-3) {
  EXPECT_NEAR(imp.normal.norm(), 1.0, 1e-12);
  EXPECT_LE(angleDeg(imp.normal, n), max_deg) << "normal " << imp.normal.transpose() << " expected "
                                              << n.transpose();
}

void expectPoint(const TimeOfImpact& imp, const Vector3d& p, double tol) {
  EXPECT_LE((imp.point - p).norm(), tol) << "point " << imp.point.transpose() << " expected "
                                         << p.transpose();
}

// A closed box surface as a mesh (12 triangles, outward winding irrelevant for a soup).
void appendBoxMesh(std::vector<Vector3d>& v, std::vector<std::array<int, 3>>& t, const Vector3d& c,
                   const Vector3d& half) {
  const int base = static_cast<int>(v.size());
  for (int i = 0; i < 8; ++i) {
    v.push_back(c + Vector3d((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                             (i & 4) ? half.z() : -half.z()));
  }
  const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& q : quads) {
    t.push_back({base + q[0], base + q[1], base + q[2]});
    t.push_back({base + q[0], base + q[2], base + q[3]});
  }
}

Shape boxMesh(const Vector3d& half) {
  std::vector<Vector3d> v;
  std::vector<std::array<int, 3>> t;
  appendBoxMesh(v, t, Vector3d::Zero(), half);
  return vadop::makeMesh(v, t);
}

// Two pillars (x = +-1, 0.2 x 2 x 0.2 each) in one non-convex mesh, nothing in between.
Shape twoPillars() {
  std::vector<Vector3d> v;
  std::vector<std::array<int, 3>> t;
  appendBoxMesh(v, t, Vector3d(-1.0, 0.0, 0.0), Vector3d(0.1, 1.0, 0.1));
  appendBoxMesh(v, t, Vector3d(1.0, 0.0, 0.0), Vector3d(0.1, 1.0, 0.1));
  return vadop::makeMesh(v, t);
}

// ---------------------------------------------------------------------------------------

TEST(TimeOfImpact, HeadOnSpheresClosedFormAndAdvancement) {
  // a: r = 0.5 at rest at the origin; b: r = 0.25 at x = 3 moving at -1 m/s.
  // Gap 3 - 0.75 = 2.25 closes at 1 m/s: t* = 2.25, contact point x = 0.5, normal +x.
  const Shape sa = vadop::makeSphere(0.5), sb = vadop::makeSphere(0.25);
  const Motion ma = motion(Vector3d::Zero()), mb = motion(Vector3d(3, 0, 0), Vector3d(-1, 0, 0));
  const TimeOfImpact imp = vadop::timeOfImpact(sa, ma, sb, mb, 0.0, 5.0);
  expectTime(imp, 2.25, 1.0);
  EXPECT_FALSE(imp.initially_touching);
  EXPECT_LE(imp.distance, kTol);
  expectNormal(imp, Vector3d::UnitX());
  expectPoint(imp, Vector3d(0.5, 0, 0), kTol);

  // The same geometry through conservative advancement: a capsule of zero length is a sphere.
  const Shape ca = vadop::makeCapsule(0.5, 0.0);
  const TimeOfImpact imp2 = vadop::timeOfImpact(ca, ma, sb, mb, 0.0, 5.0);
  expectTime(imp2, 2.25, 1.0);
  expectNormal(imp2, Vector3d::UnitX());
  expectPoint(imp2, Vector3d(0.5, 0, 0), kTol);
  EXPECT_LE(imp2.iterations, 5);

  // Both moving, a reference time that is not t0, a window that does not start at 0:
  // at t_ref = 1: a at (0,0,0) moving +0.5 m/s in x, b at (4,0,0) moving -1.5 m/s.
  // Gap at t = 1 is 3.25, closing 2 m/s: t* = 1 + 1.625; a is then at x = 0.8125.
  const Motion ma2 = motion(Vector3d::Zero(), Vector3d(0.5, 0, 0), Vector3d::Zero(), Quaterniond::Identity(), 1.0);
  const Motion mb2 = motion(Vector3d(4, 0, 0), Vector3d(-1.5, 0, 0), Vector3d::Zero(), Quaterniond::Identity(), 1.0);
  for (const Shape* s : {&sa, &ca}) {
    const TimeOfImpact imp3 = vadop::timeOfImpact(*s, ma2, sb, mb2, 1.0, 4.0);
    expectTime(imp3, 2.625, 2.0);
    expectPoint(imp3, Vector3d(0.8125 + 0.5, 0, 0), kTol);
  }
  // Window ends before the contact: no hit.
  EXPECT_FALSE(vadop::timeOfImpact(sa, ma, sb, mb, 0.0, 2.2).hit);
  EXPECT_FALSE(vadop::timeOfImpact(ca, ma, sb, mb, 0.0, 2.2).hit);
}

TEST(TimeOfImpact, GlancingTangentPathIsAHit) {
  // b (r 0.5) moves along y = 1 at +1 m/s, a (r 0.5) rests at the origin: the centres are 1
  // apart exactly at t = 3 (tangency, gap 0 for one instant). Gap g(t) = sqrt(1 + (t-3)^2) - 1.
  const Shape sa = vadop::makeSphere(0.5), sb = vadop::makeSphere(0.5);
  const Shape ca = vadop::makeCapsule(0.5, 0.0);
  const Motion ma = motion(Vector3d::Zero()), mb = motion(Vector3d(-3, 1, 0), Vector3d(1, 0, 0));
  for (const Shape* a : {&sa, &ca}) {
    const TimeOfImpact imp = vadop::timeOfImpact(*a, ma, sb, mb, 0.0, 6.0);
    ASSERT_TRUE(imp.hit);
    EXPECT_LE(imp.time, 3.0 + 1e-12);
    const double g = std::sqrt(1.0 + (imp.time - 3.0) * (imp.time - 3.0)) - 1.0;
    EXPECT_LE(g, kTol + 1e-12);
    // Gap <= tol only within |t - 3| <= sqrt(2 tol) (about 1.4e-3 s).
    EXPECT_GE(imp.time, 3.0 - std::sqrt(2.0 * kTol) - 1e-9);
    const Vector3d centre_dir(imp.time - 3.0, 1.0, 0.0);
    expectNormal(imp, centre_dir, 1e-6);
    expectNormal(imp, Vector3d::UnitY(), 0.1);
  }
  // Passing 10 tolerances wide of tangency is no hit.
  const Motion mb_far = motion(Vector3d(-3, 1 + 10 * kTol, 0), Vector3d(1, 0, 0));
  EXPECT_FALSE(vadop::timeOfImpact(sa, ma, sb, mb_far, 0.0, 6.0).hit);
  EXPECT_FALSE(vadop::timeOfImpact(ca, ma, sb, mb_far, 0.0, 6.0).hit);

  // Sphere (r 0.2) grazing a unit box's top edge: centre path y = 0.7 from x = -3 at 1 m/s.
  // It touches the edge (x = -0.5, y = 0.5) at t = 2.5 and then slides along the face.
  const Shape box = vadop::makeBox(Vector3d(1, 1, 1));
  const Shape s2 = vadop::makeSphere(0.2);
  const TimeOfImpact imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), s2,
                                         motion(Vector3d(-3, 0.7, 0), Vector3d(1, 0, 0)), 0.0, 4.0);
  ASSERT_TRUE(imp.hit);
  EXPECT_LE(imp.time, 2.5 + 1e-12);
  const double dx = imp.time - 2.5;
  EXPECT_LE(std::hypot(dx, 0.2) - 0.2, kTol + 1e-12);  // gap to the edge at that time
  expectNormal(imp, Vector3d(dx, 0.2, 0.0), 1e-4);       // edge to centre
}

TEST(TimeOfImpact, AlreadyOverlappingOrTouching) {
  const Shape sa = vadop::makeSphere(0.5), sb = vadop::makeSphere(0.5);
  // Overlapping spheres: centre to centre (1,1,0)/sqrt 2.
  TimeOfImpact imp = vadop::timeOfImpact(sa, motion(Vector3d::Zero()), sb,
                                   motion(Vector3d(0.3, 0.3, 0), Vector3d(-1, 0, 0)), 0.5, 2.0);
  ASSERT_TRUE(imp.hit);
  EXPECT_TRUE(imp.initially_touching);
  EXPECT_EQ(imp.time, 0.5);
  // At t = 0.5, b is at (-0.2, 0.3, 0).
  expectNormal(imp, Vector3d(-0.2, 0.3, 0));
  // Concentric: any unit normal, finite point.
  imp = vadop::timeOfImpact(sa, motion(Vector3d::Zero()), sb, motion(Vector3d::Zero()), 0.0, 1.0);
  EXPECT_TRUE(imp.hit && imp.initially_touching);
  EXPECT_NEAR(imp.normal.norm(), 1.0, 1e-12);
  EXPECT_TRUE(imp.point.allFinite());

  // Unit boxes overlapping by 0.1 along x (offset (0.9, 0.2, 0.1)): least penetration +x.
  const Shape box = vadop::makeBox(Vector3d(1, 1, 1));
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), box, motion(Vector3d(0.9, 0.2, 0.1)), 0.0, 1.0);
  ASSERT_TRUE(imp.hit);
  EXPECT_TRUE(imp.initially_touching);
  EXPECT_EQ(imp.time, 0.0);
  expectNormal(imp, Vector3d::UnitX(), 0.5);
  EXPECT_NEAR(imp.distance, -0.1, 1e-3);  // minus the penetration depth
  EXPECT_GE(imp.point.x(), 0.4 - 1e-6);   // between the two surfaces in x
  EXPECT_LE(imp.point.x(), 0.5 + 1e-6);

  // Capsule overlapping a cylinder sideways by 0.05: normal -y (cylinder is a, above is b).
  const Shape cyl = vadop::makeCylinder(0.3, 1.0);
  const Shape cap = vadop::makeCapsule(0.1, 0.5);
  imp = vadop::timeOfImpact(cyl, motion(Vector3d::Zero()), cap, motion(Vector3d(0, -0.35, 0)), 0.0, 1.0);
  ASSERT_TRUE(imp.hit && imp.initially_touching);
  expectNormal(imp, -Vector3d::UnitY(), 0.5);
  EXPECT_NEAR(imp.distance, -0.05, 1e-3);
}

TEST(TimeOfImpact, SeparatingAndParallelMotion) {
  const Shape box = vadop::makeBox(Vector3d(1, 1, 1));
  const Shape cyl = vadop::makeCylinder(0.2, 0.6);
  // Moving apart.
  TimeOfImpact imp = vadop::timeOfImpact(box, motion(Vector3d::Zero(), Vector3d(-1, 0, 0)), cyl,
                                   motion(Vector3d(1.0, 0, 0), Vector3d(1, 0.2, 0)), 0.0, 10.0);
  EXPECT_FALSE(imp.hit);
  EXPECT_EQ(imp.time, 10.0);
  EXPECT_LE(imp.iterations, 2);
  // Same velocity: parallel motion at a 1 mm gap, never closer.
  const Vector3d v(3, -2, 1);
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero(), v), cyl, motion(Vector3d(0.7 + 1e-3, 0, 0), v), 0.0, 10.0);
  EXPECT_FALSE(imp.hit);
  EXPECT_LE(imp.iterations, 2);
  // Sliding along the face, 1 mm off it, until past the box.
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), cyl,
                            motion(Vector3d(0.7 + 1e-3, -2, 0), Vector3d(0, 1, 0)), 0.0, 10.0);
  EXPECT_FALSE(imp.hit);
  // Touching in parallel: resting on the face (gap 0) with a common velocity.
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero(), v), cyl, motion(Vector3d(0.7, 0, 0), v), 0.0, 10.0);
  ASSERT_TRUE(imp.hit);
  EXPECT_TRUE(imp.initially_touching);
  EXPECT_EQ(imp.time, 0.0);
  expectNormal(imp, Vector3d::UnitX());
  EXPECT_NEAR(imp.point.x(), 0.5, kTol);
  // Sliding along the face in contact: touching from t0.
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), cyl,
                            motion(Vector3d(0.7 + 0.3 * kTol, 0, 0), Vector3d(0, 1, 0)), 0.0, 1.0);
  EXPECT_TRUE(imp.hit && imp.initially_touching);
  // Arriving in parallel: the cylinder (r 0.2) slides along y with its axis at x = 0.7
  // (exact contact distance from the face x = 0.5) from y = -2. Its distance to the box's
  // edge (0.5, -0.5) is hypot(0.2, y + 0.5) - 0.2: first contact at y = -0.5, t = 1.5.
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), cyl,
                            motion(Vector3d(0.7, -2, 0), Vector3d(0, 1, 0)), 0.0, 3.0);
  ASSERT_TRUE(imp.hit);
  EXPECT_FALSE(imp.initially_touching);
  EXPECT_LE(imp.time, 1.5 + 1e-9);
  const double dy = imp.time - 1.5;
  EXPECT_LE(std::hypot(0.2, dy) - 0.2, kTol + 1e-12);  // gap to the edge at that time
}

TEST(TimeOfImpact, ThinFastBodyCrossesThinWall) {
  // Wall: 1 mm thick in x (faces at x = +-0.5 mm), 1 m x 1 m, at rest at the origin.
  // Body: 2 mm cube moving at +100 m/s from x = -4.55 over [0, 0.1] s. It spends only
  // 3e-5 s overlapping the wall. Its front face (x + 1 mm) meets x = -0.5 mm at
  // t* = (4.55 - 0.0015) / 100.
  const Shape wall = vadop::makeBox(Vector3d(0.001, 1.0, 1.0));
  const Shape body = vadop::makeBox(Vector3d(0.002, 0.002, 0.002));
  const Motion mw = motion(Vector3d::Zero());
  const Motion mbody = motion(Vector3d(-4.55, 0.1, -0.2), Vector3d(100, 0, 0));
  // A 10-step sampled check sees no contact at any of its 11 samples.
  for (int i = 0; i <= 10; ++i) {
    const double t = 0.01 * i;
    const vadop::DistanceResult d = vadop::distance(wall, mw.poseAt(t), body, mbody.poseAt(t));
    EXPECT_GT(d.distance, 0.4) << "sample " << i;
  }
  const double t_star = (4.55 - 0.0015) / 100.0;
  TimeOfImpact imp = vadop::timeOfImpact(body, mbody, wall, mw, 0.0, 0.1);
  expectTime(imp, t_star, 100.0);
  expectNormal(imp, Vector3d::UnitX());  // from the body (a) to the wall (b)
  EXPECT_NEAR(imp.point.x(), -0.0005, kTol);
  EXPECT_LE(imp.iterations, 4);
  // A thin capsule (r 0.5 mm) crossing at 100 m/s too, wall as a.
  const Shape needle = vadop::makeCapsule(0.0005, 0.05);
  imp = vadop::timeOfImpact(wall, mw, needle, motion(Vector3d(4.55, 0, 0), Vector3d(-100, 0, 0)), 0.0, 0.1);
  expectTime(imp, (4.55 - 0.001) / 100.0, 100.0);
  expectNormal(imp, Vector3d::UnitX());
}

TEST(TimeOfImpact, RotatingBarSweepsSphere) {
  // Box bar 2 x 0.1 x 0.1 spinning about z at 2 rad/s from angle 0. Sphere r 0.1 at
  // (0, 0.8, 0). In the bar frame the sphere centre is (D sin th, D cos th) with D = 0.8;
  // the bar's leading face y' = 0.05 touches it when D cos th = 0.05 + 0.1.
  const double w = 2.0, D = 0.8, hw = 0.05, r = 0.1;
  const Shape bar = vadop::makeBox(Vector3d(2.0, 2 * hw, 2 * hw));
  const Shape ball = vadop::makeSphere(r);
  const Motion mbar = motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(0, 0, w));
  const Motion mball = motion(Vector3d(0, D, 0));
  const double th = std::acos((hw + r) / D);
  const double t_star = th / w;
  const double closing = w * D * std::sin(th);  // speed of the face point along the normal
  const TimeOfImpact imp = vadop::timeOfImpact(bar, mbar, ball, mball, 0.0, 2.0);
  expectTime(imp, t_star, closing);
  const Vector3d n(-std::sin(th), std::cos(th), 0.0);  // bar frame +y'
  expectNormal(imp, n, 0.05);
  const Vector3d contact = D * std::sin(th) * Vector3d(std::cos(th), std::sin(th), 0) + hw * n;
  expectPoint(imp, contact, 1e-4);
  EXPECT_LE(imp.iterations, 60);

  // Just outside its reach (corner at sqrt(1 + hw^2) in the plane): no hit in a full turn,
  // with a 1e-4 m clearance.
  const double reach = std::hypot(1.0, hw);
  const Motion mfar = motion(Vector3d(0, reach + r + 1e-4, 0));
  const TimeOfImpact miss = vadop::timeOfImpact(bar, mbar, ball, mfar, 0.0, 1.1 * kPi / w);
  EXPECT_FALSE(miss.hit);
  EXPECT_FALSE(miss.undecided);
  // ... and 0.3 tol inside its reach: the corner touches it at th = pi/2 - atan(hw).
  const Motion mnear = motion(Vector3d(0, reach + r - 0.3 * kTol, 0));
  const TimeOfImpact hit = vadop::timeOfImpact(bar, mbar, ball, mnear, 0.0, 1.1 * kPi / w);
  ASSERT_TRUE(hit.hit);
  EXPECT_LE(hit.time, (kPi / 2 - std::atan(hw)) / w + 1e-9);
  EXPECT_GE(hit.time, (kPi / 2 - std::atan(hw)) / w - 2e-3);  // grazing: sqrt(2 gap / (w^2 reach))
  EXPECT_FALSE(hit.undecided);

  // Capsule bar (r 0.05, segment 2 along z) spinning about x at 2 rad/s: its axis is
  // (0, -sin th, cos th). Sphere r 0.1 at (0, -D, 0): distance from the axis line D cos th.
  const Shape cap = vadop::makeCapsule(hw, 2.0);
  const Motion mcap = motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(w, 0, 0));
  const Motion mball2 = motion(Vector3d(0, -D, 0));
  const TimeOfImpact imp2 = vadop::timeOfImpact(cap, mcap, ball, mball2, 0.0, 2.0);
  expectTime(imp2, t_star, closing);
  const Vector3d axis(0, -std::sin(th), std::cos(th));
  const Vector3d c(0, -D, 0);
  const Vector3d foot = c.dot(axis) * axis;
  expectNormal(imp2, c - foot, 0.05);
  expectPoint(imp2, foot + hw * (c - foot).normalized(), 1e-4);

  // Rotation plus translation: the same bar moving at +0.5 m/s in y meets the sphere
  // earlier; all we know in closed form is that it must hit before the pure-rotation time.
  const Motion mbar2 = motion(Vector3d::Zero(), Vector3d(0, 0.5, 0), Vector3d(0, 0, w));
  const TimeOfImpact imp3 = vadop::timeOfImpact(bar, mbar2, ball, mball, 0.0, 2.0);
  ASSERT_TRUE(imp3.hit);
  EXPECT_LT(imp3.time, t_star);
  // At the reported time the gap (evaluated independently by the distance layer) is <= tol.
  const vadop::DistanceResult d = vadop::distance(bar, mbar2.poseAt(imp3.time), ball, mball.poseAt(imp3.time));
  EXPECT_LE(d.distance, kTol + 1e-9);
  EXPECT_GE(d.distance, 0.0);
}

TEST(TimeOfImpact, EveryShapeTypeHitHeadOn) {
  // a at rest at the origin, a sphere b (r 0.1) coming along -x at 2 m/s from x = 3.
  // The front of a on the x axis is at x = e; t* = (3 - 0.1 - e) / 2, point (e, 0, 0), normal +x.
  std::vector<Vector3d> pts = {{0.4, 0, 0}, {-0.2, 0.3, 0.1}, {-0.2, -0.3, 0.1}, {-0.1, 0, -0.3}};
  struct Case {
    Shape s;
    double e;
  };
  const std::vector<Case> cases = {
      {vadop::makeSphere(0.3), 0.3},
      {vadop::makeBox(Vector3d(0.6, 0.4, 0.2)), 0.3},
      {vadop::makeCapsule(0.25, 1.0), 0.25},
      {vadop::makeCylinder(0.35, 0.5), 0.35},
      {vadop::makeConvex(pts), 0.4},
      {boxMesh(Vector3d(0.45, 0.2, 0.2)), 0.45},
      {twoPillars(), 1.1},
  };
  const Shape ball = vadop::makeSphere(0.1);
  const Motion mb = motion(Vector3d(3, 0, 0), Vector3d(-2, 0, 0));
  for (const Case& c : cases) {
    SCOPED_TRACE(vadop::toString(c.s.type));
    const TimeOfImpact imp = vadop::timeOfImpact(c.s, motion(Vector3d::Zero()), ball, mb, 0.0, 2.0);
    expectTime(imp, (2.9 - c.e) / 2.0, 2.0);
    expectNormal(imp, Vector3d::UnitX());
    expectPoint(imp, Vector3d(c.e, 0, 0), kTol);
    // Swapped roles: the normal flips.
    const TimeOfImpact sw = vadop::timeOfImpact(ball, mb, c.s, motion(Vector3d::Zero()), 0.0, 2.0);
    expectTime(sw, (2.9 - c.e) / 2.0, 2.0);
    expectNormal(sw, -Vector3d::UnitX());
    // Prepared shapes give the same answer.
    const TimeOfImpact pr = vadop::timeOfImpact(vadop::PreparedShape(c.s), motion(Vector3d::Zero()),
                                          vadop::PreparedShape(ball), mb, 0.0, 2.0);
    EXPECT_EQ(pr.hit, imp.hit);
    EXPECT_EQ(pr.time, imp.time);
  }
}

TEST(TimeOfImpact, CylinderAndConvexContacts) {
  // Cylinder (r 0.3, height 0.8) falling at 1 m/s onto a box top at z = 0 (box centre z = -0.5).
  const Shape cyl = vadop::makeCylinder(0.3, 0.8);
  const Shape floor = vadop::makeBox(Vector3d(4, 4, 1));
  const Motion mfloor = motion(Vector3d(0, 0, -0.5));
  TimeOfImpact imp = vadop::timeOfImpact(cyl, motion(Vector3d(0.2, 0.1, 1.4), Vector3d(0, 0, -1)), floor, mfloor, 0.0, 2.0);
  expectTime(imp, 1.0, 1.0);
  expectNormal(imp, -Vector3d::UnitZ());
  EXPECT_NEAR(imp.point.z(), 0.0, kTol);
  // Tilted by 30 degrees about x: the lowest rim point is at -(h cos30 + r sin30).
  const double tilt = kPi / 6;
  const Quaterniond q(AngleAxisd(tilt, Vector3d::UnitX()));
  const double low = 0.4 * std::cos(tilt) + 0.3 * std::sin(tilt);
  imp = vadop::timeOfImpact(cyl, motion(Vector3d(0, 0, 1.0), Vector3d(0, 0, -1), Vector3d::Zero(), q), floor, mfloor, 0.0, 2.0);
  expectTime(imp, 1.0 - low, 1.0);
  expectNormal(imp, -Vector3d::UnitZ());
  // Rim point: body (0, -0.3, -0.4) rotated by the tilt (the rim point facing -z).
  const Vector3d rim = q * Vector3d(0, -0.3, -0.4) + Vector3d(0, 0, 1.0 - imp.time);
  EXPECT_NEAR(rim.z(), 0.0, 2 * kTol);
  expectPoint(imp, Vector3d(rim.x(), rim.y(), 0.0), 1e-6);

  // Sphere hitting the cylinder's side at mid height.
  imp = vadop::timeOfImpact(vadop::makeSphere(0.1), motion(Vector3d(-2, 0, 0.1), Vector3d(1, 0, 0)), cyl,
                            motion(Vector3d::Zero()), 0.0, 3.0);
  expectTime(imp, 1.6, 1.0);
  expectNormal(imp, Vector3d::UnitX());
  expectPoint(imp, Vector3d(-0.3, 0, 0.1), kTol);

  // Convex tetrahedron, vertex down, falling onto the floor: vertex (0,0,-0.5) in the body.
  const Shape tet = vadop::makeConvex({{0, 0, -0.5}, {0.4, 0, 0.3}, {-0.2, 0.35, 0.3}, {-0.2, -0.35, 0.3}});
  imp = vadop::timeOfImpact(tet, motion(Vector3d(0.3, -0.2, 2.0), Vector3d(0, 0, -3)), floor, mfloor, 0.0, 1.0);
  expectTime(imp, 0.5, 3.0);
  expectNormal(imp, -Vector3d::UnitZ());
  expectPoint(imp, Vector3d(0.3, -0.2, 0.0), kTol);
  // Cylinder rolling sideways into a convex wedge's face x = 1 (face points at x = 1).
  const Shape wedge = vadop::makeConvex({{1, -1, -1}, {1, 1, -1}, {1, 0, 1}, {2, 0, 0}});
  imp = vadop::timeOfImpact(cyl, motion(Vector3d(0, 0, 0), Vector3d(0.5, 0, 0), Vector3d(0, 0, 3.0)), wedge,
                            motion(Vector3d::Zero()), 0.0, 3.0);
  expectTime(imp, (1.0 - 0.3) / 0.5, 0.5);  // spinning about its own axis does not matter
  expectNormal(imp, Vector3d::UnitX());
  EXPECT_LE(imp.iterations, 20);
}

TEST(TimeOfImpact, MeshIsNotItsConvexHull) {
  const Shape pillars = twoPillars();  // inner faces at x = +-0.9, front faces y = +-1
  const Shape ball = vadop::makeSphere(0.3);
  // Through the middle: 0.6 m clear of each inner face: no hit (the hull would be hit).
  TimeOfImpact imp = vadop::timeOfImpact(pillars, motion(Vector3d::Zero()), ball,
                                   motion(Vector3d(0, 3, 0), Vector3d(0, -2, 0)), 0.0, 3.0);
  EXPECT_FALSE(imp.hit);
  // Offset to x = 0.95: inside the right pillar's x range [0.9, 1.1]; it hits the
  // front face y = 1 when its centre is at y = 1.3: t* = (3 - 1.3) / 2.
  imp = vadop::timeOfImpact(pillars, motion(Vector3d::Zero()), ball,
                            motion(Vector3d(0.95, 3, 0), Vector3d(0, -2, 0)), 0.0, 3.0);
  expectTime(imp, 0.85, 2.0);
  expectNormal(imp, Vector3d::UnitY());
  expectPoint(imp, Vector3d(0.95, 1.0, 0), kTol);
  // Into the inner face sideways from the middle: centre x from 0 at +1 m/s; the ball
  // (r 0.3) meets x = 0.9 at t = 0.6.
  imp = vadop::timeOfImpact(pillars, motion(Vector3d::Zero()), ball,
                            motion(Vector3d(0, 0.2, 0), Vector3d(1, 0, 0)), 0.0, 3.0);
  expectTime(imp, 0.6, 1.0);
  expectNormal(imp, -Vector3d::UnitX());
  expectPoint(imp, Vector3d(0.9, 0.2, 0), kTol);
  // Mesh against mesh: a box mesh (half 0.5 x 0.1 x 0.5, x in [0.1, 1.1]) comes down -y at
  // 1 m/s from y = 2 onto the right pillar's end face y = 1: t* = (2 - 0.1 - 1) / 1.
  imp = vadop::timeOfImpact(boxMesh(Vector3d(0.5, 0.1, 0.5)), motion(Vector3d(0.6, 2, 0), Vector3d(0, -1, 0)),
                            pillars, motion(Vector3d::Zero()), 0.0, 3.0);
  expectTime(imp, 0.9, 1.0);
  expectNormal(imp, -Vector3d::UnitY());
  EXPECT_NEAR(imp.point.y(), 1.0, kTol);
  // The pillars spinning about y at 1 rad/s; a ball (r 0.3) at rest at (0, 0, 0.7). The left
  // pillar (x' in [-1.1, -0.9], z' in [-0.1, 0.1] in its frame) swings towards +z. In the
  // pillars' frame the ball centre is (-0.7 sin th, 0, 0.7 cos th); its distance to the
  // pillar is hypot(0.9 - 0.7 sin th, max(0, 0.7 cos th - 0.1)) (the edge x' = -0.9,
  // z' = 0.1) until the centre passes z' = 0.1. First contact where that equals 0.3.
  auto f = [](double th) {
    return std::hypot(0.9 - 0.7 * std::sin(th), std::max(0.0, 0.7 * std::cos(th) - 0.1)) - 0.3;
  };
  double lo = 0.0, hi = kPi / 2;  // f(0) > 0 > f(pi/2); f decreasing on [0, pi/2]
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > 0 ? lo : hi) = mid;
  }
  const double th = lo;
  const Motion mspin = motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(0, 1, 0));
  imp = vadop::timeOfImpact(pillars, mspin, ball, motion(Vector3d(0, 0, 0.7)), 0.0, 2.0);
  // Closing speed: d/dt of f at th (about 0.6 m/s); allow the tolerance gap over 0.1 m/s.
  expectTime(imp, th, 0.1);
  const Eigen::Matrix3d R = AngleAxisd(th, Vector3d::UnitY()).toRotationMatrix();
  const Vector3d n_local(0.9 - 0.7 * std::sin(th), 0.0, 0.7 * std::cos(th) - 0.1);
  expectNormal(imp, R * n_local, 0.05);
  expectPoint(imp, R * Vector3d(-0.9, 0.0, 0.1), 1e-4);
}

TEST(TimeOfImpact, MarginsPadTheShapes) {
  // Box (half 0.5) with margin 0.1 at rest; sphere r 0.2 from x = 3 at -1 m/s: t* = 3 - 0.8.
  const Shape box = vadop::inflate(vadop::makeBox(Vector3d(1, 1, 1)), 0.1);
  const Shape ball = vadop::makeSphere(0.2);
  const Motion mb = motion(Vector3d(3, 0.2, -0.1), Vector3d(-1, 0, 0));
  TimeOfImpact imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), ball, mb, 0.0, 5.0);
  expectTime(imp, 2.2, 1.0);
  expectNormal(imp, Vector3d::UnitX());
  expectPoint(imp, Vector3d(0.6, 0.2, -0.1), kTol);
  // Both padded: + 0.05 on the ball.
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), vadop::inflate(ball, 0.05), mb, 0.0, 5.0);
  expectTime(imp, 2.15, 1.0);
  // A padded corner is round: ball coming along the diagonal (1,1,0) from 3 m away
  // touches when its centre is 0.5 sqrt 2 + 0.1 + 0.2 from the origin.
  const Vector3d dir = Vector3d(1, 1, 0).normalized();
  imp = vadop::timeOfImpact(box, motion(Vector3d::Zero()), ball, motion(3 * dir, -dir), 0.0, 5.0);
  expectTime(imp, 3.0 - (0.5 * std::sqrt(2.0) + 0.3), 1.0);
  expectNormal(imp, dir, 1e-3);
  expectPoint(imp, (0.5 * std::sqrt(2.0) + 0.1) * dir, 1e-6);
  // Sphere-sphere closed form with margins.
  imp = vadop::timeOfImpact(vadop::inflate(ball, 0.3), motion(Vector3d::Zero()), ball, mb, 0.0, 5.0);
  expectTime(imp, 3.0 - std::sqrt(0.7 * 0.7 - 0.05) , 1.0 - 1e-6);
  // Padded mesh and padded capsule.
  imp = vadop::timeOfImpact(vadop::inflate(twoPillars(), 0.05), motion(Vector3d::Zero()), ball,
                            motion(Vector3d(0, 0.2, 0), Vector3d(1, 0, 0)), 0.0, 3.0);
  expectTime(imp, 0.9 - 0.05 - 0.2, 1.0);  // padded inner face at 0.85, ball r 0.2
  imp = vadop::timeOfImpact(vadop::inflate(vadop::makeCapsule(0.1, 1.0), 0.02), motion(Vector3d::Zero()), ball,
                            motion(Vector3d(0, 0, 3), Vector3d(0, 0, -1)), 0.0, 5.0);
  expectTime(imp, 3.0 - 0.5 - 0.12 - 0.2, 1.0);
  expectNormal(imp, Vector3d::UnitZ());
  // A margin makes an otherwise clear pass a hit: the pillars' inner faces are 0.7 m from
  // the 0.2 m ball's surface as it passes through the middle.
  EXPECT_FALSE(vadop::timeOfImpact(vadop::inflate(twoPillars(), 0.69), motion(Vector3d::Zero()), ball,
                                   motion(Vector3d(0, 3, 0), Vector3d(0, -2, 0)), 0.0, 3.0).hit);
  EXPECT_TRUE(vadop::timeOfImpact(vadop::inflate(twoPillars(), 0.71), motion(Vector3d::Zero()), ball,
                                  motion(Vector3d(0, 3, 0), Vector3d(0, -2, 0)), 0.0, 3.0).hit);
}

// Rounded shapes: the GJK's relative stopping rule must be relative to the gap of the padded
// shapes, not to the distance of their cores (which the rounding makes large): else the
// estimate of a near-contact gap stays off by a share of the rounding, far above the gap.
// A capsule (a segment core rounded by 0.3, length 4) lying along y beside an upright
// cylinder (r 1, length 2), its axis the line x = 1.3 + gap, z = 0, its centre at y = 0.8 (the
// centre line, GJK's first direction, is oblique to the contact normal x): the gap is that
// of the line to the cylinder's side at y = 0.
TEST(Distance, RelativeToleranceIsRelativeToTheGap) {
  const Shape cyl = vadop::makeCylinder(1.0, 2.0);
  const Shape capsule = vadop::makeCapsule(0.3, 4.0);
  vadop::DistanceOptions o;
  o.tolerance = 1e-12;
  o.relative_tolerance = 1e-3;
  for (const double gap : {1e-2, 1e-4, 1e-6}) {
    Eigen::Isometry3d pb = Eigen::Isometry3d::Identity();
    pb.linear() = AngleAxisd(kPi / 2, Vector3d::UnitX()).toRotationMatrix();
    pb.translation() = Vector3d(1.3 + gap, 0.8, 0.0);
    const vadop::DistanceResult d = vadop::distance(cyl, Eigen::Isometry3d::Identity(), capsule, pb, o);
    EXPECT_NEAR(d.distance, gap, 1e-3 * gap + 1e-12) << "gap " << gap;
    EXPECT_LE(d.lower_bound, gap + 1e-12) << "gap " << gap;
  }
}

// The same capsule approaching the cylinder from x = 3.3 at 1 m/s (t* = 2): the advancement
// ends on the contact in a few steps (an estimate of the gap off by a share of the rounding
// never reaches "touching" and stalls the steps near the contact).
TEST(TimeOfImpact, RoundedShapeReachesItsContact) {
  const Shape cyl = vadop::makeCylinder(1.0, 2.0);
  const Shape capsule = vadop::makeCapsule(0.3, 4.0);
  const Quaterniond along_y(AngleAxisd(kPi / 2, Vector3d::UnitX()));
  TimeOfImpact imp = vadop::timeOfImpact(cyl, motion(Vector3d::Zero()), capsule,
                                   motion(Vector3d(3.3, 0.8, 0.0), Vector3d(-1, 0, 0), Vector3d::Zero(), along_y), 0.0, 5.0);
  expectTime(imp, 2.0, 1.0);
  expectNormal(imp, Vector3d::UnitX(), 1e-3);
  EXPECT_LE(imp.iterations, 20);
  // The cylinder turning about its axis changes nothing.
  imp = vadop::timeOfImpact(cyl, motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(0, 0, 0.5)), capsule,
                            motion(Vector3d(3.3, 0.8, 0.0), Vector3d(-1, 0, 0), Vector3d::Zero(), along_y), 0.0, 5.0);
  expectTime(imp, 2.0, 1.0);
  EXPECT_LE(imp.iterations, 20);
}

TEST(TimeOfImpact, ToleranceAndWindowEdges) {
  const Shape box = vadop::makeBox(Vector3d(1, 1, 1));
  const Shape ball = vadop::makeSphere(0.5);
  const Motion ma = motion(Vector3d::Zero());
  const Motion mb = motion(Vector3d(3, 0, 0), Vector3d(-1, 0, 0));  // t* = 2
  // A coarser tolerance reports earlier, by at most tol / closing.
  ToiOptions coarse;
  coarse.tolerance = 1e-3;
  TimeOfImpact imp = vadop::timeOfImpact(box, ma, ball, mb, 0.0, 5.0, coarse);
  expectTime(imp, 2.0, 1.0, 1e-3);
  EXPECT_LE(imp.distance, 1e-3);
  // Zero-length window: a static check.
  EXPECT_FALSE(vadop::timeOfImpact(box, ma, ball, mb, 1.0, 1.0).hit);
  imp = vadop::timeOfImpact(box, ma, ball, mb, 2.0, 2.0);
  EXPECT_TRUE(imp.hit && imp.initially_touching);
  // Contact exactly at t1 is reported.
  imp = vadop::timeOfImpact(box, ma, ball, mb, 0.0, 2.0);
  expectTime(imp, 2.0, 1.0);
  // A 1-iteration budget that cannot conclude reports undecided, neither a contact nor a miss.
  ToiOptions one;
  one.max_iterations = 1;
  const Shape cyl = vadop::makeCylinder(0.2, 0.5);
  imp = vadop::timeOfImpact(cyl, motion(Vector3d(3, 0.3, 0), Vector3d(-1, 0, 0), Vector3d(0, 0, 5)), box, ma, 0.0, 5.0, one);
  EXPECT_FALSE(imp.hit);
  EXPECT_TRUE(imp.undecided);
  EXPECT_EQ(imp.iterations, 1);
  EXPECT_GT(imp.time, 0.0);
  EXPECT_LE(imp.time, 2.3);  // certified time before the contact (t* = 3 - 0.7)
}

TEST(TimeOfImpact, BadInputThrows) {
  const Shape ball = vadop::makeSphere(0.5);
  const Shape box = vadop::makeBox(Vector3d(1, 1, 1));
  const Motion ok = motion(Vector3d::Zero());
  Motion nan_v = ok;
  nan_v.linear_velocity.x() = std::numeric_limits<double>::quiet_NaN();
  Motion inf_p = ok;
  inf_p.position.y() = std::numeric_limits<double>::infinity();
  Motion nan_w = ok;
  nan_w.angular_velocity.z() = std::numeric_limits<double>::quiet_NaN();
  Motion bad_q = ok;
  bad_q.orientation = Quaterniond(2, 0, 0, 0);
  for (const Shape* s : {&ball, &box}) {
    EXPECT_THROW(vadop::timeOfImpact(*s, nan_v, ball, ok, 0, 1), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, inf_p, 0, 1), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, nan_w, ball, ok, 0, 1), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, bad_q, 0, 1), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, 1.0, 0.5), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, std::nan(""), 1.0), vadop::InvalidArgument);
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, 0.0, std::numeric_limits<double>::infinity()),
                 vadop::InvalidArgument);
    ToiOptions o;
    o.tolerance = 0.0;
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, 0, 1, o), vadop::InvalidArgument);
    o.tolerance = std::nan("");
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, 0, 1, o), vadop::InvalidArgument);
    o = ToiOptions();
    o.max_iterations = 0;
    EXPECT_THROW(vadop::timeOfImpact(*s, ok, ball, ok, 0, 1, o), vadop::InvalidArgument);
  }
  Shape neg = ball;
  neg.radius = -1.0;
  EXPECT_THROW(vadop::timeOfImpact(neg, ok, box, ok, 0, 1), vadop::InvalidArgument);
  EXPECT_THROW(vadop::timeOfImpact(box, ok, neg, ok, 0, 1), vadop::InvalidArgument);
  Shape stale = box;
  stale.half_extents.x() = 3.0;  // bounding_radius no longer matches
  EXPECT_THROW(vadop::timeOfImpact(stale, ok, ball, ok, 0, 1), vadop::InvalidArgument);
  Shape bad_mesh = boxMesh(Vector3d(0.5, 0.5, 0.5));
  bad_mesh.triangles[3][1] = 99;
  EXPECT_THROW(vadop::timeOfImpact(bad_mesh, ok, ball, ok, 0, 1), vadop::InvalidArgument);
  EXPECT_THROW(vadop::PreparedShape{bad_mesh}, vadop::InvalidArgument);
  Shape empty = vadop::makeConvex({{0, 0, 0}});
  empty.points.clear();
  EXPECT_THROW(vadop::timeOfImpact(empty, ok, ball, ok, 0, 1), vadop::InvalidArgument);
  Shape nan_pts = vadop::makeConvex({{0, 0, 0}, {1, 0, 0}});
  nan_pts.points[1].z() = std::nan("");
  EXPECT_THROW(vadop::timeOfImpact(ball, ok, nan_pts, ok, 0, 1), vadop::InvalidArgument);
  Shape neg_margin = box;
  neg_margin.margin = -0.1;
  EXPECT_THROW(vadop::timeOfImpact(neg_margin, ok, ball, ok, 0, 1), vadop::InvalidArgument);
  // Distance layer too.
  Eigen::Isometry3d bad_pose = Eigen::Isometry3d::Identity();
  bad_pose.translation().x() = std::nan("");
  EXPECT_THROW(vadop::distance(box, bad_pose, ball, Eigen::Isometry3d::Identity()), vadop::InvalidArgument);
}

// ---------------------------------------------------------------------------------------
// Distance layer

TEST(Distance, AnalyticStaticDistances) {
  Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  auto at = [](const Vector3d& p, const Quaterniond& q = Quaterniond::Identity()) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = p;
    return T;
  };
  const Shape box = vadop::makeBox(Vector3d(1, 2, 3));
  // Box corner (0.5, 1, 1.5) to a sphere centre at (1.5, 2, 2.5): sqrt 3 - r.
  vadop::DistanceResult d = vadop::distance(box, I, vadop::makeSphere(0.2), at(Vector3d(1.5, 2, 2.5)));
  EXPECT_NEAR(d.distance, std::sqrt(3.0) - 0.2, 1e-9);
  EXPECT_LE(d.lower_bound, d.distance + 1e-15);
  EXPECT_NEAR(d.lower_bound, d.distance, 1e-8);
  EXPECT_LE(angleDeg(d.normal, Vector3d(1, 1, 1)), 1e-6);
  EXPECT_LE((d.point_a - Vector3d(0.5, 1, 1.5)).norm(), 1e-8);
  // Box rotated 45 degrees about z: its edge reaches sqrt(0.5^2+1^2)... use a cube instead.
  const Shape cube = vadop::makeBox(Vector3d(1, 1, 1));
  d = vadop::distance(cube, at(Vector3d::Zero(), Quaterniond(AngleAxisd(kPi / 4, Vector3d::UnitZ()))), cube,
                      at(Vector3d(2, 0, 0)));
  EXPECT_NEAR(d.distance, 2.0 - 0.5 - std::sqrt(0.5), 1e-9);
  // Cylinder rim to a point: cylinder r 1, h 2 at origin; sphere at (2, 0, 2): rim (1,0,1).
  d = vadop::distance(vadop::makeCylinder(1.0, 2.0), I, vadop::makeSphere(0.1), at(Vector3d(2, 0, 2)));
  EXPECT_NEAR(d.distance, std::sqrt(2.0) - 0.1, 1e-8);
  // Parallel capsules 1 apart: 1 - 2 r.
  d = vadop::distance(vadop::makeCapsule(0.1, 2.0), I, vadop::makeCapsule(0.2, 1.0), at(Vector3d(1, 0, 0.3)));
  EXPECT_NEAR(d.distance, 0.7, 1e-9);
  // Crossed segments (capsules) at different heights: x axis and y axis, 0.5 apart in z.
  const Quaterniond to_x(AngleAxisd(kPi / 2, Vector3d::UnitY()));
  const Quaterniond to_y(AngleAxisd(kPi / 2, Vector3d::UnitX()));
  d = vadop::distance(vadop::makeCapsule(0.1, 2.0), at(Vector3d::Zero(), to_x), vadop::makeCapsule(0.1, 2.0),
                      at(Vector3d(0, 0, 0.5), to_y));
  EXPECT_NEAR(d.distance, 0.3, 1e-9);
  EXPECT_LE(angleDeg(d.normal, Vector3d::UnitZ()), 1e-6);
  // Mesh: nearest pillar's inner face from a sphere in the middle.
  d = vadop::distance(twoPillars(), I, vadop::makeSphere(0.1), at(Vector3d(0.3, 0.2, 0.05)));
  EXPECT_NEAR(d.distance, 0.9 - 0.3 - 0.1, 1e-9);
  EXPECT_LE(angleDeg(d.normal, -Vector3d::UnitX()), 1e-6);
  // Overlap: cores intersect.
  d = vadop::distance(cube, I, cube, at(Vector3d(0.7, 0, 0)));
  EXPECT_TRUE(d.cores_overlap);
  EXPECT_NEAR(d.distance, -0.3, 1e-6);
  EXPECT_LE(angleDeg(d.normal, Vector3d::UnitX()), 0.1);
}

// ---------------------------------------------------------------------------------------
// Fast spinners (issue 13, defect 5): the budget must not turn a near miss into a contact,
// and the swept-volume certificate must settle them quickly.

// A bar 2 x 0.1 x 0.1 spinning about z at w (its corners reach hypot(1, 0.05) in the xy
// plane) and a 0.2 m block whose near face is `clearance` beyond that reach, on the y axis.
struct SpinScene {
  Shape bar = vadop::makeBox(Vector3d(2, 0.1, 0.1));
  Shape block = vadop::makeBox(Vector3d(0.2, 0.2, 0.2));
  Motion mbar, mblock;
  SpinScene(double w, double clearance) {
    mbar = motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(0, 0, w));
    mblock = motion(Vector3d(0, std::hypot(1.0, 0.05) + clearance + 0.1, 0));
  }
};

double cpuMsPerCall(const std::function<void()>& f, int reps) {
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < reps; ++i) f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / reps;
}

TEST(TimeOfImpact, FastSpinnerNearMissIsClearNotAContact) {
  // 1 cm clear of the block at every turn. Before the swept volumes, conservative
  // advancement ran out of its 10,000 steps (at t = 47.9 s and 3.39 s of these windows in the
  // issue's scenes) and reported a "conservative" contact.
  for (const auto& [w, horizon] : {std::pair<double, double>{20.0, 60.0}, {1000.0, 10.0}}) {
    const SpinScene sc(w, 0.01);
    const TimeOfImpact imp = vadop::timeOfImpact(sc.bar, sc.mbar, sc.block, sc.mblock, 0.0, horizon);
    EXPECT_FALSE(imp.hit) << "w = " << w << ": contact reported at t = " << imp.time;
    EXPECT_FALSE(imp.undecided) << "w = " << w << ": undecided at t = " << imp.time;
    EXPECT_EQ(imp.time, horizon);
    EXPECT_LE(imp.iterations, 100) << "w = " << w;
    // Both orders of the pair, and the block turning too (slowly, about its own centre).
    const TimeOfImpact rev = vadop::timeOfImpact(sc.block, sc.mblock, sc.bar, sc.mbar, 0.0, horizon);
    EXPECT_FALSE(rev.hit || rev.undecided) << "w = " << w;
    Motion slow = sc.mblock;
    slow.angular_velocity = Vector3d(0, 0, 1e-4);  // its near face comes < 1 mm closer over 60 s
    const TimeOfImpact both = vadop::timeOfImpact(sc.bar, sc.mbar, sc.block, slow, 0.0, horizon);
    EXPECT_FALSE(both.hit || both.undecided) << "w = " << w;
    const vadop::PreparedShape pa(sc.bar), pb(sc.block);
    const double ms = cpuMsPerCall([&] { (void)vadop::timeOfImpact(pa, sc.mbar, pb, sc.mblock, 0.0, horizon); }, 200);
    std::printf("spinning bar, w = %g rad/s over %g s: %d evaluations, %.4f ms per pair\n", w, horizon,
                imp.iterations, ms);
  }
  // The same at a clearance of 1 mm and with the pivot moving along the axis (the block
  // staying beside it): the swept cylinder plus the pivot's path still clears the block.
  SpinScene sc(300.0, 1e-3);
  sc.mbar.linear_velocity = Vector3d(0, 0, 0.002);  // 6 cm up over 30 s, the block is 10 cm tall
  const TimeOfImpact imp = vadop::timeOfImpact(sc.bar, sc.mbar, sc.block, sc.mblock, 0.0, 30.0);
  EXPECT_FALSE(imp.hit || imp.undecided) << imp.time;
  EXPECT_LE(imp.iterations, 200);
}

// The gap between the bar (spinning about its moving centre) and a wall: the bar's reach
// along x at angle th is L |cos th| + W |sin th|.
TEST(TimeOfImpact, ContactAfterLongSpinningIsFoundOnTime) {
  const double L = 1.0, W = 0.05, w = 20.0, v = 0.01;
  // The reach peaks at R = hypot(L, W) when th = k pi +- atan(W / L). The wall's face X is
  // placed 0.75 mm inside the reach at the peak th = 191 pi - atan(W / L) (t = 29.998 s, after
  // 95 turns), so that the peak before it (th = 190 pi + atan(W / L)) clears the wall by 0.8 mm
  // (a cleaner contact than a graze within microns, which costs advancement thousands of steps).
  const double X = std::hypot(L, W) + v * (191 * kPi - std::atan2(W, L)) / w - 0.00075;
  const Shape bar = vadop::makeBox(Vector3d(2 * L, 2 * W, 0.1));
  const Shape wall = vadop::makeBox(Vector3d(0.2, 10, 10));
  const Motion mbar = motion(Vector3d::Zero(), Vector3d(v, 0, 0), Vector3d(0, 0, w));
  const Motion mwall = motion(Vector3d(X + 0.1, 0, 0));
  auto gap = [&](double t) { return X - v * t - (L * std::abs(std::cos(w * t)) + W * std::abs(std::sin(w * t))); };
  // The first time the gap reaches `level`: a scan at 1e-5 s (near a maximum of the reach the
  // gap changes by < 3e-8 m in that time), then bisection.
  auto first = [&](double level) {
    double t = 0.0;
    while (gap(t + 1e-5) > level) t += 1e-5;
    double lo = t, hi = t + 1e-5;
    for (int k = 0; k < 60; ++k) {
      const double mid = 0.5 * (lo + hi);
      (gap(mid) > level ? lo : hi) = mid;
    }
    return hi;
  };
  const double t_tol = first(kTol), t_half = first(0.5 * kTol);
  ASSERT_GT(t_half, 25.0);
  const TimeOfImpact imp = vadop::timeOfImpact(bar, mbar, wall, mwall, 0.0, 60.0);
  ASSERT_TRUE(imp.hit) << "undecided " << imp.undecided << " at " << imp.time;
  EXPECT_FALSE(imp.undecided);
  // The contract: gap > tol/2 before `time`, gap <= tol at `time`.
  EXPECT_GE(imp.time, t_tol - 1e-9);
  EXPECT_LE(imp.time, t_half + 1e-9);
  EXPECT_LE(angleDeg(imp.normal, Vector3d::UnitX()), 0.1);
  EXPECT_LE(imp.iterations, 2000);
  std::printf("contact after %.1f turns: t = %.9f s (truth [%.9f, %.9f]), %d evaluations\n", w * t_half / (2 * kPi),
              imp.time, t_tol, t_half, imp.iterations);
}

TEST(TimeOfImpact, TinyBudgetIsUndecidedWithACertifiedTime) {
  // The bar sweeps the block (5 mm inside its reach): a contact at the first pass of a corner.
  // The contact angle th solves L cos th + W sin th = D (a corner's distance along y), from th = 0.
  const double L = 1.0, W = 0.05, w = 20.0;
  const double D = std::hypot(L, W) - 0.005;
  const Shape bar = vadop::makeBox(Vector3d(2 * L, 2 * W, 0.1));
  const Shape block = vadop::makeBox(Vector3d(0.2, 0.2, 0.2));
  // The bar starts along x; its corner (L, W) turns towards +y: its y is L sin th + W cos th.
  const Motion mbar = motion(Vector3d::Zero(), Vector3d::Zero(), Vector3d(0, 0, w));
  const Motion mblock = motion(Vector3d(0, D + 0.1, 0));
  const double th = std::asin(D / std::hypot(L, W)) - std::atan2(W, L);
  const double t_star = th / w;
  const TimeOfImpact full = vadop::timeOfImpact(bar, mbar, block, mblock, 0.0, 1.0);
  ASSERT_TRUE(full.hit);
  EXPECT_NEAR(full.time, t_star, 1e-6);
  for (const int budget : {1, 2, 5}) {
    ToiOptions o;
    o.max_iterations = budget;
    const TimeOfImpact imp = vadop::timeOfImpact(bar, mbar, block, mblock, 0.0, 1.0, o);
    EXPECT_FALSE(imp.hit) << "budget " << budget;
    EXPECT_TRUE(imp.undecided) << "budget " << budget;
    EXPECT_LE(imp.iterations, budget);
    EXPECT_GT(imp.time, 0.0);
    EXPECT_LE(imp.time, t_star);
    // Certified: the gap stays > tol/2 on [0, time] (sampled).
    for (int k = 0; k <= 200; ++k) {
      const double t = imp.time * k / 200.0;
      const vadop::DistanceResult d = vadop::distance(bar, mbar.poseAt(t), block, mblock.poseAt(t));
      ASSERT_GT(d.distance, 0.5 * kTol) << "budget " << budget << " t = " << t;
    }
  }
}

// The swept-volume certificate against dense sampling: random shapes, motions (turning or
// not, about the origin or an offset pivot) and intervals. Whenever it certifies a bound, every
// sampled gap over the interval is at least that bound (the GJK's distance is an upper bound
// of the gap, so a sample below the bound is a real violation).
TEST(SweptVolume, CertifiedBoundHoldsAgainstDenseSampling) {
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.05, 0.5);
  std::normal_distribution<double> g;
  auto randomShape = [&](int kind) -> Shape {
    switch (kind) {
      case 0: return vadop::makeSphere(pos(rng));
      case 1: return vadop::makeBox(Vector3d(2 * pos(rng), 2 * pos(rng), 2 * pos(rng)));
      case 2: return vadop::makeCapsule(0.5 * pos(rng), 2 * pos(rng));
      case 3: return vadop::makeCylinder(pos(rng), 2 * pos(rng));
      case 4: {
        std::vector<Vector3d> pts;
        for (int i = 0; i < 6; ++i) pts.push_back(Vector3d(u(rng), u(rng), u(rng)) * 0.4);
        return vadop::inflate(vadop::makeConvex(pts), 0.5 * pos(rng) * static_cast<double>(rng() % 2));
      }
      default: return boxMesh(Vector3d(pos(rng), pos(rng), pos(rng)));
    }
  };
  auto randomMotion = [&](int turning) {
    const Quaterniond q(g(rng), g(rng), g(rng), g(rng));
    Motion m = motion(Vector3d(u(rng), u(rng), u(rng)) * 1.5, Vector3d(g(rng), g(rng), g(rng)) * 0.7,
                      turning ? Vector3d(Vector3d(g(rng), g(rng), g(rng)) * 8.0) : Vector3d::Zero(), q.normalized(),
                      u(rng));
    if (turning && rng() % 2) m.pivot_offset = Vector3d(u(rng), u(rng), u(rng)) * 0.5;
    return m;
  };
  int certified = 0, tight = 0, checked = 0;
  for (int c = 0; c < 1500; ++c) {
    const Shape a = randomShape(static_cast<int>(rng() % 6)), b = randomShape(static_cast<int>(rng() % 6));
    const Motion ma = randomMotion(static_cast<int>(rng() % 3)), mb = randomMotion(static_cast<int>(rng() % 3));
    const double ta = u(rng);
    const double tb = ta + std::pow(10.0, -3.0 + 3.3 * (0.5 + 0.5 * u(rng)));
    const vadop::PreparedShape pa(a), pb(b);
    const vadop::detail::SweptBound sb = vadop::detail::sweptLowerBound(pa, ma, pb, mb, ta, tb,
                                                                        std::numeric_limits<double>::infinity());
    if (!(sb.lower_bound > -1.0)) continue;  // the volumes overlap (or nearly): nothing certified
    ++checked;
    if (sb.lower_bound > 0.5 * kTol) ++certified;
    double lowest = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= 300; ++k) {
      const double t = ta + (tb - ta) * k / 300.0;
      const double d = vadop::distance(pa, ma.poseAt(t), pb, mb.poseAt(t)).distance;
      lowest = std::min(lowest, d);
      ASSERT_GE(d, sb.lower_bound - 1e-12)
          << "case " << c << ": sampled gap " << d << " at t = " << t << " below the certified " << sb.lower_bound
          << " over [" << ta << ", " << tb << "], types " << vadop::toString(a.type) << " / "
          << vadop::toString(b.type) << " wa " << ma.angular_velocity.transpose() << " pa " << ma.pivot_offset.transpose()
          << " wb " << mb.angular_velocity.transpose() << " pb " << mb.pivot_offset.transpose() << " r " << a.radius << "," << b.radius << " hl " << b.half_length << " margin " << a.margin << "," << b.margin
          << " posa " << ma.positionAt(t).transpose() << " posb " << mb.positionAt(t).transpose();
    }
    if (lowest - sb.lower_bound < 0.05) ++tight;
  }
  std::printf("swept volumes: %d cases with a bound, %d certify clear, %d within 5 cm of the sampled minimum\n",
              checked, certified, tight);
  EXPECT_GE(certified, 300);  // not vacuous
  EXPECT_GE(tight, 30);       // ... and sometimes close to the truth
}

// ---------------------------------------------------------------------------------------
// The numerical range (error.h; issue 13, defect 10).

TEST(Range, MotionLimitsInsideAndJustBeyond) {
  const double beyond = 1.0 + 1e-12;
  struct Case {
    const char* field;
    std::function<void(Motion&, double)> set;
    double limit;
  };
  const std::vector<Case> cases = {
      {"position[0]", [](Motion& m, double x) { m.position.x() = x; }, vadop::kMaxCoordinate},
      {"position[2]", [](Motion& m, double x) { m.position.z() = -x; }, vadop::kMaxCoordinate},
      {"pivot_offset[1]", [](Motion& m, double x) { m.pivot_offset.y() = x; }, vadop::kMaxCoordinate},
      {"|linear_velocity|", [](Motion& m, double x) { m.linear_velocity = Vector3d(0.6, -0.8, 0) * x; },
       vadop::kMaxLinearSpeed},
      {"|angular_velocity|", [](Motion& m, double x) { m.angular_velocity = Vector3d(0, 0.8, 0.6) * x; },
       vadop::kMaxAngularSpeed},
      {"t_ref", [](Motion& m, double x) { m.t_ref = -x; }, vadop::kMaxTime},
  };
  for (const Case& c : cases) {
    Motion in = motion(Vector3d::Zero());
    c.set(in, c.limit * (1.0 - 1e-12));
    EXPECT_NO_THROW(vadop::validateMotion(in, "m")) << c.field;
    Motion out = motion(Vector3d::Zero());
    c.set(out, c.limit * beyond);
    EXPECT_FALSE(vadop::isValidMotion(out)) << c.field;
    try {
      vadop::validateMotion(out, "m");
      ADD_FAILURE() << c.field << " beyond its limit accepted";
    } catch (const vadop::InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("beyond"), std::string::npos) << e.what();
    }
    // timeOfImpact checks its motions too.
    EXPECT_THROW(vadop::timeOfImpact(vadop::makeSphere(1), out, vadop::makeSphere(1), motion(Vector3d(5, 0, 0)), 0, 1),
                 vadop::InvalidArgument)
        << c.field;
  }
  // makeMotion: the same limits.
  const Quaterniond I = Quaterniond::Identity();
  const Vector3d z = Vector3d::Zero();
  EXPECT_NO_THROW(vadop::makeMotion(Vector3d(vadop::kMaxCoordinate, 0, 0), I, z, z));
  EXPECT_THROW(vadop::makeMotion(Vector3d(vadop::kMaxCoordinate * beyond, 0, 0), I, z, z), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makeMotion(Vector3d(1e12, 0, 0), I, z, z), vadop::InvalidArgument);  // the boxes
  EXPECT_NO_THROW(vadop::makeMotion(z, I, Vector3d(0, 0, vadop::kMaxLinearSpeed), z));
  EXPECT_THROW(vadop::makeMotion(z, I, Vector3d(0, 0, vadop::kMaxLinearSpeed * beyond), z), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makeMotion(z, I, Vector3d(1e150, 0, 0), z), vadop::InvalidArgument);  // the spheres
  EXPECT_NO_THROW(vadop::makeMotion(z, I, z, Vector3d(vadop::kMaxAngularSpeed, 0, 0)));
  EXPECT_THROW(vadop::makeMotion(z, I, z, Vector3d(vadop::kMaxAngularSpeed * beyond, 0, 0)), vadop::InvalidArgument);
  EXPECT_NO_THROW(vadop::makeMotion(z, I, z, z, vadop::kMaxTime));
  EXPECT_THROW(vadop::makeMotion(z, I, z, z, vadop::kMaxTime * beyond), vadop::InvalidArgument);
  // A huge finite velocity whose square overflows: named with its value, not as "not finite".
  try {
    vadop::makeMotion(z, I, Vector3d(1e200, 1e200, 0), z);
    ADD_FAILURE() << "accepted";
  } catch (const vadop::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("beyond"), std::string::npos) << e.what();
  }
  // isValidMotion never says yes to a NaN anywhere.
  Motion nan = motion(Vector3d::Zero());
  nan.position.y() = std::nan("");
  EXPECT_FALSE(vadop::isValidMotion(nan));
  nan = motion(Vector3d::Zero());
  nan.pivot_offset.z() = std::nan("");
  EXPECT_FALSE(vadop::isValidMotion(nan));
}

TEST(Range, RangeErrorMessages) {
  EXPECT_EQ(vadop::rangeError(1e7, 1e7, "x", "m"), "");
  EXPECT_EQ(vadop::rangeError(-1e7, 1e7, "x", "m"), "");
  EXPECT_EQ(vadop::rangeError(2e7, 1e7, "position[0]", "m"), "position[0] = 20000000 is beyond 10000000 m");
  EXPECT_EQ(vadop::rangeError(std::nan(""), 1e7, "t_ref", "s"), "t_ref = nan is not finite");
  EXPECT_EQ(vadop::rangeError(-std::numeric_limits<double>::infinity(), 1e7, "t", "s"), "t = -inf is not finite");
}

TEST(Range, SphereSphereAtTheEdgesOfTheRange) {
  // Spheres of the largest radius at +-kMaxCoordinate closing at the largest speed: the closed
  // form stays exact (it squared |d0| ~ 1e14 before, fine, but 1e150 overflowed).
  const double r = vadop::kMaxSize, x = vadop::kMaxCoordinate, v = 0.5 * vadop::kMaxLinearSpeed;
  const Shape big = vadop::makeSphere(r);
  const TimeOfImpact imp = vadop::timeOfImpact(big, motion(Vector3d(-x, 0, 0), Vector3d(v, 0, 0)), big,
                                         motion(Vector3d(x, 0, 0), Vector3d(-v, 0, 0)), 0.0, 2000.0);
  const double t_star = (2 * x - 2 * r) / (2 * v);
  expectTime(imp, t_star, 2 * v);
  expectNormal(imp, Vector3d::UnitX());
  // Tiny and slow: 1 um spheres 10 um apart closing at 1 nm/s, with a tolerance of 1e-9 m.
  ToiOptions fine;
  fine.tolerance = 1e-9;
  const Shape tiny = vadop::makeSphere(1e-6);
  const TimeOfImpact small = vadop::timeOfImpact(tiny, motion(Vector3d::Zero()), tiny,
                                           motion(Vector3d(1e-5, 0, 0), Vector3d(-1e-9, 0, 0)), 0.0, 1e5, fine);
  expectTime(small, (1e-5 - 2e-6) / 1e-9, 1e-9, 1e-9);
  // Crossing paths at the largest speed, far out: a miss by 1 m stays a miss.
  const TimeOfImpact miss = vadop::timeOfImpact(vadop::makeSphere(1.0), motion(Vector3d(-x, 0, 0), Vector3d(1e4, 0, 0)),
                                          vadop::makeSphere(1.0), motion(Vector3d(x, 3.0, 0), Vector3d(-1e4, 0, 0)),
                                          0.0, 3000.0);
  EXPECT_FALSE(miss.hit);
}

}  // namespace
