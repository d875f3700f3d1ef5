// The point reported for bodies in contact at the start (contact_patch.h), checked against
// geometry written here from the shapes' definitions (distances to a sphere, segment, box,
// cylinder, triangle, ...), never from the library: for every pair of shape kinds, touching and
// overlapping, the point lies in both shapes (grown by 1e-6 of their size plus the overlap), and
// for faces meeting face to face at the patch's centroid, the patch sampled densely on the
// contact plane. Then cases from other projects' suites and every path that reports a contact at
// the start (twist, TimedPath, LinkChain, World::predict).
#include "vadop/distance.h"
#include "vadop/joint_chain.h"
#include "vadop/time_of_impact.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace {

using Eigen::Isometry3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// ---- Independent geometry: the distance from a point (body frame) to a shape; 0 inside a solid.

double segmentDistance(const Vector3d& x, const Vector3d& a, const Vector3d& b) {
  const Vector3d e = b - a;
  const double ee = e.squaredNorm();
  const double s = ee > 0.0 ? std::clamp((x - a).dot(e) / ee, 0.0, 1.0) : 0.0;
  return (x - (a + s * e)).norm();
}

// To a triangle: the plane when the foot falls inside it (barycentric signs), else the nearest edge.
double triangleDistance(const Vector3d& x, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 1e-24) {
    const Vector3d m = n.normalized();
    const Vector3d f = x - m.dot(x - a) * m;
    const double s1 = (b - a).cross(f - a).dot(m), s2 = (c - b).cross(f - b).dot(m), s3 = (a - c).cross(f - c).dot(m);
    if (s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0) return std::abs(m.dot(x - a));
  }
  return std::min({segmentDistance(x, a, b), segmentDistance(x, b, c), segmentDistance(x, c, a)});
}

double boxSigned(const Vector3d& x, const Vector3d& h) {
  const Vector3d q = x.cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

struct Kind {
  std::string name;
  vadop::Shape shape;
  std::function<double(const Vector3d&)> distance;  // body frame
  double size;                                      // its largest distance from the origin
};

using Tri = std::array<Vector3d, 3>;

double trianglesDistance(const std::vector<Tri>& tris, const Vector3d& x) {
  double d = 1e300;
  for (const Tri& t : tris) d = std::min(d, triangleDistance(x, t[0], t[1], t[2]));
  return d;
}

std::vector<Kind> kinds() {
  std::vector<Kind> k;
  k.push_back({"sphere", vadop::makeSphere(0.5), [](const Vector3d& x) { return std::max(x.norm() - 0.5, 0.0); }, 0.5});
  k.push_back({"capsule", vadop::makeCapsule(0.3, 0.8),
               [](const Vector3d& x) {
                 return std::max(segmentDistance(x, Vector3d(0, 0, -0.4), Vector3d(0, 0, 0.4)) - 0.3, 0.0);
               },
               0.7});
  const Vector3d hb(0.5, 0.4, 0.3);
  k.push_back({"box", vadop::makeBox(2.0 * hb), [hb](const Vector3d& x) { return std::max(boxSigned(x, hb), 0.0); },
               hb.norm()});
  k.push_back({"cylinder", vadop::makeCylinder(0.4, 0.9),
               [](const Vector3d& x) {
                 const double dr = std::max(std::hypot(x.x(), x.y()) - 0.4, 0.0);
                 const double dz = std::max(std::abs(x.z()) - 0.45, 0.0);
                 return std::hypot(dr, dz);
               },
               std::hypot(0.4, 0.45)});
  // A tetrahedron: 0 inside its four faces' half-spaces, else the nearest face.
  const std::vector<Vector3d> tp = {{0.6, 0, -0.3}, {-0.3, 0.5, -0.3}, {-0.3, -0.5, -0.3}, {0, 0, 0.6}};
  const std::vector<Tri> tf = {
      {tp[0], tp[2], tp[1]}, {tp[0], tp[1], tp[3]}, {tp[1], tp[2], tp[3]}, {tp[2], tp[0], tp[3]}};
  k.push_back({"convex", vadop::makeConvex(tp),
               [tf](const Vector3d& x) {
                 bool inside = true;
                 for (const Tri& t : tf) inside = inside && (t[1] - t[0]).cross(t[2] - t[0]).dot(x - t[0]) <= 0.0;
                 return inside ? 0.0 : trianglesDistance(tf, x);
               },
               0.6});
  // A box's surface as a mesh of 12 triangles.
  const Vector3d hm(0.45, 0.35, 0.4);
  std::vector<Vector3d> mv;
  for (int i = 0; i < 8; ++i) {
    mv.emplace_back(i & 1 ? hm.x() : -hm.x(), i & 2 ? hm.y() : -hm.y(), i & 4 ? hm.z() : -hm.z());
  }
  const std::vector<std::array<int, 3>> mt = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::vector<Tri> mtris;
  for (const auto& t : mt) mtris.push_back({mv[t[0]], mv[t[1]], mv[t[2]]});
  k.push_back({"mesh", vadop::makeMesh(mv, mt), [mtris](const Vector3d& x) { return trianglesDistance(mtris, x); },
               hm.norm()});
  std::vector<Vector3d> pts;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) pts.emplace_back(-0.3 + 0.3 * i, -0.3 + 0.3 * j, 0.1 * ((i + j) % 2));
  }
  k.push_back({"point_set", vadop::makePointSet(pts, 0.15),
               [pts](const Vector3d& x) {
                 double d = 1e300;
                 for (const Vector3d& p : pts) d = std::min(d, (x - p).norm());
                 return std::max(d - 0.15, 0.0);
               },
               std::hypot(0.3, 0.3, 0.1) + 0.15});
  // Boxes' surfaces (the box set is a mesh of their faces).
  const std::vector<Vector3d> bc = {{0, 0, 0}, {0.4, 0, 0}, {0, 0.4, 0.2}};
  const Vector3d hs(0.2, 0.2, 0.2);
  k.push_back({"box_set", vadop::makeBoxSet(bc, 2.0 * hs),
               [bc, hs](const Vector3d& x) {
                 double d = 1e300;
                 for (const Vector3d& c : bc) d = std::min(d, std::abs(boxSigned(x - c, hs)));
                 return d;
               },
               (Vector3d(0.4, 0, 0) + hs).norm()});
  return k;
}

struct Posed {
  const Kind* kind;
  Isometry3d pose;
  double distance(const Vector3d& x) const { return kind->distance(pose.inverse() * x); }
};

vadop::Motion still(const Isometry3d& pose, const Vector3d& v = Vector3d::Zero()) {
  return vadop::makeMotion(pose.translation(), Quaterniond(pose.linear()), v, Vector3d::Zero(), 0.0);
}

// B along u from A, its gap to A just >= 0 (coming in from far, then bisection): the library's
// distance only places the bodies; what is checked is measured on the geometry above.
Isometry3d touchingPose(const vadop::PreparedShape& a, const Isometry3d& pa, const vadop::PreparedShape& b,
                        Isometry3d pb, const Vector3d& u) {
  const Vector3d base = pb.translation();
  auto gap = [&](double s) {
    pb.translation() = base + s * u;
    return vadop::distance(a, pa, b, pb).distance;
  };
  double hi = a.shape().bounding_radius + b.shape().bounding_radius + 0.1, lo = hi;
  const double step = 0.02;
  while (gap(lo) > 0.0) {
    hi = lo;
    lo -= step;
  }
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (lo + hi);
    (gap(m) > 0.0 ? hi : lo) = m;
  }
  pb.translation() = base + hi * u;
  return pb;
}

// The contact patch sampled on the plane through `at` normal to n: the points within eta of both
// shapes on a grid of spacing h about `around`, radius r.
std::vector<Vector3d> samplePatch(const Posed& A, const Posed& B, const Vector3d& at, const Vector3d& n,
                                  const Vector3d& around, double r, double h, double eta) {
  const Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  const Vector3d c = around + n.dot(at - around) * n;
  std::vector<Vector3d> in;
  const int m = static_cast<int>(std::ceil(r / h));
  for (int i = -m; i <= m; ++i) {
    for (int j = -m; j <= m; ++j) {
      const Vector3d x = c + i * h * u + j * h * v;
      if (A.distance(x) <= eta && B.distance(x) <= eta) in.push_back(x);
    }
  }
  return in;
}

struct Trial {
  Posed A, B;
  double overlap;  // B moved this far into A after touching (an upper bound of the depth)
  bool aligned;    // both axis-aligned, B straight above A: faces meet face to face
};

// The reported point lies in both shapes grown by 1e-6 of their size plus the overlap; touching
// face to face, it lies in the sampled patch, at its centroid when the patch has area.
void checkTrial(const Trial& tr, const vadop::TimeOfImpact& hit, const std::string& what, int& centroid_checks) {
  ASSERT_TRUE(hit.hit) << what;
  ASSERT_TRUE(hit.initially_touching) << what;
  const Vector3d p = hit.point;
  EXPECT_LE(tr.A.distance(p), 1e-6 * tr.A.kind->size + tr.overlap)
      << what << " point " << p.transpose() << " normal " << hit.normal.transpose() << " distance " << hit.distance;
  EXPECT_LE(tr.B.distance(p), 1e-6 * tr.B.kind->size + tr.overlap) << what << " point " << p.transpose();
  if (!tr.aligned || tr.overlap > 0.0) return;
  const double r = tr.B.kind->size, h = r / 60.0;
  const std::vector<Vector3d> patch =
      samplePatch(tr.A, tr.B, p, Vector3d::UnitZ(), tr.B.pose.translation(), r, h, 2e-6 * (tr.A.kind->size + r));
  // A face on a face: the patch has area (points and lines, as a point set's balls or a side on
  // a face, fall between the grid's points: checked above).
  if (!(patch.size() * h * h > 0.02 * r * r)) return;
  ++centroid_checks;
  double nearest = 1e300;
  Vector3d mean = Vector3d::Zero();
  for (const Vector3d& x : patch) {
    nearest = std::min(nearest, (x - p).norm());
    mean += x / static_cast<double>(patch.size());
  }
  EXPECT_LE(nearest, 1.5 * h) << what << " outside the patch: " << p.transpose();
  EXPECT_LE((mean - p).norm(), 2.0 * h + 0.01 * r) << what << " centroid " << mean.transpose() << " point "
                                                   << p.transpose();
}

// Trials for each ordered pair of kinds, half of them face on face: fewer under the sanitizers
// (instrumented code runs ~20x slower; the same paths are exercised).
#if defined(__SANITIZE_ADDRESS__)
constexpr int kTrialsPerPair = 2;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kTrialsPerPair = 2;
#else
constexpr int kTrialsPerPair = 6;
#endif
#else
constexpr int kTrialsPerPair = 6;
#endif

Quaterniond randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
}

TEST(ContactPatch, PointInBothShapesForEveryPairOfKinds) {
  const std::vector<Kind> ks = kinds();
  std::mt19937 rng(52);
  std::uniform_real_distribution<double> uni(-1.0, 1.0), frac(0.01, 1.0);
  int trials = 0, centroid_checks = 0;
  for (size_t i = 0; i < ks.size(); ++i) {
    for (size_t j = 0; j < ks.size(); ++j) {
      const vadop::PreparedShape a(ks[i].shape), b(ks[j].shape);
      for (int k = 0; k < kTrialsPerPair; ++k) {
        const bool aligned = k < kTrialsPerPair / 2;
        Isometry3d pa = Isometry3d::Identity(), pb = Isometry3d::Identity();
        pa.translation() = Vector3d(uni(rng), uni(rng), uni(rng));
        Vector3d u = Vector3d::UnitZ();
        if (aligned) {
          const double shift = 0.3 * std::min(ks[i].size, ks[j].size);
          pb.translation() = pa.translation() + shift * Vector3d(uni(rng), uni(rng), 0);
        } else {
          pa.linear() = randomRotation(rng).toRotationMatrix();
          pb.linear() = randomRotation(rng).toRotationMatrix();
          pb.translation() = pa.translation();
          u = Vector3d(uni(rng), uni(rng), uni(rng)).normalized();
        }
        pb = touchingPose(a, pa, b, pb, u);
        for (const bool overlap : {false, true}) {
          Trial tr{{&ks[i], pa}, {&ks[j], pb}, 0.0, aligned};
          if (overlap) {
            tr.overlap = 0.1 * std::min(ks[i].size, ks[j].size) * frac(rng);
            tr.B.pose.translation() -= tr.overlap * u;
          }
          const std::string what = ks[i].name + " / " + ks[j].name + " trial " + std::to_string(k) +
                                   (overlap ? " overlapping" : " touching");
          const vadop::TimeOfImpact hit =
              vadop::timeOfImpact(a, still(pa), b, still(tr.B.pose, -u), 0.0, 1.0, vadop::ToiOptions{});
          checkTrial(tr, hit, what, centroid_checks);
          ++trials;
        }
      }
    }
  }
  EXPECT_EQ(trials, 8 * 8 * 2 * kTrialsPerPair);
  // Faces on faces: box, cylinder, convex, mesh and box set on each other's tops.
  EXPECT_GE(centroid_checks, 15 * kTrialsPerPair / 2);
}

// Jolt's CastShapeTests "TestCast2DBoxVsBox": a flat 2 x 2 square (a convex point set) touching
// the top face z = 1 of a 10 x 10 x 2 box at the start and moving into it: the contact at
// (0, 0, 1), to 1e-4.
TEST(ContactPatch, JoltSquareOnBox) {
  const vadop::Shape box = vadop::makeConvex({{-5, -5, 1}, {5, -5, 1}, {5, 5, 1}, {-5, 5, 1},
                                              {-5, -5, -1}, {5, -5, -1}, {5, 5, -1}, {-5, 5, -1}});
  const vadop::Shape square = vadop::makeConvex({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}});
  Isometry3d at = Isometry3d::Identity();
  at.translation() = Vector3d(0, 0, 1);
  const vadop::TimeOfImpact hit =
      vadop::timeOfImpact(square, still(at, Vector3d(0, 0, -10)), box, still(Isometry3d::Identity()), 0.0, 1.0);
  ASSERT_TRUE(hit.hit);
  EXPECT_TRUE(hit.initially_touching);
  EXPECT_LE((hit.point - Vector3d(0, 0, 1)).norm(), 1e-4) << hit.point.transpose();
  EXPECT_NEAR(std::abs(hit.normal.z()), 1.0, 1e-9);
}

// A 2 x 2 x 2 box resting on the top face of a 10 x 10 box (10 x 10 x 2 about the origin), its
// centre at (x, y, 2): the point in the 2 x 2 patch under it, at its centre.
TEST(ContactPatch, BoxRestingOnBox) {
  const vadop::Shape big = vadop::makeBox(Vector3d(10, 10, 2)), small = vadop::makeBox(Vector3d(2, 2, 2));
  for (const Vector3d& c : {Vector3d(0, 0, 2), Vector3d(3.5, -2, 2), Vector3d(-4, 4, 2)}) {
    Isometry3d at = Isometry3d::Identity();
    at.translation() = c;
    const vadop::TimeOfImpact hit =
        vadop::timeOfImpact(big, still(Isometry3d::Identity()), small, still(at, Vector3d(0.3, 0, -1)), 0.0, 1.0);
    ASSERT_TRUE(hit.hit);
    EXPECT_TRUE(hit.initially_touching);
    EXPECT_LE((hit.point - Vector3d(c.x(), c.y(), 1)).norm(), 1e-9) << hit.point.transpose();
  }
}

// Jolt's CastShapeTests "TestCastShapeSphereVsBox": a unit sphere centred on the top face y = 11
// of a box 2 x 20 x 2 about (0, 1, 0), depth 1: the point under the sphere's centre, midway
// through the penetration, (0, 10.5, 0).
TEST(ContactPatch, JoltSphereStartingInBox) {
  const vadop::Shape box = vadop::makeBox(Vector3d(2, 20, 2)), sphere = vadop::makeSphere(1.0);
  Isometry3d pb = Isometry3d::Identity(), ps = Isometry3d::Identity();
  pb.translation() = Vector3d(0, 1, 0);
  ps.translation() = Vector3d(0, 11, 0);
  const vadop::TimeOfImpact hit =
      vadop::timeOfImpact(sphere, still(ps, Vector3d(0, 1, 0)), box, still(pb), 0.0, 1.0);
  ASSERT_TRUE(hit.hit);
  EXPECT_TRUE(hit.initially_touching);
  EXPECT_NEAR(hit.distance, -1.0, 1e-9);
  EXPECT_LE((hit.point - Vector3d(0, 10.5, 0)).norm(), 1e-9) << hit.point.transpose();
}

// Every path reporting a contact at the start gives the patch's centre: a 1 x 1 x 1 box on the
// top face z = 0.5 of a 4 x 4 x 1 mesh box, centred at (1, -1, 1), under a turning motion, a
// TimedPath, a LinkChain whose joint turns, and World::predict.
TEST(ContactPatch, EveryPathReportsThePatch) {
  std::vector<Vector3d> v;
  for (int i = 0; i < 8; ++i) v.emplace_back(i & 1 ? 2.0 : -2.0, i & 2 ? 2.0 : -2.0, i & 4 ? 0.5 : -0.5);
  const std::vector<std::array<int, 3>> t = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  const vadop::Shape floor = vadop::makeMesh(v, t), cube = vadop::makeBox(Vector3d(1, 1, 1));
  const vadop::PreparedShape pf(floor), pc(cube);
  const Vector3d c(1, -1, 1), expected(1, -1, 0.5);
  const vadop::Motion ground = still(Isometry3d::Identity());
  const vadop::Motion turning = vadop::makeMotion(c, Quaterniond::Identity(), Vector3d(0, 0, -0.5), Vector3d(0, 0, 1));
  const vadop::TimeOfImpact twist = vadop::timeOfImpact(pc, turning, pf, ground, 0.0, 1.0);
  ASSERT_TRUE(twist.hit);
  EXPECT_LE((twist.point - expected).norm(), 1e-9) << "twist " << twist.point.transpose();

  const vadop::TimeOfImpact path =
      vadop::timeOfImpact(pc, vadop::TimedPath(turning), pf, vadop::TimedPath(ground), 0.0, 1.0);
  ASSERT_TRUE(path.hit);
  EXPECT_LE((path.point - expected).norm(), 1e-9) << "TimedPath " << path.point.transpose();

  // The cube on a revolute joint about the base's z axis, turning: the twist narrow phase and,
  // for the mesh, its distance queries.
  vadop::ChainJoint joint;
  joint.type = vadop::JointType::kRevolute;
  joint.path = vadop::JointPath::constantVelocity(0.0, 0.0, 0.5);
  Isometry3d link = Isometry3d::Identity();
  link.translation() = c;
  joint.origin = link;
  const vadop::LinkChain arm(vadop::TimedPath(ground), {joint});
  const vadop::LinkChain base{vadop::TimedPath(ground)};
  const vadop::TimeOfImpact chain = vadop::timeOfImpact(pc, arm, pf, base, 0.0, 1.0);
  ASSERT_TRUE(chain.hit);
  EXPECT_LE((chain.point - expected).norm(), 1e-9) << "LinkChain " << chain.point.transpose();
  const vadop::Shape floor_box = vadop::makeBox(Vector3d(4, 4, 1));
  const vadop::TimeOfImpact chain_box = vadop::timeOfImpact(vadop::PreparedShape(cube), arm,
                                                            vadop::PreparedShape(floor_box), base, 0.0, 1.0);
  ASSERT_TRUE(chain_box.hit);
  EXPECT_LE((chain_box.point - expected).norm(), 1e-9) << "LinkChain, twist steps " << chain_box.point.transpose();

  vadop::World world;
  world.add("floor", floor, ground);
  world.add("cube", cube, turning);
  const std::vector<vadop::Contact> contacts = world.predict(0.0, 1.0);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_LE((contacts[0].impact.point - expected).norm(), 1e-9) << "World " << contacts[0].impact.point.transpose();
}

}  // namespace
