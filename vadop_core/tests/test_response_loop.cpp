// ResponseLoop (response_loop.h): contacts in time order with responses that change motions.
//  - a Newton's cradle, on every engine: the B-C contact exists only after A's response;
//  - random sphere scenes with elastic responses against an independent brute-force event loop
//    (every pair re-tested after every response): the same contacts, in the same order, at the
//    same times, and the same final motions;
//  - the same with walls (ResponseLoop::setBoundary) interleaving with the pairs;
//  - callbacks that change bodies not in the contact, a throwing callback, bad input.
#include "response_loop.h"  // the bench's loop (vadop_core/bench, library vadop_response_loop)
#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/error.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace vadop {
namespace {

Motion moving(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t_ref = 0.0) {
  return makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero(), t_ref);
}

std::vector<std::unique_ptr<BroadPhase>> engines() {
  std::vector<std::unique_ptr<BroadPhase>> e;
  e.push_back(std::make_unique<BruteForceBroadPhase>());
  e.push_back(SweepPruneBroadPhase::makeEveryAxis(3));
  e.push_back(std::make_unique<SweepPruneBroadPhase>(VadopConfig{}));
  e.push_back(std::make_unique<VadopGridBroadPhase>(VadopConfig{}));
  e.push_back(VadopGridBroadPhase::makeBoxOnly());
  return e;
}

// Equal masses, elastic: exchange the velocity components along the normal when approaching.
// Returns the new motions of a and b from time t.
// Reflection at a wall of normal n (from the body into the wall), from time t.
Motion reflect(const Motion& m, const Eigen::Vector3d& n, double t) {
  const Eigen::Vector3d v = m.linear_velocity;
  return moving(m.positionAt(t), v - 2.0 * v.dot(n) * n, t);
}

std::pair<Motion, Motion> elastic(const Motion& ma, const Motion& mb, const Eigen::Vector3d& n, double t) {
  const Eigen::Vector3d va = ma.linear_velocity, vb = mb.linear_velocity;
  const double closing = (va - vb).dot(n);
  if (closing <= 0.0) return {ma, mb};
  const Eigen::Vector3d dv = closing * n;
  return {moving(ma.positionAt(t), va - dv, t), moving(mb.positionAt(t), vb + dv, t)};
}

TEST(ResponseLoop, NewtonsCradleOnEveryEngine) {
  // A moves at 1 m/s towards B and C at rest: A stops at B (t = 2), B stops at C (t = 4). B-C
  // is no impact at the start: only the re-prediction after A's response finds it.
  for (auto& bp : engines()) {
    const std::string name = bp->name();
    ResponseLoop loop(std::move(bp));
    const BodyId a = loop.add(makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
    const BodyId b = loop.add(makeSphere(0.5), moving({3, 0, 0}, {0, 0, 0}));
    const BodyId c = loop.add(makeSphere(0.5), moving({6, 0, 0}, {0, 0, 0}));
    std::vector<std::pair<BodyId, BodyId>> pairs;
    std::vector<double> times;
    const auto stats = loop.advance(0.0, 10.0, [&](const ResponseLoop::Contact& k, ResponseLoop::Response& r) {
      pairs.push_back({k.a, k.b});
      times.push_back(k.impact.time);
      EXPECT_EQ(r.time(), k.impact.time);
      const auto [na, nb] = elastic(r.motion(k.a), r.motion(k.b), k.impact.normal, k.impact.time);
      r.setMotion(k.a, na);
      r.setMotion(k.b, nb);
    });
    EXPECT_EQ(pairs, (std::vector<std::pair<BodyId, BodyId>>{{a, b}, {b, c}})) << name;
    ASSERT_EQ(times.size(), 2u) << name;
    EXPECT_NEAR(times[0], 2.0, 1e-6) << name;
    EXPECT_NEAR(times[1], 4.0, 1e-6) << name;
    EXPECT_NEAR(loop.motion(a).linear_velocity.norm(), 0.0, 1e-12) << name;
    EXPECT_NEAR(loop.motion(b).linear_velocity.norm(), 0.0, 1e-12) << name;
    EXPECT_NEAR(loop.motion(c).linear_velocity.x(), 1.0, 1e-12) << name;
    EXPECT_EQ(stats.contacts, 2u) << name;
    EXPECT_EQ(stats.requeried, 4u) << name;  // a and b, then b and c
  }
}

struct Logged {
  BodyId a, b;
  double time;
};

// The reference: after every response, every pair is predicted again from the time the later
// of its two bodies last changed (where the loop predicts it), and so is every body's boundary
// contact; the earliest contact not yet reported for that pair (or body and boundary) is the
// next one. O(n^2) per contact; shares only timeOfImpact and the boundary function.
std::vector<Logged> referenceLoop(const std::vector<Shape>& shapes, std::vector<Motion>& motions, double t0,
                                  double t1, const ResponseLoop::Boundary& boundary = {}) {
  const size_t n = shapes.size();
  const BodyId kWall = ResponseLoop::kBoundary;
  std::vector<PreparedShape> prepared(shapes.begin(), shapes.end());
  std::vector<double> changed_at(n, t0);
  std::vector<std::vector<double>> reported(n, std::vector<double>(n + 1, -INFINITY));  // [a][n]: boundary
  std::vector<Logged> log;
  for (;;) {
    bool found = false;
    Logged best{0, 0, INFINITY};
    TimeOfImpact best_hit;
    // Order of the queue: time, then a, then b (the boundary after every body).
    auto consider = [&](BodyId a, BodyId b, const TimeOfImpact& hit) {
      const bool earlier = hit.time < best.time ||
                           (hit.time == best.time && (a < best.a || (a == best.a && b < best.b)));
      if (!found || earlier) {
        best = {a, b, hit.time};
        best_hit = hit;
        found = true;
      }
    };
    for (BodyId a = 0; a < n; ++a) {
      for (BodyId b = a + 1; b < n; ++b) {
        const double from = std::max(changed_at[a], changed_at[b]);
        const TimeOfImpact hit = timeOfImpact(prepared[a], motions[a], prepared[b], motions[b], from, t1);
        if (hit.hit && hit.time > reported[a][b]) consider(a, b, hit);
      }
      if (boundary) {
        const TimeOfImpact hit = boundary(a, motions[a], changed_at[a], t1);
        if (hit.hit && hit.time > reported[a][n]) consider(a, kWall, hit);
      }
    }
    if (!found) return log;
    log.push_back(best);
    if (best.b == kWall) {
      reported[best.a][n] = best.time;
      motions[best.a] = reflect(motions[best.a], best_hit.normal, best.time);
      changed_at[best.a] = best.time;
    } else {
      reported[best.a][best.b] = best.time;
      const auto [na, nb] = elastic(motions[best.a], motions[best.b], best_hit.normal, best.time);
      motions[best.a] = na;
      motions[best.b] = nb;
      changed_at[best.a] = changed_at[best.b] = best.time;
    }
    if (log.size() > 10000) throw std::runtime_error("reference does not terminate");
  }
}

// Spheres at random non-overlapping places in [-2.5, 2.5]^3 with random velocities.
void randomScene(uint64_t seed, std::vector<Shape>& shapes, std::vector<Motion>& motions) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(-2.5, 2.5), vel(-2.0, 2.0), rad(0.2, 0.4);
  while (shapes.size() < 60) {
    const Eigen::Vector3d p(pos(rng), pos(rng), pos(rng));
    const double r = rad(rng);
    bool free = true;
    for (size_t i = 0; i < shapes.size(); ++i) {
      free = free && (motions[i].position - p).norm() > r + shapes[i].bounding_radius + 0.01;
    }
    if (!free) continue;
    shapes.push_back(makeSphere(r));
    motions.push_back(moving(p, Eigen::Vector3d(vel(rng), vel(rng), vel(rng))));
  }
}

// Runs the loop on every engine with elastic responses (and reflection at the boundary) and
// compares contacts and final motions with the reference. Returns the number of contacts.
size_t compareWithReference(uint64_t seed, double t1, const std::function<ResponseLoop::Boundary(
                                                          const std::vector<Shape>&)>& make_boundary) {
  std::vector<Shape> shapes;
  std::vector<Motion> motions;
  randomScene(seed, shapes, motions);
  const ResponseLoop::Boundary boundary = make_boundary ? make_boundary(shapes) : ResponseLoop::Boundary{};
  std::vector<Motion> ref_motions = motions;
  const std::vector<Logged> want = referenceLoop(shapes, ref_motions, 0.0, t1, boundary);
  EXPECT_GT(want.size(), 10u) << "seed " << seed << ": too few contacts";
  size_t walls = 0;
  for (const Logged& w : want) walls += w.b == ResponseLoop::kBoundary;
  if (boundary) EXPECT_GT(walls, 5u) << "seed " << seed << ": too few boundary contacts";
  for (auto& bp : engines()) {
    const std::string name = bp->name();
    ResponseLoop loop(std::move(bp));
    loop.setBoundary(boundary);
    for (size_t i = 0; i < shapes.size(); ++i) EXPECT_EQ(loop.add(shapes[i], motions[i]), i);
    std::vector<Logged> got;
    const auto stats = loop.advance(0.0, t1, [&](const ResponseLoop::Contact& k, ResponseLoop::Response& r) {
      got.push_back({k.a, k.b, k.impact.time});
      if (k.b == ResponseLoop::kBoundary) {
        r.setMotion(k.a, reflect(r.motion(k.a), k.impact.normal, k.impact.time));
        return;
      }
      const auto [na, nb] = elastic(r.motion(k.a), r.motion(k.b), k.impact.normal, k.impact.time);
      r.setMotion(k.a, na);
      r.setMotion(k.b, nb);
    });
    EXPECT_EQ(stats.boundary_contacts, walls) << name << " seed " << seed;
    EXPECT_EQ(got.size(), want.size()) << name << " seed " << seed;
    for (size_t i = 0; i < std::min(got.size(), want.size()); ++i) {
      EXPECT_EQ(got[i].a, want[i].a) << name << " seed " << seed << " contact " << i;
      EXPECT_EQ(got[i].b, want[i].b) << name << " seed " << seed << " contact " << i;
      EXPECT_EQ(got[i].time, want[i].time) << name << " seed " << seed << " contact " << i;
    }
    for (BodyId i = 0; i < shapes.size(); ++i) {
      EXPECT_EQ(loop.motion(i).linear_velocity, ref_motions[i].linear_velocity) << name << " body " << i;
    }
  }
  return want.size();
}

TEST(ResponseLoop, MatchesABruteForceEventLoopOnRandomScenes) {
  size_t total = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) total += compareWithReference(seed, 3.0, nullptr);
  std::printf("%zu contacts compared per engine\n", total);
}

// Walls of the box [-3, 3]^3: a sphere's first time of reaching one while moving outwards.
ResponseLoop::Boundary boxWalls(const std::vector<Shape>& shapes) {
  return [&shapes](BodyId id, const Motion& m, double from, double t1) {
    const double reach = 3.0 - shapes[id].bounding_radius;
    const Eigen::Vector3d p = m.positionAt(from), v = m.linear_velocity;
    TimeOfImpact best;
    for (int k = 0; k < 3; ++k) {
      if (v[k] == 0.0) continue;
      const double gap = v[k] > 0.0 ? reach - p[k] : reach + p[k];
      const double t = from + std::max(0.0, gap / std::abs(v[k]));
      if (t > t1 || (best.hit && t >= best.time)) continue;
      best.hit = true;
      best.time = t;
      best.normal = Eigen::Vector3d::Zero();
      best.normal[k] = v[k] > 0.0 ? 1.0 : -1.0;
      best.point = m.positionAt(t) + shapes[id].bounding_radius * best.normal;
    }
    return best;
  };
}

TEST(ResponseLoop, BoundaryContactsInterleaveWithPairsAsInTheReference) {
  size_t total = 0;
  for (uint64_t seed = 5; seed <= 7; ++seed) total += compareWithReference(seed, 4.0, boxWalls);
  std::printf("%zu contacts (pairs and walls) compared per engine\n", total);
}

TEST(ResponseLoop, ABoundaryContactOutsideTheIntervalThrows) {
  ResponseLoop loop(std::make_unique<BruteForceBroadPhase>());
  loop.add(makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  loop.setBoundary([](BodyId, const Motion&, double, double t1) {
    TimeOfImpact hit;
    hit.hit = true;
    hit.time = t1 + 1.0;
    hit.normal = Eigen::Vector3d::UnitX();
    return hit;
  });
  try {
    loop.advance(0.0, 1.0, [](const ResponseLoop::Contact&, ResponseLoop::Response&) {});
    FAIL() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("boundary function"), std::string::npos) << e.what();
  }
  // Nothing stays pending: without the faulty boundary the next advance reports nothing.
  loop.setBoundary({});
  size_t contacts = 0;
  loop.advance(0.0, 1.0, [&](const ResponseLoop::Contact&, ResponseLoop::Response&) { ++contacts; });
  EXPECT_EQ(contacts, 0u);
}

TEST(ResponseLoop, CallbacksMayChangeBodiesOutsideTheContact) {
  // A-B touch at t = 1. C heads for D (contact at t = 3); the response to A-B stops C, so C-D
  // never happens; it also launches E towards F (contact at t = 2 + 1 = ...), which must be found.
  ResponseLoop loop(VadopGridBroadPhase::makeBoxOnly());
  const BodyId a = loop.add(makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  const BodyId b = loop.add(makeSphere(0.5), moving({2, 0, 0}, {0, 0, 0}));
  const BodyId c = loop.add(makeSphere(0.5), moving({0, 10, 0}, {1, 0, 0}));
  const BodyId d = loop.add(makeSphere(0.5), moving({4, 10, 0}, {0, 0, 0}));
  const BodyId e = loop.add(makeSphere(0.5), moving({0, 20, 0}, {0, 0, 0}));
  const BodyId f = loop.add(makeSphere(0.5), moving({3, 20, 0}, {0, 0, 0}));
  std::vector<std::pair<BodyId, BodyId>> pairs;
  std::vector<double> times;
  loop.advance(0.0, 5.0, [&](const ResponseLoop::Contact& k, ResponseLoop::Response& r) {
    pairs.push_back({k.a, k.b});
    times.push_back(k.impact.time);
    if (k.a == a && k.b == b) {
      r.setMotion(c, moving(r.motion(c).positionAt(r.time()), {0, 0, 0}, r.time()));
      r.setMotion(e, moving({0, 20, 0}, {2, 0, 0}, r.time()));
    }
  });
  EXPECT_EQ(pairs, (std::vector<std::pair<BodyId, BodyId>>{{a, b}, {e, f}}));
  ASSERT_EQ(times.size(), 2u);
  EXPECT_NEAR(times[0], 1.0, 1e-6);
  EXPECT_NEAR(times[1], 2.0, 1e-6);  // E starts at t = 1, gap 2 m at 2 m/s
  EXPECT_EQ(loop.motion(c).linear_velocity, Eigen::Vector3d::Zero());
  (void)d;
}

TEST(ResponseLoop, AThrowingCallbackStopsTheLoopWithMotionsAsLastSet) {
  ResponseLoop loop(std::make_unique<VadopGridBroadPhase>(VadopConfig{}));
  const BodyId a = loop.add(makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  const BodyId b = loop.add(makeSphere(0.5), moving({3, 0, 0}, {0, 0, 0}));
  const BodyId c = loop.add(makeSphere(0.5), moving({6, 0, 0}, {0, 0, 0}));
  int calls = 0;
  auto cradle = [&](const ResponseLoop::Contact& k, ResponseLoop::Response& r) {
    ++calls;
    const auto [na, nb] = elastic(r.motion(k.a), r.motion(k.b), k.impact.normal, k.impact.time);
    r.setMotion(k.a, na);
    r.setMotion(k.b, nb);
    if (calls == 1) throw std::runtime_error("response failed");
  };
  EXPECT_THROW(loop.advance(0.0, 10.0, cradle), std::runtime_error);
  // The response made before the throw stands: A stopped at B, B moving.
  EXPECT_NEAR(loop.motion(a).linear_velocity.norm(), 0.0, 1e-12);
  EXPECT_NEAR(loop.motion(b).linear_velocity.x(), 1.0, 1e-12);
  EXPECT_EQ(loop.motion(c).linear_velocity, Eigen::Vector3d::Zero());
  // A later advance starts afresh from those motions: A and B still touch at its start (a
  // contact at t0, separating: no response), then B reaches C at t = 4.
  std::vector<std::pair<BodyId, BodyId>> pairs;
  std::vector<double> times;
  loop.advance(2.0, 10.0, [&](const ResponseLoop::Contact& k, ResponseLoop::Response& r) {
    pairs.push_back({k.a, k.b});
    times.push_back(k.impact.time);
    cradle(k, r);
  });
  EXPECT_EQ(pairs, (std::vector<std::pair<BodyId, BodyId>>{{a, b}, {b, c}}));
  ASSERT_EQ(times.size(), 2u);
  EXPECT_EQ(times[0], 2.0);
  EXPECT_NEAR(times[1], 4.0, 1e-6);
  EXPECT_NEAR(loop.motion(c).linear_velocity.x(), 1.0, 1e-12);
}

// Bodies share one prepared shape per shared pointer; a shape no body uses any more is freed
// and its slot reused, so that add/remove churn does not grow the loop and every body is
// tested with its own shape.
TEST(ResponseLoop, SharedShapesAreRecycledAndEachBodyKeepsItsOwn) {
  ResponseLoop loop(std::make_unique<VadopGridBroadPhase>(VadopConfig{}));
  auto sphere = std::make_shared<const Shape>(makeSphere(0.5));
  std::vector<BodyId> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(loop.add(sphere, moving({10.0 * i, 50, 0}, {0, 0, 0})));
  for (BodyId id : ids) loop.remove(id);
  // The sphere's entry is free: the same pointer added again must be prepared again, not
  // point at the freed entry, which the box then takes.
  const BodyId ball = loop.add(sphere, moving({5, 0, 0}, {-1, 0, 0}));
  const BodyId box = loop.add(std::make_shared<const Shape>(makeBox({2, 2, 2})), moving({0, 0, 0}, {0, 0, 0}));
  std::vector<double> times;
  loop.advance(0.0, 10.0, [&](const ResponseLoop::Contact& c, ResponseLoop::Response& r) {
    EXPECT_EQ(c.a, std::min(box, ball));
    times.push_back(c.impact.time);
    r.setMotion(ball, moving(r.motion(ball).positionAt(r.time()), {0, 0, 0}, r.time()));
  });
  ASSERT_EQ(times.size(), 1u);
  // The box's face at x = 1, the sphere's surface 0.5 ahead of its centre at 5 - t.
  EXPECT_NEAR(times[0], 3.5, 1e-5);

  // Churn: a fresh shape object per add, removed again; the loop's memory stays put.
  const size_t before = loop.memoryBytes();
  for (int i = 0; i < 200; ++i) {
    const BodyId id = loop.add(makeSphere(0.1 + 0.001 * i), moving({0, 20, 0}, {0, 0, 0}));
    loop.remove(id);
  }
  EXPECT_EQ(loop.memoryBytes(), before);
  EXPECT_EQ(loop.size(), 2u);
}

TEST(ResponseLoop, BadInputThrowsAndChangesNothing) {
  EXPECT_THROW(ResponseLoop(nullptr), InvalidArgument);
  auto used = std::make_unique<BruteForceBroadPhase>();
  used->add(makeSphere(1.0), moving({0, 0, 0}, {0, 0, 0}));
  EXPECT_THROW(ResponseLoop(std::move(used)), InvalidArgument);
  ToiOptions bad;
  bad.tolerance = 0.0;
  EXPECT_THROW(ResponseLoop(std::make_unique<BruteForceBroadPhase>(), bad), InvalidArgument);

  ResponseLoop loop(VadopGridBroadPhase::makeBoxOnly());
  const BodyId a = loop.add(makeSphere(0.5), moving({0, 0, 0}, {1, 0, 0}));
  Shape nan_shape = makeSphere(1.0);
  nan_shape.bounding_radius = std::nan("");
  EXPECT_THROW(loop.add(nan_shape, moving({0, 0, 0}, {0, 0, 0})), InvalidArgument);
  Motion nan_motion = moving({0, 0, 0}, {0, 0, 0});
  nan_motion.position.x() = std::nan("");
  EXPECT_THROW(loop.add(makeSphere(1.0), nan_motion), InvalidArgument);
  EXPECT_THROW(loop.setMotion(a, nan_motion), InvalidArgument);
  EXPECT_THROW(loop.setMotion(7, moving({0, 0, 0}, {0, 0, 0})), InvalidArgument);
  EXPECT_THROW(loop.remove(7), InvalidArgument);
  auto none = [](const ResponseLoop::Contact&, ResponseLoop::Response&) {};
  EXPECT_THROW(loop.advance(1.0, 0.0, none), InvalidArgument);
  EXPECT_THROW(loop.advance(0.0, std::nan(""), none), InvalidArgument);
  EXPECT_THROW(loop.advance(0.0, 1.0, ResponseLoop::Callback{}), InvalidArgument);
  EXPECT_EQ(loop.size(), 1u);
  EXPECT_EQ(loop.motion(a).linear_velocity, Eigen::Vector3d(1, 0, 0));
  // A callback setting a bad motion: the exception propagates, the motion stays.
  const BodyId b = loop.add(makeSphere(0.5), moving({2, 0, 0}, {0, 0, 0}));
  EXPECT_THROW(loop.advance(0.0, 5.0,
                            [&](const ResponseLoop::Contact&, ResponseLoop::Response& r) { r.setMotion(b, nan_motion); }),
               InvalidArgument);
  EXPECT_EQ(loop.motion(b).linear_velocity, Eigen::Vector3d::Zero());
  EXPECT_EQ(loop.motion(b).position, Eigen::Vector3d(2, 0, 0));
}

}  // namespace
}  // namespace vadop
