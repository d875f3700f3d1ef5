// vadop_microbench: Google Benchmark micro-benchmarks of the pieces under vadop_bench, for
// profiling (perf record ./vadop_microbench --benchmark_filter=...). Not the benchmark of the
// issue (vadop_bench is): these loop one operation, on one scene, without the checks.
#include "bench_adapters.h"
#include "bench_world.h"

#include "vadop/sweep_prune.h"
#include "vadop/time_of_impact.h"

#include <benchmark/benchmark.h>

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
    default: return makeGridBroadPhase();
  }
}

// One whole frame of the continuous world (broad phase, narrow phase, responses); each
// iteration is the next frame. Args: method (0 vadop, 1 sap, 2 fcl_rebuild, 3 bullet,
// 4 grid), n, speed * 10 (radii per frame).
void BM_Frame(benchmark::State& state) {
  SceneParams p;
  p.n = static_cast<int>(state.range(1));
  p.speed = state.range(2) / 10.0;
  ContinuousWorld world(makeScene(p), make(static_cast<int>(state.range(0))), RequeryMode::kGrid);
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

}  // namespace

BENCHMARK_MAIN();
