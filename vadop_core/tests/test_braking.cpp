// The braking manoeuvre of a velocity gate (issue 48) against an independent truth:
//  1. appendBrakingKeyframes: the TimedPath through its keyframes against the exact braking
//     (the pose `motion` takes at t0 + u - u^2 / (2 T), by the truth's own Rodrigues formula,
//     toi_truth::poseAt) sampled 2,000 times per manoeuvre, for points on the sphere of the
//     stated radius: within the returned deviation, that deviation within max_deviation unless
//     the 512-piece cap is hit, standing still after t0 + T, starting at motion's pose, stopping
//     half the way motion covers; bad arguments throw.
//  2. World::firstContactAlong for a mover on a manoeuvre (a motion held over a reaction time,
//     another twist held, then braking: appendKeyframes, appendBrakingKeyframes) against one
//     other body of every shape kind (static, a constant twist, braking with setStopDuration in
//     the others_stop future), against a dense truth: the exact manoeuvre and the exact braking of
//     the other (not the keyframes), and the gap of toi_truth.h's independent geometry (explicit
//     vertex lists, a 2^20-gon sandwich for cylinders, a certified min-norm distance) at times
//     stepped by conservative advancement on the truth's own speed bound (every stretch between
//     samples certified by the Lipschitz bound; 1e-4 s apart near contact, at most 0.01 s
//     anywhere). 0 missed (a truth contact is reported, no later than the earliest time the
//     truth finds in contact), 0 false (a scene whose certified minimum gap is above the
//     tolerance band is not reported, and a report at t has the truth's gap at t within the
//     band: the path tolerance plus the deviations); scenes whose minimum gap falls inside the
//     band are counted, not asserted.
//  3. The pressing rule: touching at a stage boundary blocks only when that stage presses (and
//     a box face touching a wall that turns in place presses: a corner digs in).
//  4. Scenes built for the two ways a check of keyframes could go wrong: a body crossing where
//     the exact braking is ahead of its keyframes (the deviation's tolerance), and a leader that
//     brakes in front of its follower (the others' braking future).
#include "vadop/error.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"

#include "toi_scenes.h"
#include "toi_truth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;
using toi_truth::Pose;
using vadop::AfterPath;
using vadop::Keyframe;
using vadop::Motion;
using vadop::ShapeType;
using vadop::TimedPath;

constexpr double kInf = std::numeric_limits<double>::infinity();
const ShapeType kShapeKinds[] = {ShapeType::kSphere,   ShapeType::kBox,    ShapeType::kCapsule,
                                 ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};

// ---------------------------------------------------------------------------------------
// The exact motions, by the truth's formulas only.

// Braking along m from t0 over T: at t0 + u the pose m takes at t0 + u - u^2 / (2 T).
Pose brakingPose(const Motion& m, double t0, double T, double t) {
  const double u = std::clamp(t - t0, 0.0, T);
  const double s = T > 0.0 ? u - u * u / (2.0 * T) : 0.0;
  return toi_truth::poseAt(m, t0 + s);
}

// How fast any point within `lever` of the origin moves under m (the origin's speed along the
// screw plus the turn's).
double pointSpeed(const Motion& m, double lever) {
  return (m.linear_velocity - m.angular_velocity.cross(m.pivot_offset)).norm() + m.angular_velocity.norm() * lever;
}

// A twist whose origin moves at vo while it turns at w: about the screw axis (a vehicle's arc)
// when `screw`, else about the origin.
Motion twist(const Vector3d& p, const Quaterniond& q, const Vector3d& vo, const Vector3d& w, double t_ref, bool screw) {
  Motion m;
  m.t_ref = t_ref;
  m.position = p;
  m.orientation = q.normalized();
  m.angular_velocity = w;
  if (screw) {
    m.linear_velocity = vadop::screwPivotVelocity(vo, w);
    m.pivot_offset = vadop::screwPivotOffset(vo, w);
  } else {
    m.linear_velocity = vo;
  }
  return m;
}

Quaterniond quatOf(const Pose& P) { return Quaterniond(P.R).normalized(); }

// A random motion of the kinds a gate brakes along: a translation, a turn on the spot, a
// vehicle's arc (yaw rate about z, the velocity along the heading), a general screw.
Motion randomMotion(toi_scenes::Rng& r, const Vector3d& p, const Quaterniond& q, double t_ref, int kind) {
  const double v = r.uni(0.1, 1.5);
  switch (kind) {
    case 0: return twist(p, q, r.unit() * v, Vector3d::Zero(), t_ref, false);
    case 1: return twist(p, q, Vector3d::Zero(), r.unit() * r.uni(0.2, 2.5), t_ref, false);
    case 2: {
      const double yaw = r.uni(-M_PI, M_PI);
      const Quaterniond heading(Eigen::AngleAxisd(yaw, Vector3d::UnitZ()));
      return twist(p, heading, heading * Vector3d(v, 0, 0), Vector3d(0, 0, r.uni(-2.0, 2.0)), t_ref, true);
    }
    default: return twist(p, q, r.unit() * v, r.unit() * r.uni(0.1, 2.5), t_ref, true);
  }
}

// ---------------------------------------------------------------------------------------
// 1. appendBrakingKeyframes against the exact braking.

std::vector<Vector3d> spherePoints(double radius) {
  std::vector<Vector3d> out{Vector3d::Zero()};
  const int n = 40;
  for (int i = 0; i < n; ++i) {  // Fibonacci sphere
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double phi = i * 2.399963229728653;
    const double rho = std::sqrt(1.0 - z * z);
    out.emplace_back(radius * rho * std::cos(phi), radius * rho * std::sin(phi), radius * z);
  }
  return out;
}

// The TimedPath's pose at t, through its own pieces (the motions the narrow phase certifies)
// but by the truth's pose formula.
Pose pathPose(const TimedPath& path, double t) { return toi_truth::poseAt(path.motion(path.pieceAt(t)), t); }

double pointsApart(const Pose& a, const Pose& b, const std::vector<Vector3d>& points) {
  double worst = 0.0;
  for (const Vector3d& x : points) worst = std::max(worst, ((a.R * x + a.p) - (b.R * x + b.p)).norm());
  return worst;
}

struct BrakingCase {
  Motion motion;
  double t0, T, radius, max_deviation;
};

// Checks one braking; returns the largest distance seen over the returned deviation.
double checkBraking(const BrakingCase& c, const std::string& what) {
  std::vector<Keyframe> k;
  const double dev = vadop::appendBrakingKeyframes(c.motion, c.t0, c.T, c.radius, c.max_deviation, k);
  const size_t pieces = k.size() - 1;
  EXPECT_GE(dev, 0.0) << what;
  if (dev > c.max_deviation) EXPECT_EQ(pieces, 512u) << what << ": deviation " << dev << " over the asked";
  EXPECT_LE(pieces, 512u) << what;
  EXPECT_DOUBLE_EQ(k.front().time, c.t0) << what;
  EXPECT_DOUBLE_EQ(k.back().time, c.t0 + c.T) << what;
  const TimedPath path(k, AfterPath::kHold);
  const std::vector<Vector3d> points = spherePoints(c.radius);
  const double scale = 1e-9 * (1.0 + c.motion.position.norm() + c.motion.pivot_offset.norm() + c.radius);
  // Starts at motion's pose at t0.
  EXPECT_LE(pointsApart(pathPose(path, c.t0), toi_truth::poseAt(c.motion, c.t0), points), scale) << what;
  double worst = 0.0;
  const int samples = 2000;
  for (int i = 0; i <= samples; ++i) {
    const double t = c.t0 + c.T * i / samples;
    const double d = pointsApart(pathPose(path, t), brakingPose(c.motion, c.t0, c.T, t), points);
    worst = std::max(worst, d);
    if (d > dev + scale) {
      ADD_FAILURE() << what << ": at t0 + " << t - c.t0 << " the keyframes are " << d << " m from the braking, bound "
                    << dev;
      break;
    }
  }
  // Stands still at the end, where motion would be half way through the duration.
  const Pose stop = toi_truth::poseAt(c.motion, c.t0 + 0.5 * c.T);
  for (double after : {0.0, 1e-3, 0.7, 30.0}) {
    EXPECT_LE(pointsApart(pathPose(path, c.t0 + c.T + after), stop, points), scale) << what << " after " << after;
  }
  return dev > 0.0 ? worst / dev : 0.0;
}

TEST(BrakingKeyframes, WithinTheStatedDeviationOfTheExactBraking) {
  toi_scenes::Rng r(4801);
  double tightest = 0.0;
  for (int i = 0; i < 120; ++i) {
    BrakingCase c;
    c.t0 = r.uni(-2.0, 2.0);
    c.motion = randomMotion(r, r.inBox(2.0), r.quat(), c.t0 + r.uni(-1.0, 1.0), i % 4);
    c.T = r.chance(0.1) ? r.logu(1e-3, 0.05) : r.uni(0.05, 3.0);
    c.radius = r.chance(0.1) ? 0.0 : r.logu(0.01, 1.5);
    c.max_deviation = r.logu(1e-5, 0.05);
    tightest = std::max(tightest, checkBraking(c, "case " + std::to_string(i)));
  }
  // The bound is reached (the secant's error at a stretch's middle, for the fastest point):
  // not a bound so loose that any path passes.
  EXPECT_GT(tightest, 0.5);
  std::printf("largest distance seen / deviation returned: %.3f\n", tightest);
}

TEST(BrakingKeyframes, CappedAt512PiecesTheReturnedDeviationStillHolds) {
  BrakingCase c;
  c.t0 = 0.0;
  c.motion = twist(Vector3d::Zero(), Quaterniond::Identity(), Vector3d(10, 0, 0), Vector3d(0, 0, 1.0), 0.0, true);
  c.T = 10.0;
  c.radius = 0.5;
  c.max_deviation = 1e-6;
  std::vector<Keyframe> k;
  const double dev = vadop::appendBrakingKeyframes(c.motion, c.t0, c.T, c.radius, c.max_deviation, k);
  EXPECT_EQ(k.size(), 513u);
  EXPECT_GT(dev, c.max_deviation);
  checkBraking(c, "capped");
}

TEST(BrakingKeyframes, StopsHalfTheWayTheMotionWouldGo) {
  // Straight line at 1 m/s braking over 0.5 s (2 m/s^2): stops 0.25 m ahead.
  const Motion m = twist(Vector3d(1, 2, 3), Quaterniond::Identity(), Vector3d(1, 0, 0), Vector3d::Zero(), 0.0, false);
  std::vector<Keyframe> k;
  const double dev = vadop::appendBrakingKeyframes(m, 0.0, 0.5, 0.3, 1e-4, k);
  EXPECT_LE(dev, 1e-4);
  EXPECT_NEAR(k.back().position.x(), 1.25, 1e-12);
  EXPECT_NEAR((k.back().position - Vector3d(1.25, 2, 3)).norm(), 0.0, 1e-12);
  const TimedPath path(k, AfterPath::kHold);
  EXPECT_NEAR(path.poseAt(0.25).translation().x(), 1.0 + 0.25 - 0.0625, dev + 1e-12);  // u - u^2 / (2T)
  EXPECT_NEAR(path.poseAt(5.0).translation().x(), 1.25, 1e-12);
  // Duration 0: stops at once (one keyframe, motion's pose at t0).
  std::vector<Keyframe> once;
  EXPECT_EQ(vadop::appendBrakingKeyframes(m, 2.0, 0.0, 0.3, 1e-4, once), 0.0);
  ASSERT_EQ(once.size(), 1u);
  EXPECT_NEAR((once[0].position - Vector3d(3, 2, 3)).norm(), 0.0, 1e-12);
  // A turn on the spot at 2 rad/s over 1 s stops after 1 rad.
  const Motion spin = twist(Vector3d::Zero(), Quaterniond::Identity(), Vector3d::Zero(), Vector3d(0, 0, 2), 0.0, false);
  std::vector<Keyframe> turned;
  vadop::appendBrakingKeyframes(spin, 0.0, 1.0, 1.0, 1e-3, turned);
  EXPECT_NEAR(turned.back().orientation.angularDistance(Quaterniond(Eigen::AngleAxisd(1.0, Vector3d::UnitZ()))), 0.0,
              1e-12);
}

TEST(BrakingKeyframes, FollowsKeyframesOfTheHeldMotionWithoutRepeatingThePose) {
  toi_scenes::Rng r(4802);
  const Motion held = randomMotion(r, Vector3d::Zero(), r.quat(), 0.0, 3);
  std::vector<Keyframe> k;
  vadop::appendKeyframes(held, 0.0, 0.4, k);
  const size_t before = k.size();
  vadop::appendBrakingKeyframes(held, 0.4, 0.8, 0.5, 1e-3, k);
  EXPECT_GT(k.size(), before);
  EXPECT_GT(k[before].time, 0.4);  // the pose at 0.4 is not appended twice
  const TimedPath path(k, AfterPath::kHold);
  const std::vector<Vector3d> points = spherePoints(0.5);
  for (double t : {0.0, 0.2, 0.4}) EXPECT_LE(pointsApart(pathPose(path, t), toi_truth::poseAt(held, t), points), 1e-9);
}

TEST(BrakingKeyframes, BadArgumentsThrow) {
  const Motion m = twist(Vector3d::Zero(), Quaterniond::Identity(), Vector3d(1, 0, 0), Vector3d::Zero(), 0.0, false);
  std::vector<Keyframe> k;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, -1.0, 0.1, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, nan, 0.1, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, kInf, 0.1, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, -0.1, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, nan, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, kInf, 1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, 0.1, 0.0, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, 0.1, -1e-3, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, 0.1, nan, k), vadop::InvalidArgument);
  EXPECT_THROW(vadop::appendBrakingKeyframes(m, 0.0, 1.0, 0.1, kInf, k), vadop::InvalidArgument);
  EXPECT_TRUE(k.empty());  // nothing appended on a throw
  try {
    vadop::appendBrakingKeyframes(m, 0.0, 1.0, 0.1, 0.0, k);
  } catch (const vadop::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("max_deviation"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------
// 2. firstContactAlong against the dense truth.

// The mover's manoeuvre: `held` on [t0, ta), `command` on [ta, tb), then braking along
// `command` over T, standing from tb + T.
struct Manoeuvre {
  Motion held, command;
  double t0 = 0.0, ta = 0.0, tb = 0.0, T = 0.0;

  Pose at(double t) const {
    if (t < ta) return toi_truth::poseAt(held, t);
    if (t < tb) return toi_truth::poseAt(command, t);
    return brakingPose(command, tb, T, t);
  }
  // A bound on every point's speed (within `lever` of the origin) from t on.
  double speedFrom(double t, double lever) const {
    const double c = pointSpeed(command, lever);
    if (t < ta) return std::max(pointSpeed(held, lever), c);
    if (t < tb) return c;
    return T > 0.0 ? c * std::max(0.0, 1.0 - (t - tb) / T) : 0.0;
  }
  // The keyframes a gate builds (timed_path.h); *deviation: the braking's bound.
  TimedPath path(double radius, double max_deviation, double* deviation) const {
    std::vector<Keyframe> k;
    vadop::appendKeyframes(held, t0, ta, k);
    vadop::appendKeyframes(command, ta, tb, k);
    *deviation = vadop::appendBrakingKeyframes(command, tb, T, radius, max_deviation, k);
    return TimedPath(k, AfterPath::kHold);
  }
};

Manoeuvre randomManoeuvre(toi_scenes::Rng& r, double t0) {
  Manoeuvre m;
  m.t0 = t0;
  m.ta = t0 + (r.chance(0.2) ? 0.0 : r.uni(0.02, 0.3));
  m.tb = m.ta + (r.chance(0.1) ? 0.0 : r.uni(0.05, 0.5));
  m.T = r.chance(0.1) ? 0.0 : r.uni(0.05, 1.5);
  const int kind_a = r.integer(0, 3), kind_b = r.chance(0.5) ? kind_a : r.integer(0, 3);
  m.held = r.chance(0.15) ? twist(Vector3d::Zero(), r.quat(), Vector3d::Zero(), Vector3d::Zero(), t0, false)
                          : randomMotion(r, Vector3d::Zero(), r.quat(), t0, kind_a);
  const Pose pa = toi_truth::poseAt(m.held, m.ta);
  m.command = randomMotion(r, pa.p, quatOf(pa), m.ta, kind_b);
  if (kind_b == 2) {  // keep the body's own heading: the arc turns from where stage A left it
    const Motion arc = m.command;
    const Vector3d vo_body = Vector3d(r.uni(0.1, 1.5), 0, 0);
    const Vector3d up = quatOf(pa) * Vector3d::UnitZ();
    m.command = twist(pa.p, quatOf(pa), quatOf(pa) * vo_body, up * arc.angular_velocity.z(), m.ta, true);
  }
  return m;
}

struct Gap {
  double lo = kInf, hi = kInf;  // certified bounds of the gap between the padded shapes
};

// The gap of two posed bodies of the truth's geometry: every piece pair whose bounding spheres
// may be nearer than the best pair so far, by the certified min-norm distance.
Gap gapAt(const toi_truth::Body& A, const Pose& PA, const toi_truth::Body& B, const Pose& PB) {
  const size_t na = A.pieces.size(), nb = B.pieces.size();
  std::vector<std::pair<double, size_t>> order;
  order.reserve(na * nb);
  std::vector<Vector3d> cb(nb);
  for (size_t j = 0; j < nb; ++j) cb[j] = PB.R * B.pieces[j].centre + PB.p;
  for (size_t i = 0; i < na; ++i) {
    const Vector3d ca = PA.R * A.pieces[i].centre + PA.p;
    for (size_t j = 0; j < nb; ++j) {
      order.emplace_back((ca - cb[j]).norm() - A.pieces[i].radius - B.pieces[j].radius, i * nb + j);
    }
  }
  std::sort(order.begin(), order.end());
  Gap g;
  for (const auto& [sphere_gap, k] : order) {
    if (sphere_gap >= g.hi) {
      g.lo = std::min(g.lo, sphere_gap);
      break;
    }
    const toi_truth::Piece& a = A.pieces[k / nb];
    const toi_truth::Piece& b = B.pieces[k % nb];
    const toi_truth::CoreDist c = toi_truth::coreDistance(a, PA, b, PB);
    const double rounding = a.rounding + b.rounding;
    g.lo = std::min(g.lo, c.lo - rounding);
    g.hi = std::min(g.hi, c.overlap ? -rounding : c.hi - rounding);
  }
  g.lo = std::min(g.lo, g.hi);
  return g;
}

constexpr double kDtMin = 1e-4;  // s: the truth's finest step (near contact)
constexpr double kDtMax = 1e-2;  // s: and its coarsest (100 samples a second at least)

struct Scan {
  bool contact = false;
  double t_contact = kInf;  // the earliest time found in contact (>= the first contact)
  double min_lo = kInf;     // certified: the gap is >= min_lo over [t0, t1] (up to t_contact)
  int evaluations = 0;
};

// The truth over [t0, t1]: samples stepped by half the certified gap over the speed bound (at
// least dt_min, at most kDtMax), so each stretch between samples is certified above min_lo; at
// the first sample in contact, bisection back to the earliest time found in contact.
template <class PoseA, class PoseB, class Speed>
Scan scan(const toi_truth::Body& A, PoseA pose_a, const toi_truth::Body& B, PoseB pose_b, Speed speed, double t0,
          double t1, double dt_min = kDtMin) {
  Scan s;
  double t = t0, prev = t0;
  for (;;) {
    const Gap g = gapAt(A, pose_a(t), B, pose_b(t));
    ++s.evaluations;
    if (g.hi <= 0.0) {
      s.contact = true;
      double lo = prev, hi = t;
      for (int i = 0; i < 40 && hi - lo > 1e-12; ++i) {
        const double mid = 0.5 * (lo + hi);
        (gapAt(A, pose_a(mid), B, pose_b(mid)).hi <= 0.0 ? hi : lo) = mid;
      }
      s.t_contact = hi;
      return s;
    }
    if (t >= t1) {
      s.min_lo = std::min(s.min_lo, g.lo);
      return s;
    }
    const double L = speed(t);
    double step = L > 0.0 ? std::max(dt_min, 0.5 * g.lo / L) : t1 - t;
    step = std::min({step, kDtMax, t1 - t});
    s.min_lo = std::min(s.min_lo, g.lo - L * step);
    prev = t;
    t = step < t1 - t ? t + step : t1;
  }
}

struct Tally {
  int scenes = 0, contacts = 0, clears = 0, band = 0, missed = 0, false_hits = 0, early = 0;
  int stopping_contacts = 0;  // contacts found only in the others' braking future
  long evaluations = 0;
  void add(const Tally& o) {
    scenes += o.scenes;
    contacts += o.contacts;
    clears += o.clears;
    band += o.band;
    missed += o.missed;
    false_hits += o.false_hits;
    early += o.early;
    stopping_contacts += o.stopping_contacts;
    evaluations += o.evaluations;
  }
};

constexpr double kOthersDeviation = 5e-4;  // world.h: the others' braking within 0.5 mm

struct OtherBody {
  Motion motion;
  double stop = kInf;  // stop duration
};

// One scene: the mover's manoeuvre against `other`, asked with others_stop false and true.
void checkScene(vadop::World& world, const vadop::Shape& mover_shape, const vadop::Shape& other_shape,
                const Manoeuvre& man, const OtherBody& other, double max_deviation, double horizon,
                const std::string& what, Tally& tally) {
  const toi_truth::Body A = toi_truth::makeBody(mover_shape), B = toi_truth::makeBody(other_shape);
  const double lever_a = toi_truth::bodyLever(A), lever_b = toi_truth::bodyLever(B);
  double dev = 0.0;
  const TimedPath path = man.path(mover_shape.bounding_radius, max_deviation, &dev);
  const double t0 = man.t0, t1 = t0 + horizon;
  const double tol = world.config().toi.tolerance;
  const auto mover_pose = [&](double t) { return man.at(t); };
  const auto predicted = [&](double t) { return toi_truth::poseAt(other.motion, t); };
  const auto braking = [&](double t) { return brakingPose(other.motion, t0, other.stop, t); };
  const double other_speed = pointSpeed(other.motion, lever_b);
  const auto speed_predicted = [&](double t) { return man.speedFrom(t, lever_a) + other_speed; };
  const auto speed_braking = [&](double t) {
    const double f = other.stop > 0.0 ? std::max(0.0, 1.0 - (t - t0) / other.stop) : 0.0;
    return man.speedFrom(t, lever_a) + other_speed * f;
  };
  const Scan truth_p = scan(A, mover_pose, B, predicted, speed_predicted, t0, t1, kDtMin);
  const bool stops = std::isfinite(other.stop);
  const Scan truth_b = stops ? scan(A, mover_pose, B, braking, speed_braking, t0, t1, kDtMin) : Scan{};
  tally.evaluations += truth_p.evaluations + truth_b.evaluations;
  // A report at t: the path's gap <= its tolerance there, the exact one within the deviations more.
  const double band_p = std::max(tol, 2.0 * dev) + dev;
  const double band_b = std::max(tol, 2.0 * (dev + kOthersDeviation)) + dev + kOthersDeviation;
  const double slack = 1e-7;

  world.setMotion("other", other.motion);
  world.setStopDuration("other", other.stop);
  vadop::World::PathQuery query;
  query.deviation = dev;
  for (bool others_stop : {false, true}) {
    query.others_stop = others_stop;
    const std::string label = what + (others_stop ? " (others_stop)" : "");
    const std::optional<vadop::World::MoverContact> c = world.firstContactAlong({"mover"}, {path}, t0, horizon, query);
    const bool use_b = others_stop && stops;
    const bool contact = truth_p.contact || (use_b && truth_b.contact);
    const double t_contact = std::min(truth_p.t_contact, use_b ? truth_b.t_contact : kInf);
    const bool clear = !contact && truth_p.min_lo > band_p + slack && (!use_b || truth_b.min_lo > band_b + slack);
    ++tally.scenes;
    if (contact) {
      ++tally.contacts;
      if (use_b && truth_b.t_contact < truth_p.t_contact) ++tally.stopping_contacts;
    } else if (clear) {
      ++tally.clears;
    } else {
      ++tally.band;
    }
    if (contact && (!c || c->impact.time > t_contact + 1e-9)) {
      ++tally.missed;
      ADD_FAILURE() << label << ": missed: the truth touches at " << t_contact - t0 << " s, reported "
                    << (c ? std::to_string(c->impact.time - t0) : std::string("none"));
    }
    if (!c) continue;
    if (clear) {
      ++tally.false_hits;
      ADD_FAILURE() << label << ": false contact at " << c->impact.time - t0 << " s; truth's gap >= "
                    << std::min(truth_p.min_lo, use_b ? truth_b.min_lo : kInf);
      continue;
    }
    EXPECT_FALSE(c->undecided) << label;
    EXPECT_EQ(c->other, "other") << label;
    EXPECT_TRUE(!c->others_stopping || use_b) << label << ": others_stopping without that future";
    // The future it names has the gap within its band at the reported time.
    const double t = c->impact.time;
    const Gap g = gapAt(A, man.at(t), B, c->others_stopping ? braking(t) : predicted(t));
    const double band = c->others_stopping ? band_b : band_p;
    if (g.lo > band + slack) {
      ++tally.early;
      ADD_FAILURE() << label << ": contact reported at " << t - t0 << " s where the truth's gap is " << g.lo
                    << " > band " << band << (c->others_stopping ? " (braking future)" : "");
    }
  }
}

// Places `other` so that near a random time of the window it is about its size from the mover.
OtherBody randomOther(toi_scenes::Rng& r, const Manoeuvre& man, double horizon, double reach, int kind) {
  const double tau = man.t0 + r.uni(0.0, horizon);
  const Pose at = man.at(tau);
  const Vector3d p = at.p + r.unit() * (reach * r.uni(0.3, 1.4) + r.uni(0.0, 0.05));
  OtherBody o;
  if (kind == 0) {
    o.motion = twist(p, r.quat(), Vector3d::Zero(), Vector3d::Zero(), tau, false);
    if (r.chance(0.3)) o.stop = r.uni(0.0, 1.0);  // standing: braking changes nothing
  } else {
    const Vector3d w = r.chance(0.3) ? Vector3d::Zero() : Vector3d(r.unit() * r.uni(0.1, 2.0));
    double t_ref = tau;
    if (kind == 2) {
      o.stop = r.chance(0.15) ? 0.0 : r.uni(0.05, 1.5);
      // Half of them near the mover at tau in the future where they brake (where their motion
      // puts them at t0 + u - u^2 / (2 stop)), not in the predicted one.
      if (r.chance(0.7)) {
        const double u = std::min(tau - man.t0, o.stop);
        t_ref = man.t0 + (o.stop > 0.0 ? u - u * u / (2.0 * o.stop) : 0.0);
      }
    }
    o.motion = twist(p, r.quat(), r.unit() * r.uni(0.1, 1.5), w, t_ref, r.chance(0.5));
  }
  return o;
}

TEST(FirstContactAlong, BrakingManoeuvreAgainstTheDenseTruthForEveryShapeKind) {
  vadop::World world;
  toi_scenes::Rng r(4803);
  Tally total;
  const int per_pair = 24;
  for (ShapeType ka : kShapeKinds) {
    for (ShapeType kb : kShapeKinds) {
      Tally t;
      for (int i = 0; i < per_pair; ++i) {
        const vadop::Shape sa = toi_scenes::randomShape(ka, r), sb = toi_scenes::randomShape(kb, r);
        const double t0 = r.chance(0.5) ? 0.0 : r.uni(-3.0, 3.0);
        const Manoeuvre man = randomManoeuvre(r, t0);
        const double horizon = (man.tb - t0) + man.T + r.uni(0.0, 0.5);
        const double max_deviation = r.logu(3e-4, 3e-3);
        const toi_truth::Body A = toi_truth::makeBody(sa), B = toi_truth::makeBody(sb);
        OtherBody other;
        // Not touching (nor within any band) at t0: the pressing rule is test 3's.
        for (int attempt = 0;; ++attempt) {
          other = randomOther(r, man, horizon, sa.bounding_radius + sb.bounding_radius, i % 3);
          if (gapAt(A, man.at(t0), B, toi_truth::poseAt(other.motion, t0)).lo > 0.02) break;
          ASSERT_LT(attempt, 1000);
        }
        world.add("mover", sa, man.held);
        world.add("other", sb, other.motion);
        const std::string what = std::string(vadop::toString(ka)) + "-" + vadop::toString(kb) + " scene " +
                                 std::to_string(i);
        checkScene(world, sa, sb, man, other, max_deviation, horizon, what, t);
        world.remove("mover");
        world.remove("other");
      }
      std::printf("%-8s %-8s: %2d asked, %2d contacts (%d in the braking future), %2d clear, %d in the band; "
                  "missed %d, false %d, early %d\n",
                  vadop::toString(ka), vadop::toString(kb), t.scenes, t.contacts, t.stopping_contacts, t.clears, t.band,
                  t.missed, t.false_hits, t.early);
      total.add(t);
    }
  }
  std::printf("total: %d asked, %d contacts (%d in the braking future), %d clear, %d in the band; missed %d, false %d, "
              "early %d; %ld truth evaluations\n",
              total.scenes, total.contacts, total.stopping_contacts, total.clears, total.band, total.missed,
              total.false_hits, total.early, total.evaluations);
  EXPECT_EQ(total.missed, 0);
  EXPECT_EQ(total.false_hits, 0);
  EXPECT_EQ(total.early, 0);
  // The scenes are worth their name: contacts and clear ones, some only in the braking future.
  EXPECT_GT(total.contacts, total.scenes / 5);
  EXPECT_GT(total.clears, total.scenes / 5);
  EXPECT_GT(total.stopping_contacts, 0);
  EXPECT_LT(total.band, total.scenes / 10);
}

// ---------------------------------------------------------------------------------------
// 3. The pressing rule: touching at the start of a stretch blocks only where it presses.

Motion rest(const Vector3d& p) {
  return twist(p, Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero(), 0.0, false);
}
Motion along(const Vector3d& p, const Vector3d& v, double t_ref) {
  return twist(p, Quaterniond::Identity(), v, Vector3d::Zero(), t_ref, false);
}

// A manoeuvre from rest at the origin's `start`: `held` until 0.1 s, `command` until 0.4 s,
// braking over 0.5 s.
Manoeuvre fromTouching(const Vector3d& held_velocity, const Vector3d& command_velocity) {
  Manoeuvre m;
  m.t0 = 0.0;
  m.ta = 0.1;
  m.tb = 0.4;
  m.T = 0.5;
  m.held = along(Vector3d::Zero(), held_velocity, 0.0);
  m.command = along(toi_truth::poseAt(m.held, m.ta).p, command_velocity, m.ta);
  return m;
}

std::optional<vadop::World::MoverContact> ask(vadop::World& world, const Manoeuvre& m, double radius, bool others_stop,
                                              double horizon = 1.2) {
  double dev = 0.0;
  const TimedPath path = m.path(radius, 1e-3, &dev);
  vadop::World::PathQuery q;
  q.deviation = dev;
  q.others_stop = others_stop;
  return world.firstContactAlong({"mover"}, {path}, m.t0, horizon, q);
}

TEST(FirstContactAlong, ATouchingPairBlocksOnlyWhereTheStagePressesIt) {
  // The mover (a sphere, then a box) touches a static box's face at x = 0.2 at t0 (gap 0).
  for (const vadop::Shape& mover : {vadop::makeSphere(0.2), vadop::makeBox(Vector3d(0.4, 0.4, 0.4))}) {
    vadop::World world;
    world.add("wall", vadop::makeBox(Vector3d(0.2, 2.0, 2.0)), rest(Vector3d(0.3, 0, 0)));
    world.add("mover", mover, rest(Vector3d::Zero()));
    const std::string what = vadop::toString(mover.type);
    const double r = mover.bounding_radius;
    const Vector3d zero = Vector3d::Zero(), in(0.5, 0, 0), away(-0.5, 0, 0), slide(0, 0.5, 0);
    // At rest through the reaction time, then away: never pressed.
    EXPECT_FALSE(ask(world, fromTouching(zero, away), r, false)) << what;
    EXPECT_FALSE(ask(world, fromTouching(zero, away), r, true)) << what;
    // At rest, then sliding along the face: not pressed either.
    EXPECT_FALSE(ask(world, fromTouching(zero, slide), r, false)) << what;
    // At rest, then into it: a contact at the stage boundary.
    auto c = ask(world, fromTouching(zero, in), r, false);
    ASSERT_TRUE(c) << what;
    EXPECT_EQ(c->other, "wall");
    EXPECT_NEAR(c->impact.time, 0.1, 1e-9) << what;
    EXPECT_FALSE(c->others_stopping);
    // Into it from the start: a contact at t0.
    c = ask(world, fromTouching(in, in), r, false);
    ASSERT_TRUE(c) << what;
    EXPECT_NEAR(c->impact.time, 0.0, 1e-9) << what;
    // Away during the reaction time (to x = -0.05), then back at 1 m/s: touches again at 0.15 s.
    c = ask(world, fromTouching(away, Vector3d(1.0, 0, 0)), r, false);
    ASSERT_TRUE(c) << what;
    EXPECT_NEAR(c->impact.time, 0.15, 2.5e-3) << what;  // the band: 2 mm of tolerance at 1 m/s
    EXPECT_LE(c->impact.time, 0.15 + 1e-9) << what;
  }
}

// ---------------------------------------------------------------------------------------
// 4. Scenes built where keyframes alone would be wrong.

// A body crossing the mover's line where the exact braking is, while the mover's keyframes
// (one stretch: the mean speed) lag a quarter of a metre behind: the deviation's tolerance
// must find it.
TEST(FirstContactAlong, ACrossingTheExactBrakingReachesIsFoundWhereItsKeyframesLag) {
  vadop::World world;
  world.add("mover", vadop::makeSphere(0.1), rest(Vector3d::Zero()));
  // Crosses x = 0.75 (where the exact braking is at 0.5 s) at 0.5 s, at 4 m/s along -y.
  world.add("crossing", vadop::makeSphere(0.05), along(Vector3d(0.75, 0, 0), Vector3d(0, -4, 0), 0.5));
  Manoeuvre m;
  m.held = m.command = along(Vector3d::Zero(), Vector3d(2, 0, 0), 0.0);
  m.T = 1.0;  // from 2 m/s to rest over 1 s: 1 m
  double dev = 0.0;
  const TimedPath path = m.path(0.1, 1.0, &dev);
  ASSERT_EQ(path.keyframes().size(), 2u);  // one stretch at the mean speed, 1 m/s
  EXPECT_DOUBLE_EQ(dev, 0.25);
  // The keyframes pass 0.24 m from the crossing body's centre (0.15 would touch), the exact
  // braking through it; the truth's first contact:
  const toi_truth::Body A = toi_truth::makeBody(vadop::makeSphere(0.1));
  const toi_truth::Body B = toi_truth::makeBody(vadop::makeSphere(0.05));
  const Motion crossing = along(Vector3d(0.75, 0, 0), Vector3d(0, -4, 0), 0.5);
  const Scan truth = scan(
      A, [&](double t) { return m.at(t); }, B, [&](double t) { return toi_truth::poseAt(crossing, t); },
      [](double) { return 6.0; }, 0.0, 1.5);
  ASSERT_TRUE(truth.contact);
  vadop::World::PathQuery q;
  q.deviation = dev;
  const auto c = world.firstContactAlong({"mover"}, {path}, 0.0, 1.5, q);
  ASSERT_TRUE(c) << "the exact braking touches at " << truth.t_contact;
  EXPECT_EQ(c->other, "crossing");
  EXPECT_LE(c->impact.time, truth.t_contact + 1e-9);
}

// A body braking towards a plate that sweeps across its line after its predicted self has
// passed: it touches only in the future where it brakes, at the middle of one of its braking
// keyframes' stretches, where those lag most (0.47 mm) behind the exact braking.
TEST(FirstContactAlong, TheOthersBrakingIsCheckedWithinItsKeyframesDeviation) {
  const double v = 2.0, stop = 1.0, r = 0.05;
  const Motion braker = along(Vector3d::Zero(), Vector3d(-v, 0, 0), 0.0);
  std::vector<Keyframe> k;  // the others' keyframes as world.h builds them (0.5 mm)
  vadop::appendBrakingKeyframes(braker, 0.0, stop, r, kOthersDeviation, k);
  ASSERT_GT(k.size(), 10u);
  const size_t mid = (k.size() - 1) / 2;
  const double t_c = 0.5 * (k[mid - 1].time + k[mid].time);  // the middle of a stretch
  const double x_c = -(v * t_c - v * t_c * t_c / (2.0 * stop));   // the exact braking there
  const double face = x_c - r;
  const Vector3d plate_size(0.02, 0.4, 0.4);
  const Vector3d plate_at_tc(face - 0.01, -0.18, 0.0);  // covering the line y = 0 at t_c
  const Motion plate = along(plate_at_tc, Vector3d(0, 2, 0), t_c);
  vadop::World world;
  world.add("braker", vadop::makeSphere(r), braker);
  world.add("mover", vadop::makeBox(plate_size), plate);
  world.setStopDuration("braker", stop);
  // The truth: no contact in the predicted future; the braking one touches first at t_c.
  const toi_truth::Body A = toi_truth::makeBody(vadop::makeBox(plate_size));
  const toi_truth::Body B = toi_truth::makeBody(vadop::makeSphere(r));
  const auto plate_pose = [&](double t) { return toi_truth::poseAt(plate, t); };
  const auto speed = [](double) { return 5.0; };
  const auto braker_predicted = [&](double t) { return toi_truth::poseAt(braker, t); };
  const auto braker_braking = [&](double t) { return brakingPose(braker, 0.0, stop, t); };
  const Scan predicted = scan(A, plate_pose, B, braker_predicted, speed, 0.0, 1.2);
  const Scan braking = scan(A, plate_pose, B, braker_braking, speed, 0.0, 1.2);
  ASSERT_FALSE(predicted.contact);
  ASSERT_GT(predicted.min_lo, 0.01);
  ASSERT_TRUE(braking.contact);
  ASSERT_NEAR(braking.t_contact, t_c, 1e-6);
  const TimedPath path(plate);
  vadop::World::PathQuery q;
  EXPECT_FALSE(world.firstContactAlong({"mover"}, {path}, 0.0, 1.2, q));
  q.others_stop = true;
  const auto c = world.firstContactAlong({"mover"}, {path}, 0.0, 1.2, q);
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->others_stopping);
  EXPECT_EQ(c->other, "braker");
  EXPECT_LE(c->impact.time, braking.t_contact + 1e-9);
  EXPECT_GE(c->impact.time, braking.t_contact - 3e-3);  // the band: 2 mm at 1 m/s
}

// A follower 0.2 m behind a leader, both at 1 m/s: the follower's manoeuvre (1 m/s held for
// the reaction time and the command, then braking at 1 m/s^2) is clear of the leader going on,
// and touches the leader braking hard (within 0.2 s) at 0.2 + 1 - sqrt(0.8) s.
TEST(FirstContactAlong, AFollowerTouchesALeaderThatBrakesOnlyInTheOthersStopFuture) {
  vadop::World world;
  world.add("leader", vadop::makeSphere(0.2), along(Vector3d(0.6, 0, 0), Vector3d(1, 0, 0), 0.0));
  world.add("mover", vadop::makeSphere(0.2), along(Vector3d::Zero(), Vector3d(1, 0, 0), 0.0));
  Manoeuvre m;
  m.held = m.command = along(Vector3d::Zero(), Vector3d(1, 0, 0), 0.0);
  m.ta = 0.1;
  m.tb = 0.2;
  m.T = 1.0;
  // No stop duration: it is not known to stop; that future moves it as set.
  EXPECT_FALSE(ask(world, m, 0.2, false, 2.0));
  EXPECT_FALSE(ask(world, m, 0.2, true, 2.0));
  world.setStopDuration("leader", 0.2);
  EXPECT_FALSE(ask(world, m, 0.2, false, 2.0));
  auto c = ask(world, m, 0.2, true, 2.0);
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->others_stopping);
  EXPECT_EQ(c->other, "leader");
  const double t_star = 0.2 + 1.0 - std::sqrt(0.8);
  EXPECT_LE(c->impact.time, t_star + 1e-9);
  EXPECT_GE(c->impact.time, t_star - 5e-3);  // the band: 4 mm at 0.9 m/s
  // Stopping at once: the follower reaches it at 0.2 s.
  world.setStopDuration("leader", 0.0);
  c = ask(world, m, 0.2, true, 2.0);
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->others_stopping);
  EXPECT_NEAR(c->impact.time, 0.2, 5e-3);
  EXPECT_LE(c->impact.time, 0.2 + 1e-9);
  // Bad stop durations throw and change nothing.
  EXPECT_THROW(world.setStopDuration("leader", -1.0), vadop::InvalidArgument);
  EXPECT_THROW(world.setStopDuration("leader", std::numeric_limits<double>::quiet_NaN()), vadop::InvalidArgument);
  EXPECT_THROW(world.setStopDuration("nobody", 1.0), vadop::InvalidArgument);
  c = ask(world, m, 0.2, true, 2.0);
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->impact.time, 0.2, 5e-3);
  world.setStopDuration("leader", kInf);
  EXPECT_FALSE(ask(world, m, 0.2, true, 2.0));
}

// A body touching a wall with a face (or within the tolerance of it) that turns in place: the
// closing speed at one witness point of the face says nothing of its corners, one of which digs
// into the wall at once (the truth's gap goes below zero within the stage). A round body turning
// in place, or a box sliding along the wall, presses nothing.
TEST(FirstContactAlong, AFaceTouchingAWallThatTurnsDigsACornerIn) {
  const vadop::Shape box = vadop::makeBox(Vector3d(0.4, 0.4, 0.4));
  const vadop::Shape wall = vadop::makeBox(Vector3d(0.2, 2.0, 2.0));
  const toi_truth::Body A = toi_truth::makeBody(box), B = toi_truth::makeBody(wall);
  for (double gap0 : {0.0, 1e-7, 5e-4}) {
    for (double w : {1.0, -1.0}) {
      const std::string what = "gap " + std::to_string(gap0) + ", turning at " + std::to_string(w) + " rad/s";
      vadop::World world;
      const Motion wall_motion = rest(Vector3d(0.3 + gap0, 0, 0));
      world.add("wall", wall, wall_motion);
      world.add("mover", box, rest(Vector3d::Zero()));
      Manoeuvre m = fromTouching(Vector3d::Zero(), Vector3d::Zero());
      m.command.angular_velocity = Vector3d(0, 0, w);
      const Scan truth = scan(
          A, [&](double t) { return m.at(t); }, B, [&](double t) { return toi_truth::poseAt(wall_motion, t); },
          [&](double t) { return m.speedFrom(t, toi_truth::bodyLever(A)); }, 0.1, 1.2);
      ASSERT_TRUE(truth.contact) << what;
      const auto c = ask(world, m, box.bounding_radius, false);
      ASSERT_TRUE(c) << what << ": the truth touches at " << truth.t_contact;
      EXPECT_LE(c->impact.time, truth.t_contact + 1e-9) << what;
      EXPECT_GE(c->impact.time, 0.1 - 1e-9) << what;  // not during the reaction time at rest
    }
  }
  // Not blocked: a cylinder turning in place against the wall; a box sliding along it.
  vadop::World world;
  world.add("wall", wall, rest(Vector3d(0.3, 0, 0)));
  world.add("mover", vadop::makeCylinder(0.2, 0.4), rest(Vector3d::Zero()));
  Manoeuvre turn = fromTouching(Vector3d::Zero(), Vector3d::Zero());
  turn.command.angular_velocity = Vector3d(0, 0, 1.0);
  EXPECT_FALSE(ask(world, turn, 0.3, false));
  world.remove("mover");
  world.add("mover", box, rest(Vector3d::Zero()));
  EXPECT_FALSE(ask(world, fromTouching(Vector3d::Zero(), Vector3d(0, 0.5, 0.2)), box.bounding_radius, false));
}

}  // namespace
