// Randomised comparison of timeOfImpact against an independent, certified ground truth
// (toi_truth.h: own poses, explicit vertices, cylinder sandwich, brute-force min-norm
// distance, certified time bisection). For every unordered pair of shape types, linear-only
// and rotating motion:
//   - zero missed contacts (truth: the gap reaches 0 in the window; ours: no hit),
//   - zero false contacts (truth: gap > tolerance everywhere; ours: hit),
//   - a hit is never later than the first contact, and the truth's gap at the reported
//     time is <= tolerance (the contract of time_of_impact.h),
//   - |time - t*| <= 1e-4 s where the closing speed at contact is >= 0.05 m/s (unless the
//     gap already came within the tolerance more than 1e-4 s before the contact: a graze
//     within tolerance, which the contract reports as the impact; counted as graze-first),
//   - normal within 3 degrees of the truth's where that is well defined, and the point
//     within tolerance of both surfaces,
//   - never an undecided (budget ran out) answer.
// VADOP_TOI_CASES sets the cases per pair type and motion kind (default 400, 25 under
// AddressSanitizer); the full run in the report used 10000. Costs are thread CPU time.
#include "toi_scenes.h"
#include "toi_truth.h"

#include "vadop/time_of_impact.h"

#include <gtest/gtest.h>

#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace {

using Eigen::Vector3d;
using toi_truth::Verdict;
using vadop::ShapeType;

#if defined(__SANITIZE_ADDRESS__)
constexpr int kDefaultCases = 25;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kDefaultCases = 25;
#else
constexpr int kDefaultCases = 400;
#endif
#else
constexpr int kDefaultCases = 400;
#endif

int caseCount() {
  const char* env = std::getenv("VADOP_TOI_CASES");
  if (env != nullptr && *env != '\0') {
    const int n = std::atoi(env);
    if (n > 0) return n;
  }
  return kDefaultCases;
}

constexpr double kTol = 1e-6;       // ToiOptions default
constexpr double kEps = 1e-9;       // truth time resolution (s)
constexpr double kGapSlack = 1e-9;  // truth vs ours gap comparisons (m)

// Thread CPU time (the machine running the tests may be shared: wall time would count the
// other processes). Includes ~0.3 us of clock overhead per reading.
double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double angleDeg(const Vector3d& a, const Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / M_PI;
}

// Truth gap bounds from a point to a shape (min over pieces), at the scene time of e.
double pointGap(toi_truth::Truth& tr, bool side_a, const toi_truth::Eval& e, const Vector3d& x) {
  toi_truth::Piece pt;
  pt.pts = {Vector3d::Zero()};
  toi_truth::finishPiece(pt);
  toi_truth::Pose P;
  P.p = x;
  const toi_truth::Body& body = side_a ? tr.bodyA() : tr.bodyB();
  const toi_truth::Pose& pose = side_a ? e.pa : e.pb;
  double best = toi_truth::kInf;
  for (const auto& pc : body.pieces) {
    const toi_truth::CoreDist c = toi_truth::coreDistance(pc, pose, pt, P);
    best = std::min(best, c.hi - pc.rounding);
  }
  return best;
}

struct PairParam {
  ShapeType a, b;
  bool rotating;
};

std::string paramName(const testing::TestParamInfo<PairParam>& info) {
  return std::string(vadop::toString(info.param.a)) + "_" + vadop::toString(info.param.b) + "_" +
         (info.param.rotating ? "rotating" : "linear");
}

std::vector<PairParam> allPairs() {
  const ShapeType types[] = {ShapeType::kSphere, ShapeType::kBox, ShapeType::kCapsule,
                             ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};
  std::vector<PairParam> out;
  for (bool rot : {false, true}) {
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) out.push_back({types[i], types[j], rot});
    }
  }
  return out;
}

struct Stats {
  int cases = 0, contact = 0, graze = 0, clear = 0, initial = 0, hits = 0;
  int miss = 0, false_contact = 0, late = 0, early = 0, time_fail = 0, normal_fail = 0, point_fail = 0;
  int undecided = 0, timed = 0, normals = 0, graze_then_contact = 0;
  double max_time_err = 0.0, max_normal_deg = 0.0, max_point_gap = 0.0;
  double ours_us = 0.0;
  long iterations = 0;
  int max_iterations = 0;
  double truth_ms = 0.0;
  double worst_bracket = 0.0;
  uint64_t worst_bracket_seed = 0;
  std::vector<std::string> failures;
};

class ToiGroundTruth : public testing::TestWithParam<PairParam> {};

TEST_P(ToiGroundTruth, MatchesCertifiedTruth) {
  const PairParam prm = GetParam();
  const int n = caseCount();
  Stats st;
  toi_scenes::Options opt;
  opt.rotating = prm.rotating;
  opt.tolerance = kTol;
  const uint64_t base = (static_cast<uint64_t>(prm.a) * 16 + static_cast<uint64_t>(prm.b)) * 2 + (prm.rotating ? 1 : 0);
  for (int i = 0; i < n; ++i) {
    const uint64_t seed = base * 1000003ULL + static_cast<uint64_t>(i);
    toi_scenes::Rng rng(seed);
    const toi_truth::Scene sc = toi_scenes::randomScene(prm.a, prm.b, opt, rng);

    const double c0 = cpuSeconds();
    const vadop::TimeOfImpact imp = vadop::timeOfImpact(sc.shape_a, sc.ma, sc.shape_b, sc.mb, sc.t0, sc.t1);
    const double c1 = cpuSeconds();
    toi_truth::Truth tr(sc);
    const toi_truth::Answer ans = toi_truth::classify(tr, sc, kTol, kEps);
    const double c2 = cpuSeconds();

    st.cases++;
    st.ours_us += 1e6 * (c1 - c0);
    st.truth_ms += 1e3 * (c2 - c1);
    st.iterations += imp.iterations;
    st.max_iterations = std::max(st.max_iterations, imp.iterations);
    if (imp.hit) st.hits++;
    std::ostringstream why;
    auto fail = [&](const char* kind, int* counter) {
      ++*counter;
      if (st.failures.size() < 12) {
        std::ostringstream os;
        os.precision(12);
        os << kind << " seed=" << seed << " verdict=" << static_cast<int>(ans.verdict) << " t*=" << ans.t_star
           << " t_tol=" << ans.t_tol << " closing=" << ans.closing << " ours(hit=" << imp.hit << " t=" << imp.time
           << " it=" << imp.iterations << " init=" << imp.initially_touching << ") " << why.str();
        st.failures.push_back(os.str());
      }
    };
    if (imp.undecided) fail("UNDECIDED", &st.undecided);

    switch (ans.verdict) {
      case Verdict::kClear:
        st.clear++;
        if (imp.hit) fail("FALSE_CONTACT", &st.false_contact);
        break;
      case Verdict::kGraze:
        st.graze++;
        break;
      case Verdict::kContact:
        st.contact++;
        if (ans.initial) st.initial++;
        if (!imp.hit) {
          fail("MISS", &st.miss);
          break;
        }
        if (ans.initial) {
          if (!(imp.initially_touching && imp.time == sc.t0)) fail("LATE(initial)", &st.late);
          break;
        }
        if (imp.time > ans.t_star + kEps + 1e-12) fail("LATE", &st.late);
        if (ans.t_star - ans.t_tol > 1e-4) {
          // The gap came within the tolerance well before the contact (a graze within
          // tolerance, then the contact): by the contract that graze is the impact, so the
          // time bound does not apply; LATE above and EARLY below still do.
          st.graze_then_contact++;
        } else if (ans.closing >= 0.05) {
          const double err = std::abs(imp.time - ans.t_star);
          st.timed++;
          st.max_time_err = std::max(st.max_time_err, err);
          if (err > 1e-4) fail("TIME_ERROR", &st.time_fail);
        }
        break;
    }
    if (imp.hit && !(ans.verdict == Verdict::kContact && ans.initial)) {
      // The reported time: the truth's gap there must be <= tol (not too early).
      auto e = tr.eval(imp.time);
      if (e->lo > kTol + kGapSlack) {
        why << "gap_at_time=" << e->lo;
        fail("EARLY", &st.early);
      }
      // Normal and point where the truth's gap is positive and its direction stable.
      if (e->lo > 1e-8 && e->best >= 0) {
        const Vector3d nt = e->rec[e->best].n;
        auto e2 = tr.eval(std::max(sc.t0, imp.time - 1e-5));
        const bool stable = e2->best >= 0 && e2->lo > 1e-8 && angleDeg(nt, e2->rec[e2->best].n) < 1.0;
        if (stable) {
          const double ang = angleDeg(imp.normal, nt);
          st.normals++;
          st.max_normal_deg = std::max(st.max_normal_deg, ang);
          if (ang > 3.0) {
            why << "normal " << imp.normal.transpose() << " truth " << nt.transpose() << " (" << ang << " deg)";
            fail("NORMAL", &st.normal_fail);
          }
        }
        const double ga = pointGap(tr, true, *e, imp.point), gb = pointGap(tr, false, *e, imp.point);
        const double g = std::max(ga, gb);
        st.max_point_gap = std::max(st.max_point_gap, g);
        if (g > kTol + 1e-7) {
          why << "point gaps " << ga << " " << gb;
          fail("POINT", &st.point_fail);
        }
      }
    }
    if (tr.worstBracket() > st.worst_bracket) {
      st.worst_bracket = tr.worstBracket();
      st.worst_bracket_seed = seed;
    }
  }
  std::printf(
      "[toi-gt] %-9s %-9s %-8s cases %5d | contact %5d (initial %4d) graze %4d clear %5d | ours hits %5d | "
      "miss %d false %d late %d early %d undecided %d | time-checked %5d max|dt| %.2e s (fail %d, graze-first %d) | normals %5d "
      "max %.3f deg (fail %d) | point max %.1e (fail %d) | ours %.1f us/pair, iters mean %.1f max %d | truth %.1f "
      "ms/case, bracket %.1e\n",
      vadop::toString(prm.a), vadop::toString(prm.b), prm.rotating ? "rotating" : "linear", st.cases, st.contact,
      st.initial, st.graze, st.clear, st.hits, st.miss, st.false_contact, st.late, st.early, st.undecided, st.timed,
      st.max_time_err, st.time_fail, st.graze_then_contact, st.normals, st.max_normal_deg, st.normal_fail, st.max_point_gap, st.point_fail,
      st.ours_us / st.cases, static_cast<double>(st.iterations) / st.cases, st.max_iterations, st.truth_ms / st.cases,
      st.worst_bracket);
  std::fflush(stdout);
  for (const auto& f : st.failures) ADD_FAILURE() << f;
  EXPECT_EQ(st.miss, 0);
  EXPECT_EQ(st.false_contact, 0);
  EXPECT_EQ(st.late, 0);
  EXPECT_EQ(st.early, 0);
  EXPECT_EQ(st.time_fail, 0);
  EXPECT_EQ(st.normal_fail, 0);
  EXPECT_EQ(st.point_fail, 0);
  EXPECT_EQ(st.undecided, 0);
  EXPECT_LE(st.worst_bracket, 5e-8) << "the truth could not certify its distances tightly (seed "
                                     << st.worst_bracket_seed << ")";
  // The scenes must exercise both outcomes.
  if (n >= 50) {
    EXPECT_GT(st.contact, n / 10);
    EXPECT_GT(st.clear, n / 10);
  }
}

INSTANTIATE_TEST_SUITE_P(AllPairs, ToiGroundTruth, testing::ValuesIn(allPairs()), paramName);

// ---------------------------------------------------------------------------------------
// The truth checked on its own, against closed forms and against sampled point pairs.

toi_truth::Pose at(const Vector3d& p, const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  toi_truth::Pose P;
  P.R = q.toRotationMatrix();
  P.p = p;
  return P;
}

double truthGap(const vadop::Shape& a, const toi_truth::Pose& pa, const vadop::Shape& b, const toi_truth::Pose& pb,
                double* lo = nullptr) {
  const toi_truth::Body A = toi_truth::makeBody(a), B = toi_truth::makeBody(b);
  double hi = toi_truth::kInf, l = toi_truth::kInf;
  for (const auto& x : A.pieces) {
    for (const auto& y : B.pieces) {
      const toi_truth::CoreDist c = toi_truth::coreDistance(x, pa, y, pb);
      hi = std::min(hi, c.hi - x.rounding - y.rounding);
      l = std::min(l, c.lo - x.rounding - y.rounding);
    }
  }
  if (lo) *lo = l;
  return hi;
}

TEST(ToiTruthSelfCheck, ClosedFormDistances) {
  using vadop::makeBox;
  using vadop::makeCapsule;
  using vadop::makeCylinder;
  using vadop::makeSphere;
  double lo = 0.0;
  // Point to box by clamping.
  const Vector3d half(0.3, 0.5, 0.7), c(1.0, -0.2, 2.0);
  const Vector3d clamped = c.cwiseMax(-half).cwiseMin(half);
  EXPECT_NEAR(truthGap(makeBox(2 * half), at(Vector3d::Zero()), makeSphere(0.1), at(c), &lo), (c - clamped).norm() - 0.1,
              1e-12);
  EXPECT_NEAR(lo, (c - clamped).norm() - 0.1, 1e-12);
  // Axis-aligned boxes: per-axis gaps.
  const Vector3d hb(0.2, 0.1, 0.4), off(0.9, 0.5, -0.3);
  const Vector3d gaps = (off.cwiseAbs() - half - hb).cwiseMax(0.0);
  EXPECT_NEAR(truthGap(makeBox(2 * half), at(Vector3d::Zero()), makeBox(2 * hb), at(off), &lo), gaps.norm(), 1e-12);
  EXPECT_NEAR(lo, gaps.norm(), 1e-12);
  // Cylinder to a point: radial and axial clamps (r 0.5, half height 0.4).
  for (const Vector3d& p : {Vector3d(1.0, 0.6, 0.1), Vector3d(0.1, 0.2, 1.5), Vector3d(0.8, -0.9, -1.1)}) {
    const double rad = std::hypot(p.x(), p.y());
    const double dr = std::max(0.0, rad - 0.5), dz = std::max(0.0, std::abs(p.z()) - 0.4);
    EXPECT_NEAR(truthGap(makeCylinder(0.5, 0.8), at(Vector3d::Zero()), makeSphere(0.05), at(p), &lo),
                std::hypot(dr, dz) - 0.05, 1e-10);
    EXPECT_NEAR(lo, std::hypot(dr, dz) - 0.05, 1e-10);
  }
  // Two coaxial cylinders stacked (gap along the axis) and side by side (radial gap).
  EXPECT_NEAR(truthGap(makeCylinder(0.5, 0.8), at(Vector3d::Zero()), makeCylinder(0.3, 0.2), at(Vector3d(0.1, 0, 0.7))),
              0.2, 1e-10);
  EXPECT_NEAR(truthGap(makeCylinder(0.5, 0.8), at(Vector3d::Zero()), makeCylinder(0.3, 0.2), at(Vector3d(1.0, 0, 0.1))),
              0.2, 1e-10);
  // Skew capsules: segments along x at z = 0 and along y at z = 0.5.
  const Eigen::Quaterniond qx(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitY()));
  const Eigen::Quaterniond qy(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()));
  EXPECT_NEAR(truthGap(makeCapsule(0.1, 2.0), at(Vector3d::Zero(), qx), makeCapsule(0.05, 2.0), at(Vector3d(0.2, 0.3, 0.5), qy)),
              0.35, 1e-12);
  // Overlap is detected: the realised points coincide (up to rounding), the lower bound is 0.
  EXPECT_LE(truthGap(makeBox(Vector3d(1, 1, 1)), at(Vector3d::Zero()), makeBox(Vector3d(1, 1, 1)), at(Vector3d(0.5, 0.2, 0)), &lo),
            1e-15);
  EXPECT_EQ(lo, 0.0);
}

// Random static configurations: the certified lower bound never exceeds the distance of any
// pair of sampled points of the two shapes, and the bracket is tight.
TEST(ToiTruthSelfCheck, BoundsAgainstSampledPoints) {
  toi_scenes::Rng r(4242);
  const ShapeType types[] = {ShapeType::kSphere, ShapeType::kBox, ShapeType::kCapsule,
                             ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};
  auto sample = [&](const toi_truth::Body& body, const toi_truth::Pose& P) {
    const toi_truth::Piece& pc = body.pieces[r.integer(0, static_cast<int>(body.pieces.size()) - 1)];
    Vector3d x;
    if (pc.cylinder) {
      const double rr = pc.cyl_r * std::sqrt(r.uni(0, 1)), ph = r.uni(0, 2 * M_PI);
      x = Vector3d(rr * std::cos(ph), rr * std::sin(ph), r.uni(-pc.cyl_h, pc.cyl_h));
    } else {
      std::vector<double> w(pc.pts.size());
      double s = 0;
      for (auto& v : w) s += (v = -std::log(r.uni(1e-12, 1.0)));
      x = Vector3d::Zero();
      for (size_t i = 0; i < w.size(); ++i) x += (w[i] / s) * pc.pts[i];
    }
    x += pc.rounding * std::cbrt(r.uni(0, 1)) * r.unit();
    return Vector3d(P.R * x + P.p);
  };
  for (ShapeType ta : types) {
    for (ShapeType tb : types) {
      for (int k = 0; k < 30; ++k) {
        const vadop::Shape a = toi_scenes::randomShape(ta, r), b = toi_scenes::randomShape(tb, r);
        const toi_truth::Pose pa = at(r.inBox(0.3), r.quat());
        const toi_truth::Pose pb = at(r.inBox(0.3) + r.unit() * r.uni(0.0, 1.5), r.quat());
        double lo = 0.0;
        const double hi = truthGap(a, pa, b, pb, &lo);
        EXPECT_LE(lo, hi + 1e-15);
        if (hi > 0) {
          EXPECT_LE(hi - lo, 1e-9) << vadop::toString(ta) << "-" << vadop::toString(tb);
        }
        const toi_truth::Body A = toi_truth::makeBody(a), B = toi_truth::makeBody(b);
        double sampled = toi_truth::kInf;
        for (int s = 0; s < 400; ++s) sampled = std::min(sampled, (sample(A, pa) - sample(B, pb)).norm());
        // Sampled points lie in the padded shapes: their distance bounds the gap from above.
        EXPECT_LE(std::max(lo, 0.0), sampled + 1e-12) << vadop::toString(ta) << "-" << vadop::toString(tb);
      }
    }
  }
}

TEST(ToiTruthSelfCheck, TimeSearchFindsAnalyticContact) {
  // Head-on spheres: t* = 2.25 (see the analytic test); a sphere just missing: no contact.
  toi_truth::Scene sc;
  sc.shape_a = vadop::makeSphere(0.5);
  sc.shape_b = vadop::makeSphere(0.25);
  sc.ma = vadop::makeMotion(Vector3d::Zero(), Eigen::Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero());
  sc.mb = vadop::makeMotion(Vector3d(3, 0, 0), Eigen::Quaterniond::Identity(), Vector3d(-1, 0, 0), Vector3d(0, 3, 1));
  sc.t0 = 0.0;
  sc.t1 = 5.0;
  toi_truth::Truth tr(sc);
  toi_truth::Answer ans = toi_truth::classify(tr, sc, kTol, kEps);
  EXPECT_EQ(ans.verdict, Verdict::kContact);
  EXPECT_NEAR(ans.t_star, 2.25, 2e-9);
  EXPECT_NEAR(ans.t_tol, 2.25 - kTol, 2e-9);
  EXPECT_NEAR(ans.closing, 1.0, 1e-6);
  sc.mb.position.y() = 0.75 + 2e-6;  // passes 2e-6 clear: clear of the tolerance
  toi_truth::Truth tr2(sc);
  EXPECT_EQ(toi_truth::classify(tr2, sc, kTol, kEps).verdict, Verdict::kClear);
  sc.mb.position.y() = 0.75 + 0.5e-6;  // within the tolerance but not touching
  toi_truth::Truth tr3(sc);
  EXPECT_EQ(toi_truth::classify(tr3, sc, kTol, kEps).verdict, Verdict::kGraze);
  // Spinning bar (the analytic rotating case): t* = acos(0.15 / 0.8) / 2.
  sc.shape_a = vadop::makeBox(Vector3d(2.0, 0.1, 0.1));
  sc.shape_b = vadop::makeSphere(0.1);
  sc.ma = vadop::makeMotion(Vector3d::Zero(), Eigen::Quaterniond::Identity(), Vector3d::Zero(), Vector3d(0, 0, 2));
  sc.mb = vadop::makeMotion(Vector3d(0, 0.8, 0), Eigen::Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero());
  sc.t1 = 2.0;
  toi_truth::Truth tr4(sc);
  ans = toi_truth::classify(tr4, sc, kTol, kEps);
  EXPECT_EQ(ans.verdict, Verdict::kContact);
  EXPECT_NEAR(ans.t_star, std::acos(0.15 / 0.8) / 2.0, 2e-9);
}

}  // namespace
