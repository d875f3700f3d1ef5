// Temporal coherence: maxDisplacement (motion.h) against sampled displacements of material
// points, and a World with WorldConfig::coherence against a plain World on sequences of
// predicts whose motions are re-stated, jittered, drifted and changed between predicts.
#include "vadop/error.h"
#include "vadop/motion.h"
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include "world_scene_gen.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <tuple>
#include <vector>

namespace vadop {
namespace {

using Eigen::Vector3d;

// The test's own placement of a material point (body coordinates p) by a motion, from the
// definition in motion.h: the pivot moves in a straight line, the body turns about it.
Vector3d placeTruth(const Motion& m, const Vector3d& p, double t) {
  const double s = t - m.t_ref;
  const Vector3d w = m.angular_velocity;
  const double angle = w.norm() * s;
  Eigen::Matrix3d spin = Eigen::Matrix3d::Identity();
  if (w.norm() > 0.0) spin = Eigen::AngleAxisd(angle, w.normalized()).toRotationMatrix();
  const Vector3d pivot = m.position + m.pivot_offset + m.linear_velocity * s;
  const Vector3d origin = w.norm() > 0.0 ? Vector3d(pivot - spin * m.pivot_offset) : Vector3d(m.position + m.linear_velocity * s);
  return spin * (m.orientation.toRotationMatrix() * p) + origin;
}

Vector3d unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Vector3d v(g(rng), g(rng), g(rng));
  return v / (v.norm() + 1e-300);
}

// The same trajectory, stated at time t.
Motion restate(const Motion& m, double t) {
  Motion r = m;
  r.t_ref = t;
  r.position = m.positionAt(t);
  r.orientation = m.orientationAt(t);
  r.pivot_offset = m.hasPivot() ? Vector3d(m.pivotAt(t) - r.position) : Vector3d::Zero();
  return r;
}

// m with one of its parts changed by about `a` metres of displacement for a body of radius r
// over a window of length T (kind 0: none, the same trajectory re-stated).
Motion perturb(const Motion& m, int kind, double a, double r, double T, const Vector3d& dir) {
  Motion n = m;
  switch (kind) {
    case 0: break;
    case 1: n.position += a * dir; break;
    case 2: n.linear_velocity += (a / T) * dir; break;
    case 3: n.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(a / r, dir)) * m.orientation; break;
    case 4: n.angular_velocity += (a / (r * T)) * dir; break;
    case 5: n.pivot_offset += a * dir; break;
    default: {  // everything at once
      n.position += 0.3 * a * dir;
      n.linear_velocity += (0.3 * a / T) * dir.cross(Vector3d::UnitZ());
      n.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * a / r, dir.cross(Vector3d::UnitX()).normalized())) *
                      m.orientation;
      n.angular_velocity += (0.3 * a / (r * T)) * dir;
      n.pivot_offset += 0.3 * a * dir.cross(Vector3d::UnitY());
    }
  }
  n.orientation.normalize();
  return n;
}

Motion randomMotion(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  Motion m;
  m.t_ref = 3.0 * u(rng);
  m.position = Vector3d(5 * u(rng), 5 * u(rng), 5 * u(rng));
  m.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng) + 2.0).normalized();
  m.linear_velocity = 2.0 * u01(rng) * unit(rng);
  if (u01(rng) < 0.8) m.angular_velocity = 3.0 * u01(rng) * unit(rng);
  if (u01(rng) < 0.5) m.pivot_offset = 2.0 * u01(rng) * unit(rng);
  return m;
}

// A ground vehicle as the node states odometry: origin velocity v along the heading, turn rate w,
// turning about its screw axis (the centre of its circle).
Motion vehicle(const Vector3d& position, double yaw, double v, double w, double t_ref) {
  Motion m;
  m.t_ref = t_ref;
  m.position = position;
  m.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Vector3d::UnitZ()));
  const Vector3d velocity(v * std::cos(yaw), v * std::sin(yaw), 0.0), turn(0.0, 0.0, w);
  m.linear_velocity = screwPivotVelocity(velocity, turn);
  m.angular_velocity = turn;
  m.pivot_offset = screwPivotOffset(velocity, turn);
  return m;
}

TEST(MaxDisplacement, BoundsEverySampledDisplacement) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  double worst = 0.0, ratio_sum = 0.0;
  int cases = 0;
  for (int c = 0; c < 3000; ++c) {
    Motion m = randomMotion(rng);
    const double r = 0.05 + 1.5 * u01(rng);
    const double t0 = 4.0 * u01(rng) - 2.0, t1 = t0 + 3.0 * u01(rng);
    const int kind = c % 9 == 7 ? 7 + static_cast<int>(rng() % 2) : c % 9;
    const double a = 0.5 * u01(rng);
    Motion n = kind == 8 ? randomMotion(rng) : perturb(restate(m, t0 - 1.0 + 2.0 * u01(rng)), kind, a, r, t1 - t0, unit(rng));
    if (kind == 8 && c % 2 == 0) {  // a vehicle's odometry, then the same with noisy v and w
      const Vector3d at(5 * u01(rng), 5 * u01(rng), 0.0);
      const double yaw = 6 * u01(rng), v = 1.5 * u01(rng), w = (2 * u01(rng) - 1) * (c % 4 == 0 ? 0.05 : 1.0);
      const double noise = 0.05 * u01(rng);
      m = vehicle(at, yaw, v, w, t0);
      n = vehicle(at, yaw, v + noise * (2 * u01(rng) - 1), w + noise * (2 * u01(rng) - 1), t0);
    }
    const double bound = maxDisplacement(m, n, r, t0, t1);
    double truth = 0.0;
    for (int k = 0; k < 8; ++k) {
      const Vector3d p = (k == 0 ? r : r * std::cbrt(u01(rng))) * unit(rng);
      for (int i = 0; i <= 64; ++i) {
        const double t = t0 + (t1 - t0) * i / 64.0;
        truth = std::max(truth, (placeTruth(m, p, t) - placeTruth(n, p, t)).norm());
      }
    }
    ASSERT_LE(truth, bound + 1e-12) << "case " << c << " kind " << kind;
    worst = std::max(worst, truth - bound);
    if (bound > 1e-9) {
      ratio_sum += truth / bound;
      ++cases;
    }
  }
  // How tight: the mean share of the bound that the sampled points reach.
  std::printf("maxDisplacement: %d cases, mean sampled/bound %.3f\n", cases, ratio_sum / cases);
  EXPECT_GT(ratio_sum / cases, 0.3);
}

TEST(MaxDisplacement, ZeroForTheSameTrajectoryStatedElsewhere) {
  std::mt19937_64 rng(3);
  for (int c = 0; c < 500; ++c) {
    const Motion m = randomMotion(rng);
    const Motion n = restate(m, m.t_ref + 1.7);
    EXPECT_LT(maxDisplacement(m, n, 1.0, 0.0, 2.0), 1e-9) << c;
    // Pure translation: exact.
    Motion a;
    a.linear_velocity = Vector3d(1, 0, 0);
    Motion b = a;
    b.linear_velocity = Vector3d(1, 0.5, 0);
    EXPECT_NEAR(maxDisplacement(a, b, 1.0, 0.0, 2.0), 1.0, 1e-9);
  }
}

// A coherent world and a plain one fed the same motions, predict after predict: the impacts
// (pairs, times, points) and undecided pairs must be the same, while most pairs are answered
// by certificates. Motions between predicts: re-stated (the same trajectory), jittered by about
// the budget (random), drifted (the same direction each predict, so that a term missing from
// the displacement bound accumulates into a missed contact), or replaced.
TEST(Coherence, CoherentWorldReportsWhatThePlainWorldReports) {
  const double clearance = 0.1, dt = 1.0 / 30.0;
  size_t reused = 0, candidates = 0, impacts = 0, drifted_reuse = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    testing_scene::GenParams g;
    g.n = 150;
    g.box = 6.0;
    g.max_speed = 1.5;
    g.rotating_fraction = 0.5;
    g.static_fraction = 0.1;
    g.horizon = 1.0;
    const Scene scene = parseScene(testing_scene::randomSceneJson(seed, g));
    std::mt19937_64 rng(seed * 31);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    WorldConfig plain_config;
    plain_config.toi.max_iterations = 400;  // some pairs undecided: they must match too
    // Seed 3 with the time-slice cull (the default): certificates and the cull together. Seeds
    // 1 and 2 without: the cull drops many of the far pairs certificates answer, and the share
    // of pairs answered by certificates is checked on those.
    plain_config.time_slices = seed == 3 ? WorldConfig{}.time_slices : 1;
    const bool counted = plain_config.time_slices == 1;
    WorldConfig coherent_config = plain_config;
    coherent_config.coherence.clearance = clearance;
    coherent_config.coherence.lookahead = 0.4;
    coherent_config.threads = seed == 2 ? 2 : 1;
    World plain(plain_config), coherent(coherent_config);
    std::vector<Motion> motion;
    std::vector<int> kind;
    std::vector<Vector3d> dir;
    for (const SceneBody& b : scene.bodies) {
      Motion m = b.motion;
      if (m.isRotating() && u01(rng) < 0.5) m.pivot_offset = 0.8 * u01(rng) * unit(rng);
      motion.push_back(m);
      plain.add(b.id, b.shape, m);
      coherent.add(b.id, b.shape, m);
      kind.push_back(static_cast<int>(rng() % 8));
      dir.push_back(unit(rng));
    }
    const double budget = clearance - plain_config.toi.tolerance;
    for (int step = 0; step < 45; ++step) {
      const double t0 = step * dt;
      if (step > 0) {
        for (size_t i = 0; i < motion.size(); ++i) {
          const double r = scene.bodies[i].shape.bounding_radius;
          Motion m = restate(motion[i], t0);
          const double x = u01(rng);
          if (kind[i] >= 1 && kind[i] <= 6) {
            // drift: up to half the budget each predict along the body's own direction
            m = perturb(m, kind[i], 0.5 * budget * u01(rng), r, g.horizon, dir[i]);
          } else if (x < 0.05) {
            m.linear_velocity = 1.5 * u01(rng) * unit(rng);  // a new command
          } else if (x < 0.5) {
            m = perturb(m, 7, budget * u01(rng), r, g.horizon, unit(rng));  // jitter
          }
          motion[i] = m;
          plain.setMotion(scene.bodies[i].id, m);
          coherent.setMotion(scene.bodies[i].id, m);
        }
      }
      const std::string expected = impactsToJsonLines(plain.predict(t0, g.horizon)) +
                                   "undecided:\n" + impactsToJsonLines(plain.lastUndecided());
      const std::vector<Contact> got_impacts = coherent.predict(t0, g.horizon);
      const std::string got = impactsToJsonLines(got_impacts) + "undecided:\n" +
                              impactsToJsonLines(coherent.lastUndecided());
      ASSERT_EQ(got, expected) << "seed " << seed << " step " << step;
      EXPECT_EQ(coherent.lastCandidateCount(), plain.lastCandidateCount());
      EXPECT_EQ(plain.lastReusedCount(), 0u);
      impacts += got_impacts.size();
      if (!counted) continue;
      reused += coherent.lastReusedCount();
      candidates += coherent.lastCandidateCount();
      if (step > 0) drifted_reuse += coherent.lastReusedCount();
    }
  }
  std::printf("coherence (seeds 1, 2): %zu candidate pairs, %zu answered by certificates; %zu impacts\n", candidates, reused,
              impacts);
  EXPECT_GT(impacts, 100u);
  // Not a vacuous comparison: many pairs come from certificates despite the changes.
  EXPECT_GT(reused, candidates / 6);
  EXPECT_GT(drifted_reuse, 0u);
}

// A contact beyond the window is certified away only up to the time the wide test found it:
// once the window reaches it, the pair is computed and the contact reported.
TEST(Coherence, CertificateEndsWhereTheWideTestFoundTheContact) {
  WorldConfig c;
  c.coherence.clearance = 0.05;
  c.coherence.lookahead = 1.0;
  World w(c);
  // One box catching up with another: both candidates all along (their swept boxes overlap),
  // the gap of 0.4 m closing at 0.1 m/s: contact at 4 s; horizon 2 s.
  Motion left, right;
  left.position = Vector3d(-1.0, 0, 0);
  left.linear_velocity = Vector3d(1.1, 0, 0);
  right.linear_velocity = Vector3d(1.0, 0, 0);
  w.add("left", makeBox(Vector3d(0.6, 0.6, 0.6)), left);
  w.add("right", makeBox(Vector3d(0.6, 0.6, 0.6)), right);
  size_t reused = 0;
  for (int step = 0; step <= 100; ++step) {
    const double t0 = 0.025 * step;
    const auto out = w.predict(t0, 2.0);
    ASSERT_EQ(w.lastCandidateCount(), 1u) << t0;
    if (t0 + 2.0 < 4.0 - 1e-6) {
      EXPECT_TRUE(out.empty()) << t0;
      reused += w.lastReusedCount();
    } else if (t0 + 2.0 > 4.0 + 1e-6) {
      ASSERT_EQ(out.size(), 1u) << "missed at t0 = " << t0;
      EXPECT_NEAR(out[0].impact.time, 4.0, 1e-5);
      EXPECT_EQ(w.lastReusedCount(), 0u);
    }
  }
  // Certified at t0 = 0 up to 3 s (where the gap reaches the clearance), reused until the
  // window's end gets there (t0 = 1).
  EXPECT_GE(reused, 39u);
}

TEST(Coherence, BadConfigurationIsRefused) {
  for (const auto& [clearance, lookahead] :
       std::vector<std::pair<double, double>>{{-0.1, 0.0}, {NAN, 0.0}, {1e-7, 0.0}, {1e6, 0.0}, {0.1, -1.0},
                                              {0.1, INFINITY}, {0.1, NAN}}) {
    WorldConfig c;
    c.coherence.clearance = clearance;
    c.coherence.lookahead = lookahead;
    EXPECT_THROW(World{c}, InvalidArgument) << clearance << " " << lookahead;
  }
  WorldConfig ok;
  ok.coherence.clearance = 0.1;
  EXPECT_NO_THROW(World{ok});
}

}  // namespace
}  // namespace vadop
