// Point sets and box sets (makePointSet, makeBoxSet: what a sensor sees, as one mesh shape under
// the mesh's bounding-volume tree) against an independent brute force over their parts:
//  1. Property tests: a scan-like arc of 1,081 points a few metres away, a random cloud of 2,000
//     points, and an occupancy grid's cells as boxes, against a mover of every shape kind under
//     every motion kind (a constant twist, a TimedPath, a LinkChain whose joint moves, and the
//     gate's braking manoeuvre through World::firstContactAlong). The brute force asks the same
//     query of each point's ball (makeSphere) or each cell's box (makeBox) on its own, a
//     primitive that never enters the mesh code, and takes the minimum. With the query's
//     tolerance tau, two brute forces bracket every correct answer: one at tau / 4 (a contact
//     there is a real one: the gap falls below tau / 2, which the query must report, no later)
//     and one at 2 tau (certified clear up to its time: the query cannot report earlier). 0
//     missed, 0 false; a reported contact also has the brute force's gap within tau at its
//     time, its point on some part and a unit normal. Movers never start within 10 tau.
//  2. World::predict and World::firstContactIf with a point set among 60 movers: the same bracket.
//  3. Analytic corners: a sphere driving at a wall of points spaced closer than their radius
//     (exact time and normal, aimed at a point and between four), a body passing between two
//     points farther apart than its size (no contact; a slightly larger one hits at the exact
//     time), a box set's face (exact time from outside; a body beside the face passes).
//  4. Static distance and penetration (degenerate triangles: a point's normal is not needed; a
//     point inside a mesh body is not touched, inside a solid one it is),
//     and the constructors' errors.
// VADOP_POINT_SET_CASES: scenes per (set, shape kind, motion kind), default 6 (2 under ASan).
#include "vadop/distance.h"  // PreparedShape (src/), for the path and chain queries
#include "vadop/error.h"
#include "vadop/joint_chain.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"

#include "mesh_bvh.h"    // partsMeetingTree (src/)
#include "shape_core.h"  // the tree's nodes (src/)
#include "toi_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace {

using Eigen::Isometry3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using toi_scenes::Rng;
using vadop::ChainJoint;
using vadop::JointPath;
using vadop::JointType;
using vadop::Keyframe;
using vadop::LinkChain;
using vadop::Motion;
using vadop::PreparedShape;
using vadop::Shape;
using vadop::ShapeType;
using vadop::TimedPath;
using vadop::TimeOfImpact;
using vadop::ToiOptions;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 1e-4;     // m: the tolerance of the queries under test
constexpr double kEps = 1e-9;     // s: rounding allowance between certified times
constexpr double kHorizon = 2.0;  // s
const ShapeType kShapeKinds[] = {ShapeType::kSphere,   ShapeType::kBox,    ShapeType::kCapsule,
                                 ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};

int scenesPerCombination() {
  const char* env = std::getenv("VADOP_POINT_SET_CASES");
  if (env != nullptr && *env != '\0' && std::atoi(env) > 0) return std::atoi(env);
#if defined(__SANITIZE_ADDRESS__)
  return 2;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return 2;
#endif
#endif
  return 6;
}

Motion rest(const Vector3d& at) {
  return vadop::makeMotion(at, Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero());
}

Isometry3d translation(const Vector3d& at) {
  Isometry3d pose = Isometry3d::Identity();
  pose.translation() = at;
  return pose;
}

// ---------------------------------------------------------------------------------------
// Obstacles: one shape for the library, its parts one by one for the brute force.

struct PartSet {
  std::string name;
  Shape shape;                 // makePointSet / makeBoxSet in its body frame, posed at `centre`
  Vector3d centre;             // the parts' centroid (fixed frame)
  Shape part;                  // one ball or one box
  std::vector<Vector3d> parts; // the parts' centres (fixed frame)
  bool boxes = false;
};

Vector3d centroid(const std::vector<Vector3d>& points) {
  Vector3d c = Vector3d::Zero();
  for (const Vector3d& p : points) c += p;
  return c / static_cast<double>(points.size());
}

std::vector<Vector3d> relative(const std::vector<Vector3d>& points, const Vector3d& c) {
  std::vector<Vector3d> out;
  for (const Vector3d& p : points) out.push_back(p - c);
  return out;
}

PartSet pointSet(const std::string& name, const std::vector<Vector3d>& points, double radius) {
  PartSet s;
  s.name = name;
  s.centre = centroid(points);
  s.shape = vadop::makePointSet(relative(points, s.centre), radius);
  s.part = vadop::makeSphere(radius);
  s.parts = points;
  return s;
}

PartSet boxSet(const std::string& name, const std::vector<Vector3d>& centres, const Vector3d& size) {
  PartSet s;
  s.name = name;
  s.centre = centroid(centres);
  s.shape = vadop::makeBoxSet(relative(centres, s.centre), size);
  s.part = vadop::makeBox(size);
  s.parts = centres;
  s.boxes = true;
  return s;
}

// A 270-degree scan of 1,081 beams from a scanner at the origin, 0.3 m up: walls that wander
// between 1.9 and 4.1 m; the 90 degrees behind are open.
PartSet scanArc() {
  std::vector<Vector3d> points;
  for (int i = 0; i < 1081; ++i) {
    const double th = -0.75 * kPi + 1.5 * kPi * i / 1080.0;
    const double range = 3.0 + 0.8 * std::sin(2.0 * th + 0.4) + 0.3 * std::sin(7.0 * th);
    points.emplace_back(range * std::cos(th), range * std::sin(th), 0.3);
  }
  return pointSet("scan", points, 0.02);
}

// 2,000 points spread through a shell 1.2 to 3 m from the origin, 0.5 m below to 1.5 m above.
PartSet cloud() {
  Rng r(4901);
  std::vector<Vector3d> points;
  while (points.size() < 2000) {
    const Vector3d p(r.uni(-3.0, 3.0), r.uni(-3.0, 3.0), r.uni(-0.5, 1.5));
    const double d = p.head<2>().norm();
    if (d >= 1.2 && d <= 3.0) points.push_back(p);
  }
  return pointSet("cloud", points, 0.03);
}

// An occupancy grid's occupied cells (5 cm, as 0.4 m tall boxes): a 5 m room's walls with two
// doorways and a few pallets.
PartSet gridCells() {
  constexpr double kCell = 0.05;
  std::vector<Vector3d> centres;
  auto cell = [&](int i, int j) { centres.emplace_back((i + 0.5) * kCell, (j + 0.5) * kCell, 0.2); };
  for (int k = -50; k < 50; ++k) {
    if (k < 10 || k > 20) cell(k, -50), cell(k, 49);  // doorways in the two x walls
    cell(-50, k);
    if (k < -25 || k > -12) cell(49, k);
  }
  Rng r(4902);
  for (int pallet = 0; pallet < 6; ++pallet) {
    const int i0 = r.integer(-45, 35), j0 = r.integer(-45, 35);
    if (std::abs(i0) < 28 && std::abs(j0) < 28) continue;  // the middle stays free
    for (int i = 0; i < 8; ++i)
      for (int j = 0; j < 12; ++j) cell(i0 + i, j0 + j);
  }
  return boxSet("grid", centres, Vector3d(kCell, kCell, 0.4));
}

const std::vector<PartSet>& partSets() {
  static const std::vector<PartSet> sets = {scanArc(), cloud(), gridCells()};
  return sets;
}

// ---------------------------------------------------------------------------------------
// A mover, its query against one other body at rest, and the brute force over a set's parts.

struct Mover {
  Shape shape;
  // The query: the mover against `other` at rest at `at`, over [0, t1], with tolerance tol.
  std::function<TimeOfImpact(const PreparedShape& mover, const PreparedShape& other, const Vector3d& at, double t1,
                             double tol)>
      toi;
  std::function<Isometry3d(double t)> poseAt;
  Vector3d origin0 = Vector3d::Zero();
  // Every point of the mover stays within the union of these balls over the window (the test's
  // own bounds: the brute force asks only the parts near them).
  struct Ball {
    Vector3d centre;
    double radius;
  };
  std::vector<Ball> reach;
  double horizon = kHorizon;
  // The gate's manoeuvre (asked through World::firstContactAlong): its path and the bound of
  // appendBrakingKeyframes.
  std::optional<TimedPath> manoeuvre;
  double deviation = 0.0;
  std::optional<Motion> twist;  // a constant twist's motion (for World::predict)
};

struct Verdict {
  bool hit = false, undecided = false;
  double time = kInf;
};

// The parts that the mover may reach, whatever its motion (the test's own bound, with margin).
std::vector<Vector3d> nearParts(const PartSet& s, const Mover& m, double tol) {
  std::vector<Vector3d> out;
  for (const Vector3d& c : s.parts) {
    for (const Mover::Ball& b : m.reach) {
      if ((c - b.centre).norm() <= b.radius + s.part.bounding_radius + 2.0 * tol) {
        out.push_back(c);
        break;
      }
    }
  }
  return out;
}

// The query asked of each part on its own; the first contact (or undecided) over all of them.
Verdict bruteForce(const std::vector<Vector3d>& parts, const PreparedShape& part, const Mover& m,
                   const PreparedShape& mover, double tol) {
  Verdict v;
  double t1 = m.horizon;
  for (const Vector3d& c : parts) {
    const TimeOfImpact r = m.toi(mover, part, c, t1, tol);
    if ((r.hit || r.undecided) && r.time <= t1) {
      v.hit = r.hit;
      v.undecided = r.undecided;
      v.time = r.time;
      t1 = r.time;
    }
  }
  return v;
}

// The gap between the mover at t and the nearest part, by the static distance of primitives.
double bruteGap(const std::vector<Vector3d>& parts, const Shape& part, const Mover& m, double t) {
  double gap = kInf;
  for (const Vector3d& c : parts) {
    gap = std::min(gap, vadop::distance(m.shape, m.poseAt(t), part, translation(c)).distance);
  }
  return gap;
}

// How far a point is from the nearest part (0 inside).
double pointToParts(const PartSet& s, const Vector3d& x) {
  double best = kInf;
  for (const Vector3d& c : s.parts) {
    if (s.boxes) {
      best = std::min(best, ((x - c).cwiseAbs() - s.part.half_extents).cwiseMax(0.0).norm());
    } else {
      best = std::min(best, std::max(0.0, (x - c).norm() - s.part.radius));
    }
  }
  return best;
}

struct Tally {
  int cases = 0, hits = 0, clear = 0, in_band = 0, missed = 0, wrong = 0, undecided = 0;
  std::string first_failure;
  void fail(const std::string& what) {
    if (first_failure.empty()) first_failure = what;
  }
};

// The two brute forces that bracket every correct answer of a query of tolerance tau.
struct Bracket {
  std::vector<Vector3d> parts;  // those the mover may reach
  Verdict tight, loose;         // at tau / 4 and 2 tau
};

Bracket bracket(const PartSet& s, const Mover& m, double tau) {
  const PreparedShape part(s.part), mover(m.shape);
  Bracket b;
  b.parts = nearParts(s, m, tau);
  b.tight = bruteForce(b.parts, part, m, mover, 0.25 * tau);
  b.loose = bruteForce(b.parts, part, m, mover, 2.0 * tau);
  return b;
}

// The query's answer `ours` (tolerance tau) against the bracket.
void judge(const PartSet& s, const Mover& m, const Bracket& b, const TimeOfImpact& ours, double tau,
           const std::string& label, Tally& tally) {
  ++tally.cases;
  const Verdict& tight = b.tight;
  const Verdict& loose = b.loose;
  char buf[320];
  std::snprintf(buf, sizeof buf, "%s: ours hit %d t %.9f undecided %d; brute tau/4 hit %d t %.9f, 2 tau hit %d t %.9f",
                label.c_str(), ours.hit, ours.time, ours.undecided, tight.hit, tight.time, loose.hit, loose.time);
  if (ours.undecided || tight.undecided || loose.undecided) {
    ++tally.undecided;
    tally.fail(std::string("undecided: ") + buf);
    return;
  }
  ours.hit ? ++tally.hits : ++tally.clear;
  if (loose.hit && !tight.hit) ++tally.in_band;  // a graze within the band: either answer is right
  if (tight.hit && !(ours.hit && ours.time <= tight.time + kEps)) {
    ++tally.missed;
    tally.fail(std::string("missed: ") + buf);
  }
  if (!ours.hit) return;
  const double gap = bruteGap(b.parts, s.part, m, ours.time);
  const double off = pointToParts(s, ours.point);
  const bool unit = ours.normal.allFinite() && std::abs(ours.normal.norm() - 1.0) < 1e-9;
  if (!(loose.hit && loose.time <= ours.time + kEps) || !(gap <= tau + 1e-9) || !(off <= tau + 1e-7) || !unit) {
    ++tally.wrong;
    const size_t used = std::strlen(buf);
    std::snprintf(buf + used, sizeof buf - used, "; gap at ours %.3g, point off %.3g", gap, off);
    tally.fail(std::string("false: ") + buf);
  }
}

// ---------------------------------------------------------------------------------------
// Movers of each motion kind, starting near the scanner (the origin, 0.3 m up).

Vector3d startPoint(Rng& r, double spread) {
  const double a = r.uni(-kPi, kPi), d = r.uni(0.0, spread);
  return Vector3d(d * std::cos(a), d * std::sin(a), r.uni(0.1, 0.5));
}

// Mostly level, 0.6 to 2.5 m/s, in any heading (a quarter of them towards the scan's open back).
Vector3d heading(Rng& r, double lo, double hi) {
  const double a = r.uni(-kPi, kPi);
  return r.uni(lo, hi) * Vector3d(std::cos(a), std::sin(a), r.uni(-0.1, 0.1)).normalized();
}

ToiOptions options(double tol) {
  ToiOptions o;
  o.tolerance = tol;
  return o;
}

// A path through keyframes: each piece a screw of at most half a turn, whose arc is at most pi / 2
// times its chord, so the origin stays within that of the piece's first keyframe; every point
// of a shape within its bounding radius more (and `more`).
std::vector<Mover::Ball> pathReach(const std::vector<Keyframe>& keys, double radius) {
  std::vector<Mover::Ball> out;
  for (size_t k = 0; k < keys.size(); ++k) {
    const double chord = k + 1 < keys.size() ? (keys[k + 1].position - keys[k].position).norm() : 0.0;
    out.push_back({keys[k].position, radius + 0.5 * kPi * chord});
  }
  return out;
}

Mover twistMover(const Shape& shape, Rng& r) {
  Mover m;
  m.shape = shape;
  m.origin0 = startPoint(r, 0.6);
  const Vector3d v = heading(r, 0.6, 2.5);
  const Vector3d w = r.chance(0.6) ? Vector3d(r.unit() * r.uni(0.2, 2.0)) : Vector3d::Zero();
  Motion motion = vadop::makeMotion(m.origin0, r.quat(), v, w);
  if (w.norm() > 0.0 && r.chance(0.5)) {  // a vehicle's arc: turning about the screw axis
    motion.pivot_offset = vadop::screwPivotOffset(v, w);
    motion.linear_velocity = vadop::screwPivotVelocity(v, w);
  }
  m.reach = {{m.origin0, shape.bounding_radius + (v.norm() + w.norm() * motion.pivot_offset.norm()) * kHorizon}};
  m.toi = [motion](const PreparedShape& a, const PreparedShape& b, const Vector3d& at, double t1, double tol) {
    return vadop::timeOfImpact(a, motion, b, rest(at), 0.0, t1, options(tol));
  };
  m.poseAt = [motion](double t) { return motion.poseAt(t); };
  m.twist = motion;
  return m;
}

Mover pathMover(const Shape& shape, Rng& r) {
  Mover m;
  m.shape = shape;
  m.origin0 = startPoint(r, 0.6);
  std::vector<Keyframe> keys;
  Keyframe k;
  k.position = m.origin0;
  k.orientation = r.quat();
  Vector3d v = heading(r, 0.6, 2.5);
  while (k.time < kHorizon) {
    keys.push_back(k);
    const double dt = r.uni(0.3, 0.8);
    k.time += dt;
    k.position += v * dt;
    k.orientation = Quaterniond(Eigen::AngleAxisd(r.uni(0.0, 1.2), r.unit())) * k.orientation;
    v = Eigen::AngleAxisd(r.uni(-0.8, 0.8), Vector3d::UnitZ()) * v;
  }
  keys.push_back(k);
  m.reach = pathReach(keys, shape.bounding_radius);
  const TimedPath path(keys, vadop::AfterPath::kHold);
  m.toi = [path](const PreparedShape& a, const PreparedShape& b, const Vector3d& at, double t1, double tol) {
    return vadop::timeOfImpact(a, path, b, TimedPath(rest(at)), 0.0, t1, options(tol));
  };
  m.poseAt = [path](double t) { return path.poseAt(t); };
  return m;
}

// A link swung by a revolute joint (0.2 to 2.5 rad/s) on a base driving a twist: an arm on a
// mobile base.
Mover chainMover(const Shape& shape, Rng& r) {
  Mover m;
  m.shape = shape;
  m.origin0 = startPoint(r, 1.0);
  const Motion base = vadop::makeMotion(m.origin0, Quaterniond(Eigen::AngleAxisd(r.uni(-kPi, kPi), Vector3d::UnitZ())),
                                        heading(r, 0.3, 2.0), Vector3d(0.0, 0.0, r.uni(-0.8, 0.8)));
  ChainJoint joint;
  joint.type = JointType::kRevolute;
  joint.origin.translation() = Vector3d(r.uni(-0.2, 0.2), r.uni(-0.2, 0.2), r.uni(0.0, 0.2));
  joint.axis = r.chance(0.5) ? Vector3d::UnitZ() : r.unit();
  const double rate = (r.chance(0.5) ? 1.0 : -1.0) * r.uni(0.2, 2.5);
  joint.path = JointPath::constantVelocity(0.0, r.uni(-kPi, kPi), rate);
  ChainJoint link;  // fixed: the link's frame at the arm's end
  link.origin.translation() = Vector3d(r.uni(0.2, 0.6), 0.0, r.uni(-0.1, 0.1));
  const LinkChain chain(TimedPath(base), {joint, link});
  m.reach = {{m.origin0, shape.bounding_radius + base.linear_velocity.norm() * kHorizon +
                             joint.origin.translation().norm() + link.origin.translation().norm()}};
  m.toi = [chain](const PreparedShape& a, const PreparedShape& b, const Vector3d& at, double t1, double tol) {
    return vadop::timeOfImpact(a, chain, b, LinkChain(TimedPath(rest(at))), 0.0, t1, options(tol));
  };
  m.poseAt = [chain](double t) { return chain.poseAt(t); };
  return m;
}

// The gate's manoeuvre: the last command over a 0.1 s reaction time, the candidate (an arc)
// held 0.3 s, then braking to a stop at 0.8 to 2.5 m/s^2 (appendBrakingKeyframes within 20 um).
Mover brakingMover(const Shape& shape, Rng& r) {
  Mover m;
  m.shape = shape;
  m.origin0 = startPoint(r, 1.6);
  const Motion last = vadop::makeMotion(m.origin0, r.quat(), heading(r, 0.0, 1.5), Vector3d(0, 0, r.uni(-1.0, 1.0)));
  const Isometry3d at_react = last.poseAt(0.1);
  const Vector3d v = heading(r, 1.0, 2.5), w(0.0, 0.0, r.uni(-1.5, 1.5));
  Motion held = vadop::makeMotion(at_react.translation(), Quaterniond(at_react.linear()), v, w, 0.1);
  held.pivot_offset = vadop::screwPivotOffset(v, w);
  held.linear_velocity = vadop::screwPivotVelocity(v, w);
  std::vector<Keyframe> keys;
  vadop::appendKeyframes(last, 0.0, 0.1, keys);
  vadop::appendKeyframes(held, 0.1, 0.4, keys);
  const double braking = v.norm() / r.uni(0.8, 2.5);
  m.deviation = vadop::appendBrakingKeyframes(held, 0.4, braking, shape.bounding_radius, 2e-5, keys);
  m.horizon = 0.4 + braking;
  m.reach = pathReach(keys, shape.bounding_radius + m.deviation);
  const TimedPath path(keys, vadop::AfterPath::kHold);
  m.manoeuvre = path;
  m.toi = [path](const PreparedShape& a, const PreparedShape& b, const Vector3d& at, double t1, double tol) {
    return vadop::timeOfImpact(a, path, b, TimedPath(rest(at)), 0.0, t1, options(tol));
  };
  m.poseAt = [path](double t) { return path.poseAt(t); };
  return m;
}

using MakeMover = std::function<Mover(const Shape&, Rng&)>;

// A mover of the kind whose start is at least 10 tau from every part.
Mover clearStart(const PartSet& s, ShapeType kind, const MakeMover& make, Rng& r) {
  for (;;) {
    Shape shape;
    do {
      shape = toi_scenes::randomShape(kind, r);
    } while (shape.bounding_radius > 0.6);
    Mover m = make(shape, r);
    if (bruteGap(nearParts(s, m, kTol), s.part, m, 0.0) > 10.0 * kTol) return m;
  }
}

// The manoeuvre asked through World::firstContactAlong; its tolerance into tau.
TimeOfImpact throughWorld(vadop::World& world, const Mover& m, double& tau) {
  world.add("mover", m.shape, rest(m.origin0));
  vadop::World::PathQuery query;
  query.deviation = m.deviation;
  const auto c = world.firstContactAlong({"mover"}, {*m.manoeuvre}, 0.0, m.horizon, query);
  world.remove("mover");
  tau = std::max(kTol, 2.0 * m.deviation);  // the query's tolerance (world.h, PathQuery::deviation)
  TimeOfImpact out;
  out.time = m.horizon;
  if (c) {
    out = c->impact;
    out.undecided = c->undecided;
    out.hit = !c->undecided;
  }
  return out;
}

// 0 missed, 0 false, 0 undecided, and both verdicts exercised.
void expectSound(const std::string& what, const Tally& tally) {
  std::printf("%s: %d cases, %d contacts, %d clear, %d in the band, %d missed, %d false, %d undecided\n",
              what.c_str(), tally.cases, tally.hits, tally.clear, tally.in_band, tally.missed, tally.wrong,
              tally.undecided);
  EXPECT_EQ(tally.missed, 0) << tally.first_failure;
  EXPECT_EQ(tally.wrong, 0) << tally.first_failure;
  EXPECT_EQ(tally.undecided, 0) << tally.first_failure;
  EXPECT_GE(tally.hits, tally.cases / 8);
  EXPECT_GE(tally.clear, tally.cases / 8);
}

void runProperty(const char* motion, const MakeMover& make) {
  const int n = scenesPerCombination();
  Tally tally;
  uint64_t seed = 4900;
  for (const char* c = motion; *c; ++c) seed = seed * 31 + static_cast<unsigned char>(*c);
  for (const PartSet& s : partSets()) {
    const PreparedShape set(s.shape);
    vadop::WorldConfig config;
    config.toi.tolerance = kTol;
    vadop::World world(config);
    world.add(s.name, s.shape, rest(s.centre));
    Rng r(seed++);
    for (ShapeType kind : kShapeKinds) {
      for (int i = 0; i < n; ++i) {
        const Mover m = clearStart(s, kind, make, r);
        double tau = kTol;
        const TimeOfImpact ours = m.manoeuvre ? throughWorld(world, m, tau)
                                              : m.toi(PreparedShape(m.shape), set, s.centre, m.horizon, kTol);
        const std::string label =
            std::string(motion) + " " + s.name + " " + vadop::toString(kind) + " #" + std::to_string(i);
        judge(s, m, bracket(s, m, tau), ours, tau, label, tally);
      }
    }
  }
  expectSound(motion, tally);
}

TEST(PointSetProperty, ConstantTwist) { runProperty("twist", twistMover); }
TEST(PointSetProperty, TimedPath) { runProperty("path", pathMover); }
TEST(PointSetProperty, LinkChainWithMovingJoint) { runProperty("chain", chainMover); }
TEST(PointSetProperty, BrakingManoeuvreThroughWorld) { runProperty("braking", brakingMover); }

// ---------------------------------------------------------------------------------------
// World::predict and World::firstContactIf: a set among 5 movers per scene count (30; 10 under
// ASan), under each broad phase.

TEST(PointSetWorld, PredictAndFirstContactIfWithinTheBruteForce) {
  Tally tally;
  Rng r(4903);
  for (const PartSet& s : partSets()) {
    std::vector<Mover> movers;
    std::vector<Bracket> brackets;
    for (int i = 0; i < 5 * scenesPerCombination(); ++i) {
      movers.push_back(clearStart(s, kShapeKinds[i % 6], twistMover, r));
      brackets.push_back(bracket(s, movers.back(), kTol));
    }
    for (const vadop::BroadPhaseKind kind : {vadop::BroadPhaseKind::kVadop, vadop::BroadPhaseKind::kSap,
                                             vadop::BroadPhaseKind::kGrid, vadop::BroadPhaseKind::kBrute}) {
      vadop::WorldConfig config;
      config.broad_phase = kind;
      config.toi.tolerance = kTol;
      vadop::World world(config);
      // The caller's keys (add's `user`): the set's is 1, the movers' 0.
      constexpr uint64_t kSetUser = 1;
      world.add(s.name, s.shape, rest(s.centre), kSetUser);
      for (size_t i = 0; i < movers.size(); ++i) world.add("m" + std::to_string(i), movers[i].shape, *movers[i].twist);
      std::vector<TimeOfImpact> predicted(movers.size());
      for (TimeOfImpact& t : predicted) t.time = kHorizon;
      for (const vadop::Contact& c : world.predict(0.0, kHorizon)) {
        if (c.a == s.name) predicted[std::stoul(c.b.substr(1))] = c.impact;  // a: the set, added first
      }
      const auto others = [](uint64_t user) { return user != kSetUser; };
      for (size_t i = 0; i < movers.size(); ++i) {
        const std::string label = std::string(vadop::toString(kind)) + " " + s.name + " m" + std::to_string(i);
        EXPECT_EQ(world.lastUndecided().size(), 0u);
        judge(s, movers[i], brackets[i], predicted[i], kTol, "predict " + label, tally);
        const auto c = world.firstContactIf({"m" + std::to_string(i)}, {*movers[i].twist}, 0.0, kHorizon, others);
        TimeOfImpact ours;
        ours.time = kHorizon;
        if (c) {
          ours = c->impact;
          ours.undecided = c->undecided;
        }
        judge(s, movers[i], brackets[i], ours, kTol, "firstContactIf " + label, tally);
      }
    }
  }
  expectSound("World", tally);
}

// ---------------------------------------------------------------------------------------
// Analytic corners.

// A wall of points at x = 2 m, 1 cm apart (closer than their 2 cm radius), and a sphere of 0.1 m
// driving at it at 1 m/s: aimed at a point it touches that point's ball first (t = 2 - 0.12);
// aimed between four, the four at once, when (2 - x)^2 + 2 (5 mm)^2 = 0.12^2.
TEST(PointSetCorners, SphereAtAWallOfPointsCloserThanTheirRadius) {
  std::vector<Vector3d> points;
  for (int i = -20; i <= 20; ++i)
    for (int j = -20; j <= 20; ++j) points.emplace_back(2.0, 0.01 * i, 0.01 * j);
  const PartSet wall = pointSet("wall", points, 0.02);
  const Shape ball = vadop::makeSphere(0.1);
  for (const double off : {0.0, 0.005}) {
    const Motion m = vadop::makeMotion(Vector3d(0.0, off, off), Quaterniond::Identity(), Vector3d(1.0, 0.0, 0.0),
                                       Vector3d::Zero());
    const double exact = 2.0 - std::sqrt(0.12 * 0.12 - 2.0 * off * off);
    const TimeOfImpact t = vadop::timeOfImpact(ball, m, wall.shape, rest(wall.centre), 0.0, 3.0);
    ASSERT_TRUE(t.hit) << off;
    EXPECT_LE(t.time, exact + 1e-12) << off;
    EXPECT_GE(t.time, exact - 1e-6) << off;  // the default tolerance, 1e-6 m at 1 m/s
    EXPECT_NEAR(t.point.x(), 1.98, 1e-3) << off;  // on the sphere's surface (within the tilt off x)
    if (off == 0.0) EXPECT_LT((t.normal - Vector3d::UnitX()).norm(), 1e-6);
    // The same through World::predict.
    vadop::World world;
    world.add("wall", wall.shape, rest(wall.centre));
    world.add("ball", ball, m);
    const std::vector<vadop::Contact> contacts = world.predict(0.0, 3.0);
    ASSERT_EQ(contacts.size(), 1u);
    EXPECT_NEAR(contacts[0].impact.time, exact, 1e-6);
  }
}

// The world keeps a resting set's pair with a body only for the parts of the window where the
// body's box meets a leaf of the set's tree, posed as the set is: a row of points along the
// set's x axis from 0 to 1 m, turned 90 deg about z (a row along y from 0 to 1 at x = 0), and a
// sphere of 0.1 m crossing it along -x at y = 0.5 m hits the point at y = 0.5 when x = 0.12
// (the unturned row would lie along x at y = 0, 0.5 m away from the sphere's whole path; turned
// the other way, along -y); one at y = 1.11 grazes the row's last point (y = 1) within its
// radius only (its box never reaches the point's centre) when x^2 + 0.11^2 = 0.12^2; another
// at y = 1.3, beyond the row's end by more than the two radii, passes.
TEST(PointSetWorld, ARestingSetIsCulledWhereItIsPosed) {
  std::vector<Vector3d> points;
  for (int i = 0; i <= 100; ++i) points.emplace_back(0.01 * i, 0.0, 0.0);
  const Shape row = vadop::makePointSet(points, 0.02);
  const Quaterniond turn(Eigen::AngleAxisd(0.5 * M_PI, Vector3d::UnitZ()));
  for (const double y : {0.5, 1.11, 1.3}) {
    vadop::World world;
    world.add("row", row, vadop::makeMotion(Vector3d::Zero(), turn, Vector3d::Zero(), Vector3d::Zero()));
    world.add("ball", vadop::makeSphere(0.1),
              vadop::makeMotion(Vector3d(1.0, y, 0.0), Quaterniond::Identity(), Vector3d(-1.0, 0.0, 0.0),
                                Vector3d::Zero()));
    const std::vector<vadop::Contact> contacts = world.predict(0.0, 2.0);
    if (y > 1.2) {
      EXPECT_TRUE(contacts.empty()) << "y " << y;
      continue;
    }
    ASSERT_EQ(contacts.size(), 1u) << "y " << y;
    const double x = y == 0.5 ? 0.12 : std::sqrt(0.12 * 0.12 - 0.11 * 0.11);
    EXPECT_NEAR(contacts[0].impact.time, 1.0 - x, 1e-5) << "y " << y;
  }
}

// Two resting sets a gap of half the narrow phase's tolerance apart touch (timeOfImpact reports
// them at the window's start), and are reported by the world: the part boxes of a resting set
// are grown by the tolerance as every body's broad-phase shape is. At twice the tolerance
// neither reports them.
TEST(PointSetWorld, TwoRestingSetsWithinTheToleranceTouch) {
  const vadop::WorldConfig config;
  const double tol = config.toi.tolerance;
  for (const double gap : {0.5 * tol, 2.0 * tol}) {
    const PartSet a = pointSet("left", {Vector3d(0.0, 0.0, 0.0), Vector3d(-1.0, 0.0, 0.0)}, 0.02);
    const PartSet b = pointSet("right", {Vector3d(0.04 + gap, 0.0, 0.0), Vector3d(1.0, 0.0, 0.0)}, 0.02);
    const TimeOfImpact t = vadop::timeOfImpact(a.shape, rest(a.centre), b.shape, rest(b.centre), 0.0, 2.0, config.toi);
    EXPECT_EQ(t.hit, gap < tol) << "gap " << gap;
    vadop::World world(config);
    world.add("left", a.shape, rest(a.centre));
    world.add("right", b.shape, rest(b.centre));
    EXPECT_EQ(world.predict(0.0, 2.0).size(), t.hit ? 1u : 0u) << "gap " << gap;
  }
}

// A body that passes a resting set's point within the narrow phase's tolerance (a gap of half
// of it) is reported, as timeOfImpact reports it: the cull keeps a leaf within the tolerance of
// a part's box, though the boxes themselves do not meet.
TEST(PointSetWorld, TheCullKeepsAGrazeWithinTheTolerance) {
  const vadop::WorldConfig config;
  const double tol = config.toi.tolerance;
  for (const double gap : {0.5 * tol, 2.0 * tol}) {
    const PartSet set = pointSet("grazed", {Vector3d(0.0, 0.0, 0.0), Vector3d(0.0, -1.0, 0.0)}, 0.02);
    const Shape ball = vadop::makeSphere(0.1);
    const Motion m = vadop::makeMotion(Vector3d(1.0, 0.12 + gap, 0.0), Quaterniond::Identity(),
                                       Vector3d(-1.0, 0.0, 0.0), Vector3d::Zero());
    const TimeOfImpact t = vadop::timeOfImpact(ball, m, set.shape, rest(set.centre), 0.0, 2.0, config.toi);
    EXPECT_EQ(t.hit, gap < tol) << "gap " << gap;
    vadop::World world(config);
    world.add("set", set.shape, rest(set.centre));
    world.add("ball", ball, m);
    EXPECT_EQ(world.predict(0.0, 2.0).size(), t.hit ? 1u : 0u) << "gap " << gap;
  }
}

// The world's cull of a resting set (detail::partsMeetingTree) never drops a part whose box is
// within the slack of a point's ball, against the brute force over every point: sets along a
// room's walls (hollow: their subtrees' boxes span the room) and filled ones, flat and tall,
// posed unturned and turned, with 64 part boxes of 1 cm to 3 m at a time, some through the
// walls, most inside; and it drops most of those that meet no ball.
TEST(PointSetTree, TheCullDropsOnlyPartsThatMeetNoPoint) {
  Rng r(4911);
  const double radius = 0.05, slack = 1e-6;
  size_t dropped = 0, dropped_possible = 0, kept_true = 0;
  for (int round = 0; round < 24; ++round) {
    const bool hollow = round % 2 == 0;
    const double height = round % 3 == 0 ? 0.0 : 2.0;
    std::vector<Vector3d> points;
    for (int i = 0; i < 3000; ++i) {
      Vector3d q(r.uni(0.0, 20.0), r.uni(0.0, 12.0), r.uni(0.0, height));
      if (hollow) {
        if (i % 4 == 0) q.x() = 0.0;
        else if (i % 4 == 1) q.x() = 20.0;
        else if (i % 4 == 2) q.y() = 0.0;
        else q.y() = 12.0;
      }
      points.push_back(q);
    }
    const PartSet set = pointSet("walls", points, radius);
    const vadop::PreparedShape prepared(set.shape);
    const vadop::detail::PreparedShapeData& d = prepared.data();
    const Quaterniond turn = round % 4 < 2 ? Quaterniond::Identity()
                                           : Quaterniond(Eigen::AngleAxisd(r.uni(0.0, 6.3), Vector3d(0.3, -0.2, 1.0).normalized()));
    const Eigen::Matrix3d R = turn.toRotationMatrix();
    const Vector3d p = set.centre + Vector3d(r.uni(-1.0, 1.0), r.uni(-1.0, 1.0), 0.0);
    // The points as the world sees them: the set's body frame posed at (R, p).
    std::vector<Vector3d> placed;
    for (const Vector3d& q : points) placed.push_back(R * (q - set.centre) + p);
    std::vector<double> boxes(6 * 64);
    for (int k = 0; k < 64; ++k) {
      const Vector3d c = p + Vector3d(r.uni(-12.0, 12.0), r.uni(-8.0, 8.0), r.uni(-1.0, 3.0));
      const Vector3d h(r.uni(0.005, 1.5), r.uni(0.005, 1.5), r.uni(0.005, 1.5));
      for (int a = 0; a < 3; ++a) {
        boxes[6 * k + a] = c[a] - h[a];
        boxes[6 * k + 3 + a] = c[a] + h[a];
      }
    }
    const uint64_t all = ~uint64_t{0};
    const uint64_t kept = vadop::detail::partsMeetingTree(d, R, p, boxes.data(), all, slack);
    for (int k = 0; k < 64; ++k) {
      const double* b = &boxes[6 * k];
      bool meets = false;
      for (const Vector3d& q : placed) {
        double gap2 = 0.0;
        for (int a = 0; a < 3; ++a) {
          const double out = std::max({b[a] - q[a], q[a] - b[3 + a], 0.0});
          gap2 += out * out;
        }
        if (gap2 <= (radius + slack) * (radius + slack)) {
          meets = true;
          break;
        }
      }
      const bool is_kept = (kept >> k) & 1;
      if (meets) {
        EXPECT_TRUE(is_kept) << "round " << round << ": part " << k << " meets a point's ball but was dropped";
        ++kept_true;
      } else {
        ++dropped_possible;
        dropped += is_kept ? 0 : 1;
      }
    }
  }
  EXPECT_GT(kept_true, 100u);
  EXPECT_GT(dropped, dropped_possible / 2) << dropped << " of " << dropped_possible << " parts that meet no point dropped";
}

// Points repeated many times over (a sensor's beams returning the same spot: more copies than
// the tree splits exactly) and rows sharing one coordinate: a sphere driven at each copied spot
// touches it when its centre is 0.1 + 0.02 m from it, as the brute force over the distinct points
// says, through World::predict and timeOfImpact alike.
TEST(PointSetCorners, RepeatedPointsAndSharedCoordinates) {
  std::vector<Vector3d> points;
  for (int copy = 0; copy < 300; ++copy) points.emplace_back(2.0, 0.0, 0.0);
  for (int copy = 0; copy < 150; ++copy) points.emplace_back(2.5, 1.0, 0.0);
  for (int i = 0; i < 200; ++i) points.emplace_back(3.0, -1.0 + 0.001 * (i % 7), 0.0);  // x shared by all
  const PartSet set = pointSet("repeated", points, 0.02);
  const Shape ball = vadop::makeSphere(0.1);
  for (const Vector3d& target : {Vector3d(2.0, 0.0, 0.0), Vector3d(2.5, 1.0, 0.0), Vector3d(3.0, -0.997, 0.0)}) {
    const Motion m = vadop::makeMotion(Vector3d(0.0, target.y(), 0.0), Quaterniond::Identity(),
                                       Vector3d(1.0, 0.0, 0.0), Vector3d::Zero());
    double exact = kInf;  // the brute force: the first point whose ball the sphere reaches along +x
    for (const Vector3d& p : points) {
      const double dy = p.y() - target.y(), reach2 = 0.12 * 0.12 - dy * dy;
      if (reach2 >= 0.0) exact = std::min(exact, p.x() - std::sqrt(reach2));
    }
    const TimeOfImpact t = vadop::timeOfImpact(ball, m, set.shape, rest(set.centre), 0.0, 4.0);
    ASSERT_TRUE(t.hit) << target.transpose();
    EXPECT_LE(t.time, exact + 1e-12) << target.transpose();
    EXPECT_GE(t.time, exact - 1e-6) << target.transpose();
    vadop::World world;
    world.add("set", set.shape, rest(set.centre));
    world.add("ball", ball, m);
    const std::vector<vadop::Contact> contacts = world.predict(0.0, 4.0);
    ASSERT_EQ(contacts.size(), 1u) << target.transpose();
    EXPECT_NEAR(contacts[0].impact.time, exact, 1e-6) << target.transpose();
  }
}

// The tree itself (mesh_bvh.h): every point in exactly one leaf, every node's box holds its
// children's and its ball their balls; returns the depth (levels).
int checkPointSetTree(const vadop::detail::PreparedShapeData& d, const std::vector<Vector3d>& points, double radius) {
  const int n = static_cast<int>(points.size());
  std::vector<int> seen(n, 0);
  std::vector<Vector3d> leaf_points;
  int deepest = 0;
  std::vector<std::pair<int, int>> stack{{d.root, 1}};
  while (!stack.empty()) {
    const auto [i, depth] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, depth);
    const vadop::detail::BvhNode& node = d.nodes[i];
    if (node.tri >= 0) {
      ++seen[node.tri];
      // A leaf: its ball and box hold its point's ball.
      const Vector3d p = d.tris[node.tri].v[0];
      EXPECT_EQ(d.tris[node.tri].v[1], p);
      EXPECT_EQ(d.tris[node.tri].v[2], p);
      leaf_points.push_back(p);
      EXPECT_LE((p - node.centre).norm() + radius, node.radius + 1e-12);
      for (int k = 0; k < 3; ++k) {
        EXPECT_LE(std::abs(p[k] - d.node_boxes[i][k]) + radius, d.node_boxes[i][3 + k] + 1e-12);
      }
      continue;
    }
    for (const int c : {node.left, node.right}) {
      const vadop::detail::BvhNode& child = d.nodes[c];
      EXPECT_LE((child.centre - node.centre).norm() + child.radius, node.radius + 1e-12);
      for (int k = 0; k < 3; ++k) {
        EXPECT_LE(std::abs(d.node_boxes[c][k] - d.node_boxes[i][k]) + d.node_boxes[c][3 + k],
                  d.node_boxes[i][3 + k] + 1e-12);
      }
      stack.push_back({c, depth + 1});
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), n) << n << " points";
  // The leaves' points are the set's (repeats included).
  std::vector<Vector3d> given = points;
  const auto lexicographic = [](const Vector3d& a, const Vector3d& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  std::sort(given.begin(), given.end(), lexicographic);
  std::sort(leaf_points.begin(), leaf_points.end(), lexicographic);
  EXPECT_TRUE(given == leaf_points) << n << " points";
  return deepest;
}

// Point sets of 1 to 20,000 points with repeated points and shared coordinates (up to 2,048 the
// median splits, beyond them the Morton order's): the tree holds them, and its depth stays about
// log2(n).
TEST(PointSetTree, EveryPointInOneLeafAndEveryNodeHoldsItsChildren) {
  Rng r(4905);
  for (const int n : {1, 2, 3, 64, 65, 1000, 2048, 2049, 20000}) {
    std::vector<Vector3d> points;
    for (int i = 0; i < n; ++i) {
      if (i % 5 == 0 && i > 0) {
        points.push_back(points[r.integer(0, i - 1)]);  // a repeat
      } else {
        points.emplace_back(std::round(r.uni(-20.0, 20.0) * 10.0) / 10.0, r.uni(-20.0, 20.0), 0.3);
      }
    }
    const PreparedShape prepared(vadop::makePointSet(points, 0.02));
    const int deepest = checkPointSetTree(prepared.data(), points, 0.02);
    // About log2(n) + 1 levels; a split that peeled off one point at a time would give n.
    EXPECT_LE(deepest, static_cast<int>(std::ceil(2.0 * std::log2(n))) + 2) << n << " points";
  }
}

// Node a of tree da and node b of tree db hold the same subtree: the same splits, leaves and
// bounds (bit for bit: the same arithmetic); returns the subtree's node count.
int sameSubtree(const vadop::detail::PreparedShapeData& da, int a, const vadop::detail::PreparedShapeData& db, int b) {
  const vadop::detail::BvhNode& x = da.nodes[a];
  const vadop::detail::BvhNode& y = db.nodes[b];
  EXPECT_EQ(x.tri, y.tri);
  EXPECT_EQ(x.centre, y.centre);
  EXPECT_EQ(x.radius, y.radius);
  EXPECT_EQ(da.node_boxes[a], db.node_boxes[b]);
  if (x.tri >= 0 && y.tri >= 0) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(da.tris[x.tri].v[k], db.tris[y.tri].v[k]);
  }
  if (x.tri >= 0 || y.tri >= 0 || ::testing::Test::HasFailure()) return 1;
  return 1 + sameSubtree(da, x.left, db, y.left) + sameSubtree(da, x.right, db, y.right);
}

// A large set's tree is built on several threads (a sensor's points, in its message's callback):
// the same tree as on one, every node of the arrays in it, for point sets across the threshold
// (4,096) and for a mesh of boxes (its median splits).
TEST(PointSetTree, TheSameTreeOnAnyThreadCount) {
  Rng r(4907);
  std::vector<vadop::Shape> shapes;
  for (const int n : {4095, 4096, 9716, 30000}) {
    std::vector<Vector3d> points;
    for (int i = 0; i < n; ++i) {
      points.emplace_back(r.uni(-30.0, 30.0), r.uni(-30.0, 30.0), i % 7 == 0 ? 0.3 : r.uni(0.0, 2.0));
    }
    shapes.push_back(vadop::makePointSet(points, 0.02));
  }
  std::vector<Vector3d> centres;
  for (int i = 0; i < 700; ++i) centres.emplace_back(r.uni(-10.0, 10.0), r.uni(-10.0, 10.0), 0.0);
  shapes.push_back(vadop::makeBoxSet(centres, Vector3d(0.05, 0.05, 0.05)));  // 8,400 triangles
  for (const vadop::Shape& shape : shapes) {
    const PreparedShape one(shape, 1);
    for (const int threads : {2, 3, 8, 0}) {
      const PreparedShape many(shape, threads);
      const vadop::detail::PreparedShapeData& d = many.data();
      ASSERT_EQ(d.nodes.size(), one.data().nodes.size());
      EXPECT_EQ(sameSubtree(one.data(), one.data().root, d, d.root), static_cast<int>(d.nodes.size()))
          << shape.triangles.size() << " triangles, " << threads << " threads";
      if (shape.points.size() == shape.triangles.size()) checkPointSetTree(d, shape.points, 0.02);
      if (::testing::Test::HasFailure()) return;
    }
  }
}

// The Morton order's corners: 5,000 points within 0.1 mm and one 100 m away (most codes equal:
// those split at their middle), so the depth stays within the 30 code bits + log2(n) + 1 that
// the traversals' fixed stacks allow (64); and a flat set (20 m x 20 m x 1 m) whose first
// split is across its width, not its height (cells are cubes: per-axis scales would cut the
// slab in two thin slabs first).
TEST(PointSetTree, MortonOrderOfAClusterAndOfAFlatSet) {
  Rng r(4906);
  std::vector<Vector3d> cluster;
  for (int i = 0; i < 5000; ++i) cluster.emplace_back(r.uni(0.0, 1e-4), r.uni(0.0, 1e-4), r.uni(0.0, 1e-4));
  cluster.emplace_back(100.0, 0.0, 0.0);
  const PreparedShape clustered(vadop::makePointSet(cluster, 0.02));
  const int deepest = checkPointSetTree(clustered.data(), cluster, 0.02);
  EXPECT_LE(deepest, 30 + static_cast<int>(std::ceil(std::log2(cluster.size()))) + 1);
  EXPECT_LT(deepest, 64);

  std::vector<Vector3d> slab;
  for (int i = 0; i < 5000; ++i) slab.emplace_back(r.uni(-10.0, 10.0), r.uni(-10.0, 10.0), r.uni(0.0, 1.0));
  const PreparedShape flat(vadop::makePointSet(slab, 0.02));
  const vadop::detail::PreparedShapeData& d = flat.data();
  checkPointSetTree(d, slab, 0.02);
  const vadop::detail::BvhNode& root = d.nodes[d.root];
  for (const int c : {root.left, root.right}) {
    // Each half spans the slab's full height (half extent about 0.5 + 0.02) and about half its
    // width along x or y.
    EXPECT_GT(d.node_boxes[c][5], 0.5) << "child " << c;
    EXPECT_LT(std::min(d.node_boxes[c][3], d.node_boxes[c][4]), 5.5) << "child " << c;
  }
}

// Two points 0.3 m apart (radius 2 cm): bodies narrower than the 0.26 m between their balls
// pass; a sphere of 0.14 m (0.01 m too wide) touches both when (1 - x)^2 + 0.15^2 = 0.16^2.
TEST(PointSetCorners, BodyPassesBetweenTwoPointsFartherApartThanItsSize) {
  const PartSet pair = pointSet("pair", {Vector3d(1.0, 0.15, 0.0), Vector3d(1.0, -0.15, 0.0)}, 0.02);
  const Motion m =
      vadop::makeMotion(Vector3d::Zero(), Quaterniond::Identity(), Vector3d(1.0, 0.0, 0.0), Vector3d::Zero());
  for (const Shape& narrow : {vadop::makeSphere(0.12), vadop::makeBox(Vector3d(0.4, 0.2, 0.4)),
                              vadop::makeCapsule(0.1, 0.5), vadop::makeCylinder(0.12, 0.3)}) {
    const TimeOfImpact t = vadop::timeOfImpact(narrow, m, pair.shape, rest(pair.centre), 0.0, 2.0);
    EXPECT_FALSE(t.hit) << vadop::toString(narrow.type) << " at " << t.time;
    EXPECT_FALSE(t.undecided);
  }
  const TimeOfImpact t = vadop::timeOfImpact(vadop::makeSphere(0.14), m, pair.shape, rest(pair.centre), 0.0, 2.0);
  const double exact = 1.0 - std::sqrt(0.16 * 0.16 - 0.15 * 0.15);
  ASSERT_TRUE(t.hit);
  EXPECT_LE(t.time, exact + 1e-12);
  EXPECT_GE(t.time, exact - 1e-5);  // 1e-6 m at a closing speed of 0.35 m/s along the normal
}

// A box set: one 0.5 m box whose near face is at x = 1, and a wall of 5 cm map cells (0.4 m
// tall) whose face is at x = 3. A sphere and a box driving at 0.5 m/s touch each face when
// they reach it; a sphere sliding past the box's side 1 mm away does not.
TEST(PointSetCorners, BoxSetFaces) {
  std::vector<Vector3d> centres = {Vector3d(1.25, 0.0, 0.2)};
  const PartSet big = boxSet("big", centres, Vector3d(0.5, 0.5, 0.5));
  centres.clear();
  for (int j = -10; j < 10; ++j) centres.emplace_back(3.025, 0.05 * j + 0.025, 0.2);
  const PartSet cells = boxSet("cells", centres, Vector3d(0.05, 0.05, 0.4));
  const Vector3d v(0.5, 0.0, 0.0);
  for (const Shape& mover : {vadop::makeSphere(0.05), vadop::makeBox(Vector3d(0.1, 0.1, 0.1))}) {
    const Motion to_big = vadop::makeMotion(Vector3d(0.0, 0.0123, 0.2), Quaterniond::Identity(), v, Vector3d::Zero());
    TimeOfImpact t = vadop::timeOfImpact(mover, to_big, big.shape, rest(big.centre), 0.0, 4.0);
    ASSERT_TRUE(t.hit) << vadop::toString(mover.type);
    EXPECT_NEAR(t.time, 1.9, 2e-6) << vadop::toString(mover.type);
    EXPECT_LT((t.normal - Vector3d::UnitX()).norm(), 1e-6);
    const Motion to_cells = vadop::makeMotion(Vector3d(2.0, 0.0123, 0.2), Quaterniond::Identity(), v, Vector3d::Zero());
    t = vadop::timeOfImpact(mover, to_cells, cells.shape, rest(cells.centre), 0.0, 4.0);
    ASSERT_TRUE(t.hit) << vadop::toString(mover.type);
    EXPECT_NEAR(t.time, 1.9, 2e-6) << vadop::toString(mover.type);
  }
  const Motion beside = vadop::makeMotion(Vector3d(0.0, 0.301, 0.2), Quaterniond::Identity(), v, Vector3d::Zero());
  const TimeOfImpact t = vadop::timeOfImpact(vadop::makeSphere(0.05), beside, big.shape, rest(big.centre), 0.0, 6.0);
  EXPECT_FALSE(t.hit) << t.time;
}

// ---------------------------------------------------------------------------------------
// Static distance and penetration; the constructors.

TEST(PointSetStatic, DistanceAndPenetrationAgainstPoints) {
  // A point 1 cm inside a 0.4 m box's face (its ball 3 cm deep), one 5 cm outside, one far.
  const Isometry3d at_origin = Isometry3d::Identity();
  for (const Shape& solid : {vadop::makeBox(Vector3d(0.4, 0.4, 0.4)), vadop::makeCylinder(0.2, 0.4)}) {
    const char* kind = vadop::toString(solid.type);
    for (const double x : {0.19, 0.25}) {
      const Shape set = vadop::makePointSet({Vector3d(x, 0.0, 0.0), Vector3d(5.0, 0.0, 0.0)}, 0.02);
      const vadop::DistanceResult d = vadop::distance(solid, at_origin, set, at_origin);
      EXPECT_NEAR(d.distance, x - 0.2 - 0.02, 1e-5) << kind << " " << x;
      EXPECT_EQ(d.cores_overlap, x < 0.2) << kind << " " << x;
      // A cylinder's penetration direction comes from the expanding polytope, to 1e-6 of the bodies'
      // size in depth: about sqrt(1e-6) in angle.
      EXPECT_LT((d.normal - Vector3d::UnitX()).norm(), solid.type == ShapeType::kBox ? 1e-9 : 1e-2) << kind << " " << x;
    }
  }
  // A sphere centred on a point: every direction separates them alike; the answer is finite.
  const vadop::DistanceResult d = vadop::distance(vadop::makeSphere(0.1), at_origin,
                                                  vadop::makePointSet({Vector3d::Zero()}, 0.02), at_origin);
  EXPECT_NEAR(d.distance, -0.12, 1e-12);
  EXPECT_TRUE(d.normal.allFinite());
  EXPECT_NEAR(d.normal.norm(), 1.0, 1e-12);
  // A point inside a mesh body (a closed box surface, 1 m): a surface, as every mesh pair; inside a
  // solid box, the cores overlap.
  const Shape point = vadop::makePointSet({Vector3d::Zero()}, 0.02);
  const Shape closed_box = vadop::makeBoxSet({Vector3d::Zero()}, Vector3d::Ones());
  EXPECT_NEAR(vadop::distance(closed_box, at_origin, point, at_origin).distance, 0.48, 1e-9);
  EXPECT_NEAR(vadop::distance(vadop::makeBox(Vector3d::Ones()), at_origin, point, at_origin).distance, -0.52, 1e-9);
  // The scan against a sphere: the nearest ball's gap, through the tree over 1,081 points.
  const PartSet& scan = partSets()[0];
  Rng r(4904);
  for (int i = 0; i < 50; ++i) {
    const Vector3d c(r.uni(-4.0, 4.0), r.uni(-4.0, 4.0), r.uni(0.0, 0.6));
    const double radius = r.uni(0.05, 0.5);
    double brute = kInf;
    for (const Vector3d& p : scan.parts) brute = std::min(brute, (p - c).norm() - radius - 0.02);
    const vadop::DistanceResult e = vadop::distance(vadop::makeSphere(radius), translation(c), scan.shape,
                                                    translation(scan.centre));
    EXPECT_NEAR(e.distance, brute, 1e-8) << c.transpose();
  }
}

TEST(PointSetShapes, BoundsAndErrors) {
  const Shape s = vadop::makePointSet({Vector3d(1.0, 0.0, 0.0), Vector3d(0.0, -2.0, 0.0)}, 0.05);
  EXPECT_EQ(s.type, ShapeType::kMesh);
  EXPECT_NEAR(s.bounding_radius, 2.05, 1e-12);
  EXPECT_NEAR(vadop::support(s, Vector3d::UnitX()), 1.05, 1e-12);
  const Shape b = vadop::makeBoxSet({Vector3d(1.0, 0.0, 0.0)}, Vector3d(0.2, 0.4, 0.6));
  EXPECT_NEAR(vadop::support(b, Vector3d::UnitX()), 1.1, 1e-12);
  EXPECT_NEAR(vadop::support(b, Vector3d::UnitZ()), 0.3, 1e-12);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(vadop::makePointSet({}, 0.02), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makePointSet({Vector3d::Zero()}, 0.0), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makePointSet({Vector3d::Zero()}, nan), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makeBoxSet({}, Vector3d::Ones()), vadop::InvalidArgument);
  EXPECT_THROW(vadop::makeBoxSet({Vector3d::Zero()}, Vector3d(1.0, 0.0, 1.0)), vadop::InvalidArgument);
  try {
    vadop::makePointSet({Vector3d::Zero(), Vector3d(0.0, nan, 0.0)}, 0.02);
    ADD_FAILURE() << "no throw";
  } catch (const vadop::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("points[1]"), std::string::npos) << e.what();
  }
  try {
    vadop::makeBoxSet({Vector3d::Zero(), Vector3d::Zero(), Vector3d(nan, 0.0, 0.0)}, Vector3d::Ones());
    ADD_FAILURE() << "no throw";
  } catch (const vadop::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("centres[2]"), std::string::npos) << e.what();
  }
}

}  // namespace
