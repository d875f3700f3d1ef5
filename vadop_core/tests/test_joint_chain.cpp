// Links of joint chains (joint_chain.h) against an independent truth: its own joint
// interpolation and forward kinematics (rotation matrices by Rodrigues' formula, composed by
// hand), the static distance of toi_truth.h (explicit vertices, brute-force min-norm), and a
// left-first bisection in time certified by the Lipschitz bound of the gap (every point's
// speed bounded with the whole chain's reach at every joint: looser than the library's, and
// computed on its own), with the chains' bases on one twist and on timed paths (the path's own
// truth: path_truth.h). Analytic cases pin an arm turning into a post and a slide.
// VADOP_TOI_CASES sets the random cases per chain length (default 150, 12 under ASan).
#include "chain_scenes.h"
#include "toi_scenes.h"
#include "toi_truth.h"

#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/error.h"
#include "vadop/joint_chain.h"
#include "vadop/scene_io.h"
#include "vadop/vadop.h"
#include "vadop/world.h"

#include "impact_compare.h"

#include <gtest/gtest.h>

#include <time.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace chain_scenes;  // NOLINT: the scenes of this test (and their Eigen / vadop names)

using Eigen::AngleAxisd;
using Eigen::Quaterniond;

constexpr double kTol = 1e-6;  // ToiOptions default
constexpr double kEps = 1e-9;  // truth time resolution (s)

#if defined(__SANITIZE_ADDRESS__)
constexpr int kDefaultCases = 12;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kDefaultCases = 12;
#else
constexpr int kDefaultCases = 150;
#endif
#else
constexpr int kDefaultCases = 150;
#endif

int caseCount() {
  const char* env = std::getenv("VADOP_TOI_CASES");
  if (env != nullptr && std::atoi(env) > 0) return std::atoi(env);
  return kDefaultCases;
}

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// ------------------------------------------------------------------------------------------
// The truth's gap and its first crossing.

struct Gap {
  double t = 0.0, lo = 0.0, hi = 0.0;
};

class ChainTruth {
 public:
  ChainTruth(const vadop::Shape& sa, const TChain& a, const vadop::Shape& sb, const TChain& b, double t0, double t1)
      : A_(toi_truth::makeBody(sa)), B_(toi_truth::makeBody(sb)), a_(a), b_(b) {
    lipschitz_ = truthSpeed(a, toi_truth::bodyLever(A_), t0, t1) + truthSpeed(b, toi_truth::bodyLever(B_), t0, t1);
  }
  Gap at(double t) {
    ++evaluations_;
    const toi_truth::Pose pa = truthPose(a_, t), pb = truthPose(b_, t);
    Gap g{t, toi_truth::kInf, toi_truth::kInf};
    for (const auto& A : A_.pieces) {
      for (const auto& B : B_.pieces) {
        const toi_truth::CoreDist c = toi_truth::coreDistance(A, pa, B, pb);
        const double rnd = A.rounding + B.rounding;
        g.lo = std::min(g.lo, c.lo - rnd);
        g.hi = std::min(g.hi, c.hi - rnd);
      }
    }
    return g;
  }
  // First time in (a.t, b.t] with gap <= theta (to eps), given gap(a.t) > theta; found=false
  // when [a.t, b.t] is certified above theta.
  bool first(const Gap& a, const Gap& b, double theta, double* t, int depth = 0) {
    if (evaluations_ > kMaxEvaluations) {
      gave_up_ = true;
      return false;
    }
    if (0.5 * (a.lo + b.lo - lipschitz_ * (b.t - a.t)) > theta) return false;
    if (b.t - a.t <= kEps || depth > 200) {
      *t = b.t;
      return true;
    }
    const Gap m = at(0.5 * (a.t + b.t));
    if (first(a, m, theta, t, depth + 1)) return true;
    if (m.lo <= theta) {
      *t = m.t;
      return true;
    }
    return first(m, b, theta, t, depth + 1);
  }
  bool gaveUp() const { return gave_up_; }
  long evaluations() const { return evaluations_; }

 private:
  static constexpr long kMaxEvaluations = 400000;
  toi_truth::Body A_, B_;
  TChain a_, b_;
  double lipschitz_ = 0.0;
  long evaluations_ = 0;
  bool gave_up_ = false;
};

enum class Verdict { kClear, kGraze, kContact, kUnknown };
struct Answer {
  Verdict verdict = Verdict::kClear;
  double t_tol = 0.0, t_star = 0.0, closing = 0.0;
  bool initial = false;
};

Answer classify(ChainTruth& tr, double t0, double t1) {
  Answer out;
  const Gap g0 = tr.at(t0), g1 = tr.at(t1);
  if (g0.lo <= 0.0) {
    out.verdict = Verdict::kContact;
    out.initial = true;
    out.t_tol = out.t_star = t0;
    return out;
  }
  double t_tol = t0;
  if (g0.lo > kTol && !tr.first(g0, g1, kTol, &t_tol)) {
    out.verdict = tr.gaveUp() ? Verdict::kUnknown : Verdict::kClear;
    return out;
  }
  out.t_tol = t_tol;
  const Gap gt = tr.at(t_tol);
  double t_star = t_tol;
  if (gt.lo > 0.0 && !tr.first(gt, g1, 0.0, &t_star)) {
    out.verdict = tr.gaveUp() ? Verdict::kUnknown : Verdict::kGraze;
    return out;
  }
  out.verdict = Verdict::kContact;
  out.t_star = t_star;
  const double dt = std::min(1e-5, t_star - t0);
  if (dt > 0.0) out.closing = (tr.at(t_star - dt).hi - tr.at(t_star).hi) / dt;
  return out;
}

// ------------------------------------------------------------------------------------------

TEST(JointPath, InterpolatesHoldsAndContinues) {
  const JointPath p({1.0, 2.0, 4.0}, {0.0, 1.0, 0.0}, 0.5);
  EXPECT_DOUBLE_EQ(p.positionAt(0.0), 0.0);
  EXPECT_DOUBLE_EQ(p.positionAt(1.5), 0.5);
  EXPECT_DOUBLE_EQ(p.positionAt(3.0), 0.5);
  EXPECT_DOUBLE_EQ(p.positionAt(6.0), 1.0);
  EXPECT_DOUBLE_EQ(p.maxSpeed(1.2, 1.8), 1.0);
  EXPECT_DOUBLE_EQ(p.maxSpeed(2.5, 3.5), 0.5);
  EXPECT_DOUBLE_EQ(p.maxSpeed(-1.0, 0.5), 0.0);
  EXPECT_DOUBLE_EQ(p.maxAbsPosition(0.0, 3.0), 1.0);
  EXPECT_DOUBLE_EQ(p.nextBreak(2.0), 4.0);
  EXPECT_TRUE(std::isinf(p.nextBreak(4.0)));
}

TEST(JointPath, CubicThroughPositionsAndVelocities) {
  const JointPath p({0.0, 1.0}, {0.0, 1.0}, 0.0, {0.0, 0.0});
  EXPECT_DOUBLE_EQ(p.positionAt(0.5), 0.5);
  EXPECT_DOUBLE_EQ(p.velocityAt(0.5), 1.5);  // the cubic's steepest point
  EXPECT_DOUBLE_EQ(p.maxSpeed(0.0, 1.0), 1.5);
  EXPECT_DOUBLE_EQ(p.velocityAt(1.0), 0.0);  // holds after
  // Out and back between two equal positions: 2u^3 - 3u^2 + u peaks at sqrt(3) / 18.
  const JointPath bump({0.0, 1.0}, {0.0, 0.0}, 0.0, {1.0, 1.0});
  EXPECT_NEAR(bump.maxAbsPosition(0.0, 1.0), std::sqrt(3.0) / 18.0, 1e-15);
  EXPECT_DOUBLE_EQ(bump.velocityAt(0.0), 1.0);
  EXPECT_THROW(JointPath({0.0, 1.0}, {0.0, 1.0}, 0.0, {0.0}), vadop::InvalidArgument);
}

TEST(JointPath, ConstantVelocityStopsAtTheLimit) {
  const JointPath p = JointPath::constantVelocity(1.0, 0.5, 0.25, -1.0, 1.0);
  EXPECT_DOUBLE_EQ(p.positionAt(1.0), 0.5);
  EXPECT_DOUBLE_EQ(p.positionAt(2.0), 0.75);
  EXPECT_DOUBLE_EQ(p.positionAt(3.0), 1.0);
  EXPECT_DOUBLE_EQ(p.positionAt(10.0), 1.0);
  EXPECT_DOUBLE_EQ(p.maxSpeed(3.5, 9.0), 0.0);
  const JointPath out = JointPath::constantVelocity(0.0, 2.0, 1.0, -1.0, 1.0);  // clamped, pushing on
  EXPECT_DOUBLE_EQ(out.positionAt(5.0), 1.0);
  const JointPath free = JointPath::constantVelocity(0.0, 0.0, -2.0);
  EXPECT_DOUBLE_EQ(free.positionAt(3.0), -6.0);
}

TEST(JointPath, BadInputNamesTheEntry) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const vadop::InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([] { JointPath({}, {}); }), "JointPath: no position");
  EXPECT_EQ(message([] { JointPath({0.0, 1.0}, {0.0}); }), "JointPath: 2 times but 1 positions");
  EXPECT_EQ(message([] { JointPath({0.0, 0.0}, {0.0, 1.0}); }), "JointPath: time 1 (0) does not increase");
  EXPECT_EQ(message([] { JointPath({0.0}, {NAN}); }), "JointPath: position 0 is not finite");
  EXPECT_EQ(message([] { JointPath::constantVelocity(0.0, 0.0, 1.0, 1.0, -1.0); }),
            "JointPath: need lower <= upper, got 1 > -1");
  ChainJoint j;
  j.type = JointType::kRevolute;
  j.axis = Vector3d::Zero();
  EXPECT_EQ(message([&] { LinkChain(TimedPath(vadop::Motion()), {ChainJoint(), j}); }),
            "LinkChain: joint 1: axis is zero or not finite");
  ChainJoint s;
  s.origin.linear() = 2.0 * Matrix3d::Identity();
  EXPECT_EQ(message([&] { LinkChain(TimedPath(vadop::Motion()), {s}); }),
            "LinkChain: joint 0: origin rotation is not a rotation");
}

TEST(LinkChain, ForwardKinematicsMatchesTheTruthsOwn) {
  toi_scenes::Rng r(11);
  double worst_p = 0.0, worst_r = 0.0;
  for (int c = 0; c < 300; ++c) {
    const TChain tc = randomChain(r, r.integer(0, 6));
    const LinkChain chain = ours(tc);
    for (int i = 0; i <= 20; ++i) {
      const double t = -0.5 + 3.0 * i / 20.0;
      const toi_truth::Pose P = truthPose(tc, t);
      const Isometry3d x = chain.poseAt(t);
      worst_p = std::max(worst_p, (x.translation() - P.p).norm());
      worst_r = std::max(worst_r, (x.linear() - P.R).norm());
    }
  }
  EXPECT_LT(worst_p, 1e-9);
  EXPECT_LT(worst_r, 1e-9);
}

// Random points of random chains' links at random times: f(tc, chain, radius, t, e, tm, y) for
// a stretch [t, e] without a velocity break, tm in it at least 2h from its ends, y a point of
// the link within `radius` of its origin (link frame); 300 chains of 1 to 6 joints, 20 draws each.
template <class F>
void forEachSampledPoint(toi_scenes::Rng& r, double h, F&& f) {
  for (int c = 0; c < 300; ++c) {
    const TChain tc = randomChain(r, r.integer(1, 6));
    const LinkChain chain = ours(tc);
    const double radius = r.uni(0.0, 0.5);
    for (int i = 0; i < 20; ++i) {
      const double t = r.uni(-0.2, 2.5);
      const double e = std::min(t + 0.2, chain.nextBreak(t));
      if (e - t < 4 * h) continue;
      const double tm = r.uni(t + 2 * h, e - 2 * h);
      const Vector3d y = r.unit() * radius * std::cbrt(r.uni(0.0, 1.0));
      f(tc, chain, radius, t, e, tm, y);
    }
  }
}

// Finite differences of random points' paths never exceed the bound.
TEST(LinkChain, SpeedBoundHoldsForEveryPoint) {
  toi_scenes::Rng r(12);
  double worst = 0.0, mean_ratio = 0.0, worst_velocity = 0.0, worst_reach = -1.0;
  int n = 0;
  const double h = 1e-6;
  forEachSampledPoint(r, h, [&](const TChain& tc, const LinkChain& chain, double radius, double t, double e, double tm,
                                const Vector3d& y) {
    const double bound = chain.bounds(t, e, radius).speed;
    const Vector3d v = (truthPose(tc, tm + h).R * y + truthPose(tc, tm + h).p -
                        truthPose(tc, tm - h).R * y - truthPose(tc, tm - h).p) / (2 * h);
    worst = std::max(worst, v.norm() - bound);
    // The exact velocity and the reach agree with the truth's kinematics.
    const Vector3d x = truthPose(tc, tm).R * y + truthPose(tc, tm).p;
    worst_velocity = std::max(worst_velocity, (chain.velocityOfPoint(x, tm) - v).norm());
    const Matrix3d dR = (truthPose(tc, tm + h).R - truthPose(tc, tm - h).R) / (2 * h) * truthPose(tc, tm).R.transpose();
    worst_velocity = std::max(worst_velocity, (chain.angularVelocity(tm) - Vector3d(dR(2, 1), dR(0, 2), dR(1, 0))).norm());
    worst_reach = std::max(worst_reach, (truthPose(tc, tm).p - toi_truth::poseAt(tc.base, tm).p).norm() - chain.reach(t, e));
    if (bound > 0) mean_ratio += v.norm() / bound, ++n;
  });
  std::printf("[speed bound] worst excess %.3e m/s, mean |v| / bound %.2f over %d points\n", worst, mean_ratio / n, n);
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(worst_velocity, 1e-5);  // finite differences, h = 1e-6 s
  EXPECT_LT(worst_reach, 1e-12);
}

// Second differences of random points' paths never exceed the acceleration bound, nor the
// link's turning its angular speed bound; stateAt agrees with poseAt, velocityOfPoint and
// angularVelocity. The twist steps of the chain narrow phase rest on these bounds.
TEST(LinkChain, AccelerationBoundHoldsForEveryPoint) {
  toi_scenes::Rng r(13);
  double worst = 0.0, worst_w = 0.0, worst_state = 0.0, ratio = 0.0;
  int n = 0, cubic = 0;
  const double h = 1e-4;
  forEachSampledPoint(r, h, [&](const TChain& tc, const LinkChain& chain, double radius, double t, double e, double tm,
                                const Vector3d& y) {
    const LinkChain::StretchBounds bounds = chain.bounds(t, e, radius);
    const double bound = bounds.acceleration;
    auto at = [&](double s) { return Vector3d(truthPose(tc, s).R * y + truthPose(tc, s).p); };
    const Vector3d a = (at(tm + h) - 2.0 * at(tm) + at(tm - h)) / (h * h);
    worst = std::max(worst, a.norm() - bound);
    if (bound > 0) ratio += a.norm() / bound, ++n;
    worst_w = std::max(worst_w, chain.angularVelocity(tm).norm() - bounds.angular_speed);
    const vadop::PosedTwist st = chain.stateAt(tm);
    const Isometry3d x = chain.poseAt(tm);
    worst_state = std::max({worst_state, (st.pose.matrix() - x.matrix()).norm(),
                            (st.velocity - chain.velocityOfPoint(x.translation(), tm)).norm(),
                            (st.angular_velocity - chain.angularVelocity(tm)).norm()});
    for (const TJoint& j : tc.joints) cubic += !j.qd.empty() && tm > j.times.front() && tm < j.times.back();
  });
  std::printf("[acceleration bound] worst excess %.3e m/s^2, mean |a| / bound %.2f over %d points (%d on cubic pieces)\n",
              worst, ratio / n, n, cubic);
  EXPECT_LT(worst, 1e-3);  // second differences, h = 1e-4 s
  EXPECT_LT(worst_w, 1e-12);
  EXPECT_LT(worst_state, 1e-12);
  EXPECT_GT(cubic, 100);  // the joints' own accelerations are exercised
}

// LinkChain::partBoxes (the world's part boxes of moving links) hold the link,
// every point of its shape sampled densely against the truth's own kinematics, over windows as
// long as a time slice, over whole horizons and over their parts, breaks inside included; and a
// slice's box is tighter than the ball of the link's reach.
TEST(LinkChain, PartBoxesHoldTheLinkOverEveryWindow) {
  toi_scenes::Rng r(14);
  double worst = -1.0, slice_extent = 0.0, ball_extent = 0.0;
  int windows = 0, rigid = 0;
  for (int c = 0; c < 300; ++c) {
    TChain tc = randomChain(r, r.integer(1, 6));
    if (c % 4 == 0) {
      // Every joint standing at its position: the link rides on the base (SweptBody's boxes).
      for (TJoint& j : tc.joints) {
        j.times = {0.0};
        j.q = {j.q.front()};
        j.qd.clear();
        j.after = 0.0;
      }
    }
    const LinkChain chain = ours(tc);
    const vadop::Shape shape = randomLinkShape(r);
    for (int i = 0; i < 4; ++i) {
      // A slice, a window of up to 2.5 s, and the same split in 8 parts by partBoxes.
      const double t0 = r.uni(-0.3, 2.0), t1 = t0 + (i % 2 ? 0.25 : r.uni(0.0, 2.5));
      const int parts = i == 2 ? 8 : 1;
      std::vector<double> boxes(6 * static_cast<size_t>(parts));
      chain.partBoxes(shape, t0, t1, parts, boxes.data());
      rigid += !chain.jointsMove(t0, t1);
      for (int p = 0; p < parts; ++p) {
        const double s0 = p == 0 ? t0 : vadop::SweptBody::partEnd(t0, t1, p - 1, parts);
        const double s1 = vadop::SweptBody::partEnd(t0, t1, p, parts);
        const double* box = &boxes[6 * static_cast<size_t>(p)];
        for (int s = 0; s <= 200; ++s) {
          const toi_truth::Pose P = truthPose(tc, s0 + (s1 - s0) * s / 200.0);
          for (int k = 0; k < 3; ++k) {
            const Vector3d axis = P.R.row(k).transpose();
            const double hi = P.p[k] + vadop::support(shape, axis), lo = P.p[k] - vadop::support(shape, -axis);
            worst = std::max({worst, hi - box[3 + k], box[k] - lo});
          }
        }
        ++windows;
      }
      if (i % 2) {
        slice_extent += boxes[3] - boxes[0];
        ball_extent += 2.0 * (shape.bounding_radius + chain.reach(t0, t1));
      }
    }
  }
  std::printf("[part boxes] worst excess %.3e m over %d windows (%d calls with every joint still); x extent over a "
              "0.25 s slice %.2f of the reach ball's\n",
              worst, windows, rigid, slice_extent / ball_extent);
  EXPECT_LE(worst, 1e-12);  // the truth's rounding
  EXPECT_GT(rigid, 300);
  EXPECT_LT(slice_extent, 0.8 * ball_extent);
}

// A link 1 m out on a joint turning at 1 rad/s meets a post at angle 1 rad: both spheres of
// radius 0.1, so the centres' chord is 0.2 at the angle 2 asin(0.1) before the post.
TEST(LinkChain, ArmTurnsIntoThePostOnTime) {
  ChainJoint shoulder;
  shoulder.type = JointType::kRevolute;
  shoulder.path = JointPath::constantVelocity(0.0, 0.0, 1.0);
  ChainJoint link;  // fixed, 1 m along x
  link.origin.translation() = Vector3d(1, 0, 0);
  const LinkChain arm(TimedPath(vadop::Motion()), {shoulder, link});
  const LinkChain post(TimedPath(vadop::makeMotion(Vector3d(std::cos(1.0), std::sin(1.0), 0), Quaterniond::Identity(),
                                                   Vector3d::Zero(), Vector3d::Zero())));
  const vadop::PreparedShape ball(vadop::makeSphere(0.1));
  const vadop::TimeOfImpact hit = vadop::timeOfImpact(ball, arm, ball, post, 0.0, 2.0);
  ASSERT_TRUE(hit.hit);
  const double expected = 1.0 - 2.0 * std::asin(0.1);
  EXPECT_NEAR(hit.time, expected, 2e-6);
  EXPECT_LE(hit.time, expected);
  const Vector3d centre(std::cos(expected), std::sin(expected), 0);
  EXPECT_NEAR((hit.normal - (post.poseAt(0).translation() - centre).normalized()).norm(), 0.0, 1e-3);
  // A joint limit at 0.7 rad stops the arm short of the post.
  ChainJoint limited = shoulder;
  limited.path = JointPath::constantVelocity(0.0, 0.0, 1.0, -0.7, 0.7);
  EXPECT_FALSE(vadop::timeOfImpact(ball, LinkChain(TimedPath(vadop::Motion()), {limited, link}), ball, post, 0.0, 2.0).hit);
  // A slide: a prismatic joint at 0.5 m/s carries the ball 0.8 m to the post at x = 1.
  ChainJoint slide;
  slide.type = JointType::kPrismatic;
  slide.axis = Vector3d::UnitX();
  slide.path = JointPath::constantVelocity(0.0, 0.0, 0.5);
  const LinkChain far(TimedPath(vadop::makeMotion(Vector3d(1, 0, 0), Quaterniond::Identity(), Vector3d::Zero(),
                                                  Vector3d::Zero())));
  const vadop::TimeOfImpact slid = vadop::timeOfImpact(ball, LinkChain(TimedPath(vadop::Motion()), {slide}), ball, far, 0.0, 2.0);
  ASSERT_TRUE(slid.hit);
  EXPECT_NEAR(slid.time, 1.6, 1e-5);
}

// The speed bounds of a stretch hold up to the next velocity break only: a joint creeping at
// 0.01 and 0.02 rad/s until t = 1.5 s, then turning at 6 rad/s, swings its link into a post at
// 1.3 rad in the last stretch; a step certified by the first stretch's speeds (which would
// reach past t1 = 2 s) must not declare the whole window clear.
TEST(LinkChain, ACertificateEndsAtTheNextVelocityBreak) {
  ChainJoint shoulder;
  shoulder.type = JointType::kRevolute;
  shoulder.path = JointPath({0.0, 1.0, 1.5, 2.0}, {0.0, 0.01, 0.02, 3.02});
  ChainJoint link;  // fixed, 1 m along x
  link.origin.translation() = Vector3d(1, 0, 0);
  const LinkChain arm(TimedPath(vadop::Motion()), {shoulder, link});
  const double post_angle = 1.3;
  const LinkChain post(TimedPath(vadop::makeMotion(Vector3d(std::cos(post_angle), std::sin(post_angle), 0),
                                                   Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero())));
  const vadop::PreparedShape ball(vadop::makeSphere(0.1));
  const vadop::TimeOfImpact hit = vadop::timeOfImpact(ball, arm, ball, post, 0.0, 2.0);
  ASSERT_TRUE(hit.hit);
  // The joint reaches post_angle - 2 asin(0.1) at 1.5 + (that - 0.02) / 6 s.
  const double expected = 1.5 + (post_angle - 2.0 * std::asin(0.1) - 0.02) / 6.0;
  EXPECT_NEAR(hit.time, expected, 2e-6);
  EXPECT_LE(hit.time, expected);
}

// The reference of the World tests: the chain narrow phase on every pair over [0, 2] s, as
// ("a-b", time) in pair order.
std::vector<std::pair<std::string, double>> everyPairsImpact(const std::vector<std::string>& ids,
                                                             const std::vector<vadop::Shape>& shapes,
                                                             const std::vector<LinkChain>& chains) {
  std::vector<std::pair<std::string, double>> out;
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      const vadop::TimeOfImpact hit = vadop::timeOfImpact(vadop::PreparedShape(shapes[i]), chains[i],
                                                    vadop::PreparedShape(shapes[j]), chains[j], 0.0, 2.0);
      if (hit.hit) out.emplace_back(ids[i] + "-" + ids[j], hit.time);
    }
  }
  return out;
}

// Links of chains in a World: predict (every broad phase, and with `only`) reports exactly the
// pairs that the chain narrow phase finds when run on every pair, at the same times.
TEST(LinkChain, WorldFindsEveryPairOfEveryLink) {
  toi_scenes::Rng r(21);
  for (const vadop::BroadPhaseKind kind : {vadop::BroadPhaseKind::kVadop, vadop::BroadPhaseKind::kGrid,
                                           vadop::BroadPhaseKind::kSap, vadop::BroadPhaseKind::kBrute}) {
    vadop::WorldConfig config;
    config.broad_phase = kind;
    vadop::World w(config);
    std::vector<std::string> ids;
    std::vector<vadop::Shape> shapes;
    std::vector<LinkChain> chains;
    std::vector<TChain> tchains;
    for (int i = 0; i < 60; ++i) {
      TChain tc = randomChain(r, i < 12 ? r.integer(1, 6) : 0);
      tc.base.position = r.inBox(1.2);
      if (i >= 12 && r.chance(0.5)) {  // passing near a moving link at some time
        const double tc_time = r.uni(0.1, 1.9);
        const Vector3d target = truthPose(tchains[static_cast<size_t>(r.integer(0, 11))], tc_time).p + r.unit() * r.uni(0.0, 0.5);
        tc.base.position += target - truthPose(tc, tc_time).p;
      }
      tchains.push_back(tc);
      const vadop::Shape s = randomLinkShape(r);
      const std::string id = "body" + std::to_string(i);
      const LinkChain chain = ours(tc);
      w.add(id, s, tc.base);
      if (i < 12 || r.chance(0.2)) w.setChain(id, chain);
      ids.push_back(id);
      shapes.push_back(s);
      chains.push_back(chain);
    }
    const std::vector<vadop::Contact> got = w.predict(0.0, 2.0);
    std::vector<std::pair<std::string, double>> expected = everyPairsImpact(ids, shapes, chains);
    ASSERT_EQ(got.size(), expected.size()) << vadop::toString(kind);
    std::vector<std::pair<std::string, double>> found;
    for (const auto& x : got) found.emplace_back(x.a + "-" + x.b, x.impact.time);
    std::sort(expected.begin(), expected.end());
    std::sort(found.begin(), found.end());
    for (size_t k = 0; k < found.size(); ++k) {
      EXPECT_EQ(found[k].first, expected[k].first) << vadop::toString(kind);
      EXPECT_NEAR(found[k].second, expected[k].second, vadop::testing_compare::kContactTime);
    }
    EXPECT_GE(got.size(), 5u);
    // The same pairs of each moving link through the single-body queries.
    size_t linked = 0;
    for (size_t i = 0; i < 12; ++i) {
      const auto one = w.predict(0.0, 2.0, {ids[i]});
      size_t with = 0;
      for (const auto& x : got) with += (x.a == ids[i] || x.b == ids[i]);
      EXPECT_EQ(one.size(), with) << vadop::toString(kind) << " " << ids[i];
      linked += with;
    }
    EXPECT_GE(linked, 3u);
  }
}

// 160 links spread over 10 x 10 x 2 m, 3 times the scenes' base speeds: 100 of chains of 1 to 4
// joints, 60 rigid, of which about 36 meet a moving link at some time.
struct ArmFleet {
  std::vector<std::string> ids;
  std::vector<vadop::Shape> shapes;
  std::vector<LinkChain> chains;
  std::vector<TChain> truth;
};

ArmFleet spreadArmFleet(toi_scenes::Rng& r) {
  ArmFleet f;
  for (int i = 0; i < 160; ++i) {
    TChain tc = randomChain(r, i < 100 ? r.integer(1, 4) : 0);
    tc.base.position = Vector3d(r.uni(-5.0, 5.0), r.uni(-5.0, 5.0), r.uni(-1.0, 1.0));
    tc.base.linear_velocity *= 3.0;
    if (i >= 100 && r.chance(0.6)) {
      const double at = r.uni(0.1, 1.9);
      const Vector3d target = truthPose(f.truth[static_cast<size_t>(r.integer(0, 99))], at).p + r.unit() * r.uni(0.0, 0.5);
      tc.base.position += target - truthPose(tc, at).p;
    }
    f.truth.push_back(tc);
    f.ids.push_back("link" + std::to_string(i));
    f.shapes.push_back(randomLinkShape(r));
    f.chains.push_back(ours(tc));
  }
  return f;
}

// A fleet of arms spread out (every body a path body: 100 links of moving chains and 60 rigid
// ones, in a 10 m x 10 m x 2 m space): predict reports exactly what the chain narrow phase finds
// on every pair, while the candidates are a small share of the pairs (the path bodies' boxes
// prune them); firstContactIf of a mover, with and without reachable(), finds the earliest
// contact among every body.
TEST(LinkChain, AFleetOfArmsIsPrunedAndNoPairIsMissed) {
  toi_scenes::Rng r(33);
  const ArmFleet fleet = spreadArmFleet(r);
  const std::vector<std::string>& ids = fleet.ids;
  const std::vector<vadop::Shape>& shapes = fleet.shapes;
  const std::vector<LinkChain>& chains = fleet.chains;
  const std::vector<TChain>& tchains = fleet.truth;
  std::vector<std::pair<std::string, double>> expected = everyPairsImpact(ids, shapes, chains);
  std::sort(expected.begin(), expected.end());
  const size_t all_pairs = ids.size() * (ids.size() - 1) / 2;
  for (const vadop::BroadPhaseKind kind : {vadop::BroadPhaseKind::kVadop, vadop::BroadPhaseKind::kBrute}) {
    vadop::WorldConfig config;
    config.broad_phase = kind;
    vadop::World w(config);
    for (size_t i = 0; i < ids.size(); ++i) {
      w.add(ids[i], shapes[i], tchains[i].base);
      w.setChain(ids[i], chains[i]);
    }
    // Twice: the first predict finds the world crowded (more pairs than bodies), so the second
    // takes the path bodies' boxes from the unions of their part boxes.
    std::vector<vadop::Contact> got;
    for (int pass = 0; pass < 2; ++pass) {
      got = w.predict(0.0, 2.0);
      std::vector<std::pair<std::string, double>> found;
      for (const auto& x : got) found.emplace_back(x.a + "-" + x.b, x.impact.time);
      std::sort(found.begin(), found.end());
      ASSERT_EQ(found.size(), expected.size()) << vadop::toString(kind) << " pass " << pass;
      for (size_t k = 0; k < found.size(); ++k) {
        EXPECT_EQ(found[k].first, expected[k].first) << vadop::toString(kind) << " pass " << pass;
        EXPECT_NEAR(found[k].second, expected[k].second, vadop::testing_compare::kContactTime);
      }
      EXPECT_LT(w.lastCandidateCount(), all_pairs / 5) << vadop::toString(kind);
      std::printf("%s, pass %d: %zu impacts, %zu candidates of %zu pairs\n", vadop::toString(kind), pass, got.size(),
                  w.lastCandidateCount(), all_pairs);
    }

    // A sphere sent at a moving link's position at t = 1 from up to 1 m away (a body with one
    // Motion among them).
    const vadop::Shape ball = vadop::makeSphere(0.2);
    w.add("mover", ball, vadop::Motion());
    int contacts = 0;
    for (int trial = 0; trial < 30; ++trial) {
      const TChain& target = tchains[static_cast<size_t>(trial * 3)];
      vadop::Motion m;
      m.position = truthPose(target, 1.0).p + r.unit() * r.uni(0.3, 1.0);
      m.linear_velocity = truthPose(target, 1.0).p - m.position;
      w.setMotion("mover", m);
      double best = 1e9;
      const LinkChain mover_chain{vadop::TimedPath(m)};
      for (size_t i = 0; i < ids.size(); ++i) {
        const vadop::TimeOfImpact hit =
            vadop::timeOfImpact(vadop::PreparedShape(ball), mover_chain, vadop::PreparedShape(shapes[i]), chains[i], 0.0, 2.0);
        if (!hit.hit) continue;
        if (hit.initially_touching &&
            (m.velocityOfPoint(hit.point, 0.0) - chains[i].velocityOfPoint(hit.point, 0.0)).dot(hit.normal) <= 0.0) {
          continue;
        }
        best = std::min(best, hit.time);
      }
      const auto direct = w.firstContactIf({"mover"}, {m}, 0.0, 2.0);
      const double reach = m.linear_velocity.norm() * 2.0;
      const vadop::World::Reachable among = w.reachable({"mover"}, {m.position}, {reach}, 0.0, 2.0);
      const auto via = w.firstContactIf({"mover"}, {m}, 0.0, 2.0, {}, &among);
      ASSERT_EQ(direct.has_value(), best < 1e9) << vadop::toString(kind) << " trial " << trial;
      ASSERT_EQ(via.has_value(), best < 1e9) << vadop::toString(kind) << " trial " << trial;
      if (best < 1e9) {
        EXPECT_NEAR(direct->impact.time, best, 1e-6);
        EXPECT_NEAR(via->impact.time, best, 1e-6);
        ++contacts;
      }
      EXPECT_LT(among.ids.size(), ids.size() / 2) << "reachable() prunes the path bodies";
    }
    EXPECT_GE(contacts, 10) << vadop::toString(kind);
  }
  EXPECT_GE(expected.size(), 20u);  // not vacuous: links meet links
}

// setChain by handle shares the caller's chain (no copy) and predicts what setChain by name
// does; a null chain or a stale handle is refused naming what was wrong, the body unchanged.
TEST(LinkChain, SetChainByHandleSharesTheChainAndRefusesBadInput) {
  toi_scenes::Rng r(41);
  const ArmFleet fleet = spreadArmFleet(r);
  vadop::World by_name, by_handle;
  std::vector<std::shared_ptr<const LinkChain>> shared;
  for (size_t i = 0; i < fleet.ids.size(); ++i) {
    for (vadop::World* w : {&by_name, &by_handle}) w->add(fleet.ids[i], fleet.shapes[i], fleet.truth[i].base);
    by_name.setChain(fleet.ids[i], fleet.chains[i]);
    shared.push_back(std::make_shared<const LinkChain>(fleet.chains[i]));
    by_handle.setChain(by_handle.handle(fleet.ids[i]), shared.back());
    EXPECT_EQ(by_handle.chain(fleet.ids[i]), shared.back().get());
  }
  EXPECT_EQ(vadop::impactsToJsonLines(by_handle.predict(0.0, 2.0)), vadop::impactsToJsonLines(by_name.predict(0.0, 2.0)));
  const vadop::World::Handle h = by_handle.handle(fleet.ids[0]);
  try {
    by_handle.setChain(h, nullptr);
    ADD_FAILURE() << "a null chain was taken";
  } catch (const vadop::InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("\"" + fleet.ids[0] + "\": no chain"), std::string::npos) << e.what();
  }
  EXPECT_EQ(by_handle.chain(fleet.ids[0]), shared[0].get());
  by_handle.remove(fleet.ids[0]);
  by_handle.add(fleet.ids[0], fleet.shapes[0], fleet.truth[0].base);
  EXPECT_THROW(by_handle.setChain(h, shared[0]), vadop::InvalidArgument);  // the body was removed since
  EXPECT_EQ(by_handle.chain(fleet.ids[0]), nullptr);
}

// Random links of chains of `joints` joints against the truth; on_path: their bases on timed
// paths (a mobile manipulator following its plan while its arm moves).
void matchesCertifiedTruth(int joints, bool on_path) {
  const int cases = caseCount();
  toi_scenes::Rng r((on_path ? 200 : 100) + joints);
  int contact = 0, graze = 0, clear = 0, unknown = 0, miss = 0, false_contact = 0, late = 0, time_fail = 0;
  int undecided = 0, timed = 0;
  double max_err = 0.0, chain_s = 0.0, twist_s = 0.0;
  long iterations = 0;
  std::vector<std::string> failures;
  for (int c = 0; c < cases; ++c) {
    const Case k = randomCase(r, joints, on_path);
    const double t0 = 0.0, t1 = 2.0;
    ChainTruth truth(k.sa, k.a, k.sb, k.b, t0, t1);
    const Answer v = classify(truth, t0, t1);
    const vadop::PreparedShape pa(k.sa), pb(k.sb);
    const LinkChain ca = ours(k.a), cb = ours(k.b);
    double t = cpuSeconds();
    const vadop::TimeOfImpact got = vadop::timeOfImpact(pa, ca, pb, cb, t0, t1);
    chain_s += cpuSeconds() - t;
    iterations += got.iterations;
    // The constant-twist call on the same shapes: each link frozen on its base's twist at t0.
    auto frozen = [&](const LinkChain& ch, const TChain& tc) {
      const Isometry3d x = ch.poseAt(t0);
      const vadop::Motion& base = truthBase(tc, t0);
      return vadop::makeMotion(x.translation(), Quaterniond(x.linear()), base.linear_velocity, base.angular_velocity,
                               t0);
    };
    t = cpuSeconds();
    (void)vadop::timeOfImpact(pa, frozen(ca, k.a), pb, frozen(cb, k.b), t0, t1);
    twist_s += cpuSeconds() - t;
    const std::string tag = "case " + std::to_string(c);
    if (got.undecided) ++undecided, failures.push_back(tag + " undecided");
    if (got.hit && truth.at(got.time).lo > kTol + 1e-9) {
      ++false_contact;
      failures.push_back(tag + " hit where the gap is " + std::to_string(truth.at(got.time).lo));
    }
    switch (v.verdict) {
      case Verdict::kUnknown: ++unknown; break;
      case Verdict::kClear:
        ++clear;
        if (got.hit) ++false_contact, failures.push_back(tag + " false contact at " + std::to_string(got.time));
        break;
      case Verdict::kGraze: ++graze; break;
      case Verdict::kContact: {
        ++contact;
        if (!got.hit) {
          ++miss;
          failures.push_back(tag + " missed contact at " + std::to_string(v.t_star));
          break;
        }
        if (got.time > v.t_star + kEps) ++late, failures.push_back(tag + " late");
        if (!v.initial && v.closing >= 0.05 && v.t_tol >= v.t_star - 1e-4) {
          ++timed;
          const double err = std::abs(got.time - v.t_star);
          max_err = std::max(max_err, err);
          if (err > 1e-4) ++time_fail, failures.push_back(tag + " time error " + std::to_string(err));
        }
        break;
      }
    }
  }
  std::printf("[chain of %d joints%s] cases %d: contact %d graze %d clear %d truth-undecided %d | missed %d false %d "
              "late %d time>1e-4 %d undecided %d | timed %d max |dt| %.2e s | us/pair: chain %.1f (%.0f "
              "distance calls), constant twist %.1f\n",
              joints, on_path ? ", base on a path" : "", cases, contact, graze, clear, unknown, miss, false_contact,
              late, time_fail, undecided, timed, max_err, 1e6 * chain_s / cases,
              static_cast<double>(iterations) / cases, 1e6 * twist_s / cases);
  for (size_t i = 0; i < failures.size() && i < 10; ++i) std::printf("  %s\n", failures[i].c_str());
  EXPECT_EQ(miss, 0);
  EXPECT_EQ(false_contact, 0);
  EXPECT_EQ(late, 0);
  EXPECT_EQ(time_fail, 0);
  EXPECT_EQ(undecided, 0);
  EXPECT_LE(unknown, cases / 50);
  // Not vacuous: both verdicts are well represented, and times are checked.
  EXPECT_GE(contact, cases / 5);
  EXPECT_GE(clear, cases / 10);
  EXPECT_GE(timed, cases / 10);
}

class ChainTruthTest : public testing::TestWithParam<int> {};
TEST_P(ChainTruthTest, MatchesCertifiedTruth) { matchesCertifiedTruth(GetParam(), false); }
INSTANTIATE_TEST_SUITE_P(Joints, ChainTruthTest, testing::Values(2, 3, 4, 5, 6),
                         [](const testing::TestParamInfo<int>& i) { return std::to_string(i.param); });

class ChainOnPathTruthTest : public testing::TestWithParam<int> {};
TEST_P(ChainOnPathTruthTest, MatchesCertifiedTruth) { matchesCertifiedTruth(GetParam(), true); }
INSTANTIATE_TEST_SUITE_P(Joints, ChainOnPathTruthTest, testing::Values(2, 4, 6),
                         [](const testing::TestParamInfo<int>& i) { return std::to_string(i.param); });

}  // namespace
