// Timing and reliability of continuous collision on random pairs: FCL 0.7's
// continuousCollide (default naive mode: 10 samples; conservative advancement with the
// libccd and the "indep" GJK solvers) against vadop::timeOfImpact, every method on the same
// scenes, all compared with the certified ground truth of tests/toi_truth.h.
// Not a test: a plain program. Scenes are those of the ground-truth test without padding
// (FCL has no margins) and with rotations under 3 rad per window (FCL's InterpMotion
// interpolates the relative rotation of the two end poses, which equals our
// constant-angular-velocity motion only below pi).
//
// Build (from the repository root, after building vadop_core in build/):
//   g++ -std=c++17 -O2 -DNDEBUG -I vadop_core/include -I vadop_core/tests -I /usr/include/eigen3 \
//       vadop_core/tools/toi_bench.cpp build/libvadop_core.a -lfcl -lccd -o toi_bench
// Run: ./toi_bench [scenes per pair type and motion, default 200] [pair filter substring]
#include "toi_scenes.h"
#include "toi_truth.h"

#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/time_of_impact.h"

#include <fcl/fcl.h>

#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace {

using Eigen::Vector3d;
using vadop::ShapeType;

vadop::Shape stripMargin(vadop::Shape s) {
  s.bounding_radius -= s.margin;
  s.margin = 0.0;
  return s;
}

// Brute-force hull faces of a small point set (outward triangles), for fcl::Convex.
std::vector<int> hullFaces(const std::vector<Vector3d>& p, int* count) {
  std::vector<int> faces;
  *count = 0;
  const int n = static_cast<int>(p.size());
  double scale = 0.0;
  for (const auto& x : p) scale = std::max(scale, x.norm());
  const double eps = 1e-12 * (1.0 + scale);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        Vector3d nrm = (p[j] - p[i]).cross(p[k] - p[i]);
        if (nrm.norm() < 1e-14) continue;
        nrm.normalize();
        int above = 0, below = 0;
        for (int m = 0; m < n; ++m) {
          const double d = nrm.dot(p[m] - p[i]);
          if (d > eps) ++above;
          if (d < -eps) ++below;
        }
        if (above > 0 && below > 0) continue;
        faces.push_back(3);
        if (above == 0) {
          faces.insert(faces.end(), {i, j, k});
        } else {
          faces.insert(faces.end(), {i, k, j});
        }
        ++*count;
      }
    }
  }
  return faces;
}

std::shared_ptr<fcl::CollisionGeometryd> toFcl(const vadop::Shape& s) {
  switch (s.type) {
    case ShapeType::kSphere: return std::make_shared<fcl::Sphered>(s.radius);
    case ShapeType::kBox: return std::make_shared<fcl::Boxd>(2.0 * s.half_extents);
    case ShapeType::kCapsule: return std::make_shared<fcl::Capsuled>(s.radius, 2.0 * s.half_length);
    case ShapeType::kCylinder: return std::make_shared<fcl::Cylinderd>(s.radius, 2.0 * s.half_length);
    case ShapeType::kConvex: {
      int nf = 0;
      auto faces = std::make_shared<std::vector<int>>(hullFaces(s.points, &nf));
      auto verts = std::make_shared<std::vector<Vector3d>>(s.points);
      return std::make_shared<fcl::Convexd>(verts, nf, faces);
    }
    case ShapeType::kMesh: {
      auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
      std::vector<fcl::Triangle> tris;
      for (const auto& t : s.triangles) tris.emplace_back(t[0], t[1], t[2]);
      m->beginModel();
      m->addSubModel(s.points, tris);
      m->endModel();
      return m;
    }
  }
  return nullptr;
}

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Outcome {
  bool hit = false;
  double time = 0.0;
};

struct Tally {
  int contacts = 0, clears = 0, grazes = 0;
  int miss = 0, false_hit = 0, late = 0, calls = 0, crashed = 0;
  double us = 0.0;
};

// Runs `call` (three times, keeping the least CPU time) in a child process: FCL's
// conservative advancement can crash (stack overflow in its mesh traversal) or loop, so
// each call is isolated and limited to 10 s. Returns false when the child did not finish.
template <class F>
bool isolated(const F& call, Outcome* out, double* seconds) {
  int fd[2];
  if (pipe(fd) != 0) return false;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    alarm(10);
    double best = 1e300;
    Outcome o;
    for (int rep = 0; rep < 3; ++rep) {
      const double c0 = cpuSeconds();
      o = call();
      best = std::min(best, cpuSeconds() - c0);
    }
    const double msg[3] = {o.hit ? 1.0 : 0.0, o.time, best};
    const ssize_t w = write(fd[1], msg, sizeof(msg));
    _exit(w == static_cast<ssize_t>(sizeof(msg)) ? 0 : 1);
  }
  close(fd[1]);
  double msg[3] = {0, 0, 0};
  const ssize_t r = read(fd[0], msg, sizeof(msg));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (r != static_cast<ssize_t>(sizeof(msg)) || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return false;
  out->hit = msg[0] != 0.0;
  out->time = msg[1];
  *seconds = msg[2];
  return true;
}

}  // namespace

namespace {

constexpr int kMethods = 4;
const char* const kMethodNames[kMethods] = {"fcl-naive10", "fcl-CA-libccd", "fcl-CA-indep", "vadop"};

// One random scene with its truth and both libraries' shapes.
struct Case {
  toi_truth::Scene sc;
  toi_truth::Answer ans;
  std::shared_ptr<fcl::CollisionGeometryd> ga, gb;
  std::shared_ptr<vadop::PreparedShape> pa, pb;
};

// FCL static distance accuracy against the truth (separated configurations only).
struct DistErr {
  int samples = 0, over_half_tol = 0, over_tol = 0;
  double max_err = 0.0;
};

// FCL's static distance (both GJK solvers) against the truth at a few times of the window.
void sampleFclDistance(const Case& c, toi_truth::Truth& tr, DistErr dist_err[2]) {
  for (int k = 0; k < 3; ++k) {
    const double t = c.sc.t0 + (c.sc.t1 - c.sc.t0) * (0.25 + 0.25 * k);
    auto e = tr.eval(t);
    if (!(e->lo > 1e-6)) continue;
    for (int solver = 0; solver < 2; ++solver) {
      fcl::DistanceRequestd req(true);
      req.gjk_solver_type = solver == 0 ? fcl::GST_LIBCCD : fcl::GST_INDEP;
      fcl::DistanceResultd res;
      fcl::distance(c.ga.get(), c.sc.ma.poseAt(t), c.gb.get(), c.sc.mb.poseAt(t), req, res);
      const double d = res.min_distance;
      const double err = std::max({e->lo - d, d - e->hi, 0.0});
      DistErr& de = dist_err[solver];
      de.samples++;
      de.max_err = std::max(de.max_err, err);
      if (err > 0.5e-6) de.over_half_tol++;
      if (err > 1e-6) de.over_tol++;
    }
  }
}

// Scene i of the pair (ta, tb): without margins, turning at most 3 rad over the window.
Case makeCase(ShapeType ta, ShapeType tb, int ia, int ib, bool rot, int i, DistErr dist_err[2]) {
  toi_scenes::Rng rng(0xBE4C0000ULL + static_cast<uint64_t>(ia * 6 + ib) * 100003ULL + (rot ? 7 : 0) +
                      static_cast<uint64_t>(i) * 31ULL);
  toi_scenes::Options opt;
  opt.rotating = rot;
  Case c;
  c.sc = toi_scenes::randomScene(ta, tb, opt, rng);
  c.sc.shape_a = stripMargin(c.sc.shape_a);
  c.sc.shape_b = stripMargin(c.sc.shape_b);
  const double T = c.sc.t1 - c.sc.t0;
  for (vadop::Motion* m : {&c.sc.ma, &c.sc.mb}) {
    const double turn = m->angular_velocity.norm() * T;
    if (turn > 3.0) m->angular_velocity *= 3.0 / turn;
  }
  toi_truth::Truth tr(c.sc);
  c.ans = toi_truth::classify(tr, c.sc, 1e-6, 1e-9);
  c.ga = toFcl(c.sc.shape_a);
  c.gb = toFcl(c.sc.shape_b);
  c.pa = std::make_shared<vadop::PreparedShape>(c.sc.shape_a);
  c.pb = std::make_shared<vadop::PreparedShape>(c.sc.shape_b);
  if (!rot) sampleFclDistance(c, tr, dist_err);
  return c;
}

// FCL's continuousCollide on a case: k = 0 naive, 1 conservative advancement with libccd, 2 with indep.
Outcome fclContinuous(const Case& c, int k, bool rot) {
  const toi_truth::Scene& sc = c.sc;
  fcl::ContinuousCollisionRequestd req;
  req.num_max_iterations = 10;
  req.ccd_motion_type = rot ? fcl::CCDM_LINEAR : fcl::CCDM_TRANS;
  req.ccd_solver_type = k == 0 ? fcl::CCDC_NAIVE : fcl::CCDC_CONSERVATIVE_ADVANCEMENT;
  req.gjk_solver_type = k == 2 ? fcl::GST_INDEP : fcl::GST_LIBCCD;
  fcl::ContinuousCollisionResultd res;
  // Motions built explicitly: FCL 0.7's InterpMotion(tf1, tf2), which
  // continuousCollide(transforms...) uses for CCDM_LINEAR, leaves its reference
  // point uninitialised (a screw about a random point); the (R1, T1, R2, T2, O)
  // constructor with O = 0 is our motion (rotation about the body origin).
  const Eigen::Isometry3d a0 = sc.ma.poseAt(sc.t0), a1 = sc.ma.poseAt(sc.t1);
  const Eigen::Isometry3d b0 = sc.mb.poseAt(sc.t0), b1 = sc.mb.poseAt(sc.t1);
  std::unique_ptr<fcl::MotionBased> m1, m2;
  if (rot) {
    m1.reset(new fcl::InterpMotion<double>(a0.linear(), a0.translation(), a1.linear(), a1.translation(),
                                           Vector3d::Zero()));
    m2.reset(new fcl::InterpMotion<double>(b0.linear(), b0.translation(), b1.linear(), b1.translation(),
                                           Vector3d::Zero()));
  } else {
    m1.reset(new fcl::TranslationMotion<double>(a0, a1));
    m2.reset(new fcl::TranslationMotion<double>(b0, b1));
  }
  fcl::continuousCollide(c.ga.get(), m1.get(), c.gb.get(), m2.get(), req, res);
  Outcome out;
  out.hit = res.is_collide;
  out.time = sc.t0 + res.time_of_contact * (sc.t1 - sc.t0);
  return out;
}

Outcome runCase(const Case& c, int k, bool rot) {
  if (k < 3) return fclContinuous(c, k, rot);
  const toi_truth::Scene& sc = c.sc;
  const vadop::TimeOfImpact imp = vadop::timeOfImpact(*c.pa, sc.ma, *c.pb, sc.mb, sc.t0, sc.t1);
  Outcome out;
  out.hit = imp.hit;
  out.time = imp.time;
  return out;
}

// Method k on every case: its outcomes and CPU seconds. FCL's conservative advancement call
// by call in child processes (done[i] = 0 where one crashed); the others the least of three
// runs of the batch.
double timeMethod(const std::vector<Case>& cases, int k, bool rot, std::vector<Outcome>& outs, std::vector<char>& done,
                  int& crashed) {
  double best = 0.0;
  crashed = 0;
  if (k == 1 || k == 2) {
    for (size_t i = 0; i < cases.size(); ++i) {
      double sec = 0.0;
      if (isolated([&] { return runCase(cases[i], k, rot); }, &outs[i], &sec)) {
        best += sec;
      } else {
        done[i] = 0;
        ++crashed;
      }
    }
    return best;
  }
  best = 1e300;
  for (int rep = 0; rep < 3; ++rep) {  // the least of three runs of the batch
    const double c0 = cpuSeconds();
    for (size_t i = 0; i < cases.size(); ++i) outs[i] = runCase(cases[i], k, rot);
    best = std::min(best, cpuSeconds() - c0);
  }
  return best;
}

// The outcomes judged by the truth.
Tally judge(const std::vector<Case>& cases, const std::vector<Outcome>& outs, const std::vector<char>& done) {
  Tally t;
  for (size_t i = 0; i < cases.size(); ++i) {
    if (!done[i]) continue;
    const toi_truth::Answer& ans = cases[i].ans;
    if (ans.verdict == toi_truth::Verdict::kContact) {
      t.contacts++;
      if (!outs[i].hit) t.miss++;
      else if (outs[i].time > ans.t_star + 1e-6) t.late++;
    } else if (ans.verdict == toi_truth::Verdict::kClear) {
      t.clears++;
      if (outs[i].hit) t.false_hit++;
    } else {
      t.grazes++;
    }
  }
  return t;
}

void printRow(const char* pair, bool rot, int k, const Tally& t) {
  std::printf("%-18s %-8s %-14s %9d %9d %9d %9d %12.1f %8d\n", pair, rot ? "rotating" : "linear", kMethodNames[k],
              t.contacts, t.miss, t.false_hit, t.late, t.us / std::max(1, t.calls), t.crashed);
}

void addTo(Tally& sum, const Tally& t) {
  sum.contacts += t.contacts;
  sum.miss += t.miss;
  sum.false_hit += t.false_hit;
  sum.late += t.late;
  sum.calls += t.calls;
  sum.crashed += t.crashed;
  sum.us += t.us;
}

// Every method on n scenes of one pair type and motion: a row each, added to the totals.
void benchPair(const ShapeType types[6], int ia, int ib, bool rot, int n, Tally total[2][kMethods],
               DistErr dist_err[2]) {
  const std::string pair = std::string(vadop::toString(types[ia])) + "-" + vadop::toString(types[ib]);
  std::vector<Case> cases;
  for (int i = 0; i < n; ++i) cases.push_back(makeCase(types[ia], types[ib], ia, ib, rot, i, dist_err));
  for (int k = 0; k < kMethods; ++k) {
    std::vector<Outcome> outs(cases.size());
    std::vector<char> done(cases.size(), 1);
    int crashed = 0;
    const double best = timeMethod(cases, k, rot, outs, done, crashed);
    Tally t = judge(cases, outs, done);
    t.calls = static_cast<int>(cases.size()) - crashed;
    t.crashed = crashed;
    t.us = 1e6 * best;
    printRow(pair.c_str(), rot, k, t);
    addTo(total[rot][k], t);
  }
  std::fflush(stdout);
}

void printSummary(const Tally total[2][kMethods], const DistErr dist_err[2]) {
  std::printf("\nTotals (contacts = truth contacts; missed = no hit reported; false = hit where the truth is\n"
              "clear by more than 1e-6 m; late = reported more than 1e-6 s after the first contact;\n"
              "crashed = FCL calls that crashed or ran over 10 s, excluded from the other columns)\n");
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < kMethods; ++k) {
      const Tally& t = total[r][k];
      if (t.calls == 0) continue;
      printRow("all", r != 0, k, t);
    }
  }
  std::printf("\nFCL static distance vs the certified truth (separated by > 1e-6 m):\n");
  const char* solver_names[] = {"GST_LIBCCD", "GST_INDEP"};
  for (int s = 0; s < 2; ++s) {
    const DistErr& de = dist_err[s];
    std::printf("  %-10s samples %6d  max error %.3e m  errors > 0.5e-6: %d  > 1e-6: %d\n", solver_names[s],
                de.samples, de.max_err, de.over_half_tol, de.over_tol);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 200;
  const std::string filter = argc > 2 ? argv[2] : "";
  const ShapeType types[] = {ShapeType::kSphere, ShapeType::kBox, ShapeType::kCapsule,
                             ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};
  std::printf("Continuous collision, %d scenes per pair type and motion (thread CPU time per pair)\n", n);
  std::printf("%-18s %-8s %-14s %9s %9s %9s %9s %12s %8s\n", "pair", "motion", "method", "contacts", "missed",
              "false", "late", "us/pair", "crashed");
  Tally total[2][kMethods];
  DistErr dist_err[2];
  for (bool rot : {false, true}) {
    for (int ia = 0; ia < 6; ++ia) {
      for (int ib = ia; ib < 6; ++ib) {
        const std::string pair = std::string(vadop::toString(types[ia])) + "-" + vadop::toString(types[ib]);
        if (!filter.empty() && pair.find(filter) == std::string::npos) continue;
        benchPair(types, ia, ib, rot, n, total, dist_err);
      }
    }
  }
  printSummary(total, dist_err);
  return 0;
}
