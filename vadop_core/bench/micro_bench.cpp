// vadop_microbench: Google Benchmark micro-benchmarks of the pieces under vadop_bench, for
// profiling (perf record ./vadop_microbench --benchmark_filter=...). Not the benchmark of the
// issue (vadop_bench is): these loop one operation, on one scene, without the checks.
#include "bench_adapters.h"
#include "bench_world.h"

#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/axis_pool.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop.h"
#include "vadop/vadop_grid.h"
#include "vadop/time_of_impact.h"
#include "vadop/world.h"

#include <benchmark/benchmark.h>

#include <random>
#include <string>

namespace {

using namespace vadop_bench;

// The library's narrow phase on one sphere pair (closed form plus argument validation).
void BM_TimeOfImpactSpheres(benchmark::State& state) {
  const vadop::Shape s = vadop::makeSphere(1.0);
  vadop::Motion a, b;
  a.linear_velocity = Eigen::Vector3d(30, 0, 0);
  b.position = Eigen::Vector3d(3, 0.5, 0);
  double t1 = 1.0 / 30.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(vadop::timeOfImpact(s, a, s, b, 0.0, t1));
  }
}
BENCHMARK(BM_TimeOfImpactSpheres);

std::unique_ptr<vadop::BroadPhase> make(int which) {
  switch (which) {
    case 0: return std::make_unique<vadop::SweepPruneBroadPhase>(vadop::VadopConfig{});
    case 1: return vadop::SweepPruneBroadPhase::makeEveryAxis(3);
    case 2: return makeFclBroadPhase(FclMode::kRebuild, BoxKind::kSwept);
    case 3: return makeBulletBroadPhase();
    default: return vadop::VadopGridBroadPhase::makeBoxOnly();
  }
}

// One whole frame of the continuous world (broad phase, narrow phase, responses); each
// iteration is the next frame. Args: method (0 vadop, 1 sap, 2 fcl_rebuild, 3 bullet,
// 4 grid), n, speed * 10 (radii per frame).
void BM_Frame(benchmark::State& state) {
  SceneParams p;
  p.n = static_cast<int>(state.range(1));
  p.speed = state.range(2) / 10.0;
  ContinuousWorld world(makeScene(p), make(static_cast<int>(state.range(0))));
  int f = 0;
  FrameStats st;
  world.runFrame(f++, st, nullptr);  // the first frame inserts everything
  for (auto _ : state) world.runFrame(f++, st, nullptr);
  state.counters["candidates"] = static_cast<double>(st.candidates);
  state.counters["impacts"] = static_cast<double>(st.impacts);
}
BENCHMARK(BM_Frame)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {3000}, {1, 10, 100}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(10);

// World::predict(t0, h, {one body}) after a full predict of the same window (the gate's query:
// what does this body touch?), at equal density for growing n: the paper's scene (spheres of
// radius 1, 1% density, 1 radius per frame, one frame). Args: kind (0 vadop, 1 grid, 2 sap,
// 3 brute), n, pattern: 0 = each query a random body of all n (every lookup a cache miss at
// 10^5: the name's hash table, the body's records), 1 = the same 16 bodies in turn (gates asking
// for their robots). Counter: candidate pairs (narrow-phase calls) per query. The query path
// itself costs the neighbours, not n; pattern 0 adds the memory latency of a larger world.
void BM_PredictOne(benchmark::State& state) {
  const vadop::BroadPhaseKind kinds[] = {vadop::BroadPhaseKind::kVadop, vadop::BroadPhaseKind::kGrid,
                                         vadop::BroadPhaseKind::kSap, vadop::BroadPhaseKind::kBrute};
  SceneParams p;
  p.n = static_cast<int>(state.range(1));
  const Scene scene = makeScene(p);
  vadop::WorldConfig c;
  c.broad_phase = kinds[state.range(0)];
  vadop::World world(c);
  const vadop::Shape sphere = vadop::makeSphere(p.radius);
  std::vector<std::string> ids;
  for (int i = 0; i < p.n; ++i) {
    ids.push_back("b" + std::to_string(i));
    vadop::Motion m;
    m.position = scene.position[i];
    m.linear_velocity = scene.velocity[i];
    world.add(ids.back(), sphere, m);
  }
  const double h = 1.0 / p.fps;
  world.predict(0.0, h);
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> pick(0, p.n - 1);
  std::vector<std::string> fixed;
  for (int i = 0; i < 16; ++i) fixed.push_back(ids[pick(rng)]);
  const bool random = state.range(2) == 0;
  double calls = 0, queries = 0;
  size_t next = 0;
  for (auto _ : state) {
    const std::string& id = random ? ids[pick(rng)] : fixed[next++ % fixed.size()];
    benchmark::DoNotOptimize(world.predict(0.0, h, {id}));
    calls += static_cast<double>(world.lastCandidateCount());
    queries += 1;
  }
  state.counters["candidates"] = calls / queries;
}
BENCHMARK(BM_PredictOne)
    ->ArgsProduct({{0, 1}, {10000, 100000}, {0, 1}})
    ->Args({0, 1000000, 0})  // 10^6: the cost once every lookup misses the caches
    ->Args({0, 1000000, 1})
    ->Args({2, 10000, 0})
    ->Args({3, 10000, 0})
    ->Unit(benchmark::kMicrosecond);

// The swept volumes of the monitor's fleet: robots of four shapes (the monitor bench's sphere,
// box, cylinder and capsule) driving and turning in the plane over a 2 s window. PartBoxes:
// the cull's boxes of 8 parts per body; Project: one swept body projected on every axis of the
// default pool (32; a body uses those near its velocity's normal plane). Arg: the shape (0..3).
struct FleetBodies {
  std::vector<vadop::Shape> shapes;
  std::vector<vadop::Motion> motions;
  explicit FleetBodies(int shape) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 256; ++i) {
      switch (shape) {
        case 0: shapes.push_back(vadop::makeSphere(0.3)); break;
        case 1: shapes.push_back(vadop::makeBox(Eigen::Vector3d(0.6, 0.4, 0.5))); break;
        case 2: shapes.push_back(vadop::makeCylinder(0.3, 0.5)); break;
        default: shapes.push_back(vadop::makeCapsule(0.2, 0.4)); break;
      }
      vadop::Motion m;
      m.position = Eigen::Vector3d(50 * u(rng), 50 * u(rng), 0.25);
      m.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d::UnitZ()));
      m.linear_velocity = Eigen::Vector3d(1.5 * u(rng), 1.5 * u(rng), 0.0);
      m.angular_velocity = Eigen::Vector3d(0.0, 0.0, 0.5 * u(rng));
      motions.push_back(m);
    }
  }
};

void BM_PartBoxes(benchmark::State& state) {
  const FleetBodies fleet(static_cast<int>(state.range(0)));
  double out[6 * 8];
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ % fleet.shapes.size();
    vadop::SweptBody::partBoxes(fleet.shapes[k], fleet.motions[k], 10.0, 12.0, 8, out);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_PartBoxes)->DenseRange(0, 3);

void BM_Project(benchmark::State& state) {
  const FleetBodies fleet(static_cast<int>(state.range(0)));
  const vadop::AxisPool pool(vadop::VadopConfig{}.axes);
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ % fleet.shapes.size();
    const vadop::SweptBody swept(fleet.shapes[k], fleet.motions[k], 10.0, 12.0);
    for (int a = 0; a < pool.size(); ++a) benchmark::DoNotOptimize(swept.project(pool.axis(a)));
  }
}
BENCHMARK(BM_Project)->DenseRange(0, 3);

// The fleet's four shapes (FleetBodies 0 to 3), prepared.
std::vector<vadop::PreparedShape> fleetShapes() {
  std::vector<vadop::PreparedShape> shapes;
  for (int k = 0; k < 4; ++k) shapes.emplace_back(FleetBodies(k).shapes[0]);
  return shapes;
}

// A robot of the fleet at p, heading `heading`: driving at 0.3-1.5 m/s and turning at up to 0.5
// rad/s about its screw pivot (as the monitor hands it over).
vadop::Motion fleetRobot(const Eigen::Vector3d& p, double heading, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double speed = 0.9 + 0.6 * u(rng);
  const Eigen::Vector3d v(speed * std::cos(heading), speed * std::sin(heading), 0.0);
  const Eigen::Vector3d w(0.0, 0.0, 0.5 * u(rng));
  vadop::Motion m = vadop::makeMotion(p, Eigen::Quaterniond(Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ())),
                                      vadop::screwPivotVelocity(v, w), w, 0.0);
  m.pivot_offset = vadop::screwPivotOffset(v, w);
  return m;
}

// The narrow phase on the pairs of a robot fleet: two robots of the fleet's shapes 0.7 to 1.9 m
// apart (fleetRobot), over a 2 s window: contacts, near misses and clear pairs mixed.
void BM_FleetTimeOfImpact(benchmark::State& state) {
  const std::vector<vadop::PreparedShape> shapes = fleetShapes();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  struct Case {
    int a, b;
    vadop::Motion ma, mb;
  };
  auto robot = [&](const Eigen::Vector3d& p) { return fleetRobot(p, 3.14159 * u(rng), rng); };
  std::vector<Case> cases;
  for (int i = 0; i < 512; ++i) {
    const double r = 0.7 + 0.6 * (u(rng) + 1.0);
    const double angle = 3.14159 * u(rng);
    cases.push_back({i % 4, (i / 4) % 4, robot(Eigen::Vector3d(0, 0, 0.25)),
                     robot(Eigen::Vector3d(r * std::cos(angle), r * std::sin(angle), 0.25))});
  }
  // Each iteration all the pairs (the same work per iteration: instruction counts compare).
  size_t hits = 0;
  for (auto _ : state) {
    hits = 0;
    for (const Case& c : cases) {
      const vadop::TimeOfImpact r = vadop::timeOfImpact(shapes[c.a], c.ma, shapes[c.b], c.mb, 0.0, 2.0);
      hits += r.hit;
      benchmark::DoNotOptimize(r);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cases.size()));
  state.counters["hit_share"] = static_cast<double>(hits) / static_cast<double>(cases.size());
}
BENCHMARK(BM_FleetTimeOfImpact);

// The narrow phase of a fleet's robots against a sensor's points: robots of the fleet's four
// shapes (fleetRobot) 0.5 to 3 m from a 20 m wall of 10,000 points (balls of 0.07 m:
// point_radius and padding) 2 m high, over a 2 s window (half of them reach it).
void BM_PointSetTimeOfImpact(benchmark::State& state) {
  const std::vector<vadop::PreparedShape> shapes = fleetShapes();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> wall;
  for (int i = 0; i < 10000; ++i) wall.emplace_back(10.0 * u(rng), 0.0, 1.0 + u(rng));
  const vadop::PreparedShape points(vadop::makePointSet(wall, 0.07));
  const vadop::Motion at_rest;
  std::vector<std::pair<int, vadop::Motion>> robots;
  for (int i = 0; i < 256; ++i) {
    const double heading = -1.5708 + 1.2 * u(rng);  // towards the wall, give or take
    const double x = 8.0 * u(rng), y = 1.75 + 1.25 * u(rng);
    robots.emplace_back(i % 4, fleetRobot(Eigen::Vector3d(x, y, 0.25), heading, rng));
  }
  size_t hits = 0;
  for (auto _ : state) {
    hits = 0;
    for (const auto& [k, m] : robots) {
      const vadop::TimeOfImpact r = vadop::timeOfImpact(shapes[k], m, points, at_rest, 0.0, 2.0);
      hits += r.hit;
      benchmark::DoNotOptimize(r);
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * robots.size()));
  state.counters["hit_share"] = static_cast<double>(hits) / static_cast<double>(robots.size());
}
BENCHMARK(BM_PointSetTimeOfImpact);

}  // namespace

BENCHMARK_MAIN();
