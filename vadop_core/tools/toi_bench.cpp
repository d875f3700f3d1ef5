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

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 200;
  const std::string filter = argc > 2 ? argv[2] : "";
  const ShapeType types[] = {ShapeType::kSphere, ShapeType::kBox, ShapeType::kCapsule,
                             ShapeType::kCylinder, ShapeType::kConvex, ShapeType::kMesh};
  const char* method_names[] = {"fcl-naive10", "fcl-CA-libccd", "fcl-CA-indep", "vadop"};
  constexpr int kMethods = 4;
  std::printf("Continuous collision, %d scenes per pair type and motion (thread CPU time per pair)\n", n);
  std::printf("%-18s %-8s %-14s %9s %9s %9s %9s %12s %8s\n", "pair", "motion", "method", "contacts", "missed",
              "false", "late", "us/pair", "crashed");
  Tally total[2][kMethods];
  // FCL static distance accuracy against the truth (separated configurations only).
  struct DistErr {
    int samples = 0, over_half_tol = 0, over_tol = 0;
    double max_err = 0.0;
  } dist_err[2];
  for (bool rot : {false, true}) {
    for (int ia = 0; ia < 6; ++ia) {
      for (int ib = ia; ib < 6; ++ib) {
        const std::string pair = std::string(vadop::toString(types[ia])) + "-" + vadop::toString(types[ib]);
        if (!filter.empty() && pair.find(filter) == std::string::npos) continue;
        struct Case {
          toi_truth::Scene sc;
          toi_truth::Answer ans;
          std::shared_ptr<fcl::CollisionGeometryd> ga, gb;
          std::shared_ptr<vadop::PreparedShape> pa, pb;
        };
        std::vector<Case> cases;
        for (int i = 0; i < n; ++i) {
          toi_scenes::Rng rng(0xBE4C0000ULL + static_cast<uint64_t>(ia * 6 + ib) * 100003ULL + (rot ? 7 : 0) +
                              static_cast<uint64_t>(i) * 31ULL);
          toi_scenes::Options opt;
          opt.rotating = rot;
          Case c;
          c.sc = toi_scenes::randomScene(types[ia], types[ib], opt, rng);
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
          // FCL distance accuracy at a few times of the window.
          if (!rot) {
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
          cases.push_back(std::move(c));
        }
        for (int k = 0; k < kMethods; ++k) {
          std::vector<Outcome> outs(cases.size());
          std::vector<char> done(cases.size(), 1);
          auto run = [&](size_t i) {
            const Case& c = cases[i];
            const toi_truth::Scene& sc = c.sc;
            Outcome out;
            if (k < 3) {
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
              out.hit = res.is_collide;
              out.time = sc.t0 + res.time_of_contact * (sc.t1 - sc.t0);
            } else {
              const vadop::TimeOfImpact imp = vadop::timeOfImpact(*c.pa, sc.ma, *c.pb, sc.mb, sc.t0, sc.t1);
              out.hit = imp.hit;
              out.time = imp.time;
            }
            return out;
          };
          double best = 0.0;
          int crashed = 0;
          if (k == 1 || k == 2) {
            for (size_t i = 0; i < cases.size(); ++i) {
              double sec = 0.0;
              if (isolated([&] { return run(i); }, &outs[i], &sec)) {
                best += sec;
              } else {
                done[i] = 0;
                ++crashed;
              }
            }
          } else {
            best = 1e300;
            for (int rep = 0; rep < 3; ++rep) {  // the least of three runs of the batch
              const double c0 = cpuSeconds();
              for (size_t i = 0; i < cases.size(); ++i) outs[i] = run(i);
              best = std::min(best, cpuSeconds() - c0);
            }
          }
          Tally t;
          t.calls = static_cast<int>(cases.size()) - crashed;
          t.crashed = crashed;
          t.us = 1e6 * best;
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
          std::printf("%-18s %-8s %-14s %9d %9d %9d %9d %12.1f %8d\n", pair.c_str(), rot ? "rotating" : "linear",
                      method_names[k], t.contacts, t.miss, t.false_hit, t.late, t.us / std::max(1, t.calls), t.crashed);
          Tally& T2 = total[rot][k];
          T2.contacts += t.contacts;
          T2.miss += t.miss;
          T2.false_hit += t.false_hit;
          T2.late += t.late;
          T2.calls += t.calls;
          T2.crashed += t.crashed;
          T2.us += t.us;
        }
        std::fflush(stdout);
      }
    }
  }
  std::printf("\nTotals (contacts = truth contacts; missed = no hit reported; false = hit where the truth is\n"
              "clear by more than 1e-6 m; late = reported more than 1e-6 s after the first contact;\n"
              "crashed = FCL calls that crashed or ran over 10 s, excluded from the other columns)\n");
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < kMethods; ++k) {
      const Tally& t = total[r][k];
      if (t.calls == 0) continue;
      std::printf("%-18s %-8s %-14s %9d %9d %9d %9d %12.1f %8d\n", "all", r ? "rotating" : "linear", method_names[k],
                  t.contacts, t.miss, t.false_hit, t.late, t.us / std::max(1, t.calls), t.crashed);
    }
  }
  std::printf("\nFCL static distance vs the certified truth (separated by > 1e-6 m):\n");
  const char* solver_names[] = {"GST_LIBCCD", "GST_INDEP"};
  for (int s = 0; s < 2; ++s) {
    const DistErr& de = dist_err[s];
    std::printf("  %-10s samples %6d  max error %.3e m  errors > 0.5e-6: %d  > 1e-6: %d\n", solver_names[s],
                de.samples, de.max_err, de.over_half_tol, de.over_tol);
  }
  return 0;
}
