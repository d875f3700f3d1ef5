// vadop_bench: the VADOP paper's experiment (spheres in a box, elastic responses, 30 frames per
// second) run with VADOP and its peers on the same paths, with the paper's cost split
// c_u (bounding-volume update), c_s (sort / pair maintenance), c_t (narrow-phase tests) and
// c_r (responses), candidates, impacts, missed impacts and peak memory. See bench_world.h for
// the world and docs/bench/README.md for the measured figures.
//
// How a run is organised. For every (n, speed) the parent process builds the initial state
// (deterministic from the seed) and forks one child per method, one after the other, so each
// method's peak RSS is its own (VmHWM of the child; the state inherited from the parent is in
// its baseline, reported as baseline_rss_mb). The first child is the reference (brute force
// for n <= 5000, else the bench's exact uniform grid): it writes its per-frame impact lists to
// a temporary file. Every continuous method then runs on its own path and compares its
// per-frame impact list with the reference's: an exact method reproduces the reference path
// bit for bit (same state, same impacts, same responses). A method whose list differs in a
// frame has its missed/extra impacts counted there and leaves the reference path; from then on
// each of its frames is compared with the reference method run from its own state at the
// frame start (an oracle run; so "missed" always compares like with like). The pseudo-dynamic
// method never follows the reference path (it misses impacts by design): every frame of it is
// compared with the continuous reference run from its own state, in a second child process so
// that its timings and memory are not mixed with the oracle's.
#include "bench_adapters.h"
#include "bench_world.h"

#include "vadop/error.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

using vadop_bench::BoxKind;
using vadop_bench::ContinuousWorld;
using vadop_bench::DiscreteWorld;
using vadop_bench::FclMode;
using vadop_bench::FrameStats;
using vadop_bench::LoggedImpact;
using vadop_bench::Scene;
using vadop_bench::SceneParams;
using Json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

constexpr int kBruteMaxN = 5000;
constexpr int kMinFrames = 3;  // --max-seconds never stops a run before this many frames
                               // (nor the reference run, which the others are compared with)

const std::vector<std::string> kAllMethods = {
    "vadop", "vadop_rebuild", "vadop_sap", "kdop", "sap", "fcl_refit", "fcl_rebuild", "bullet", "brute", "grid", "fcl_discrete_refit",
    "fcl_discrete_rebuild"};
// grid is not a peer: it is the exact reference for n > 5000, run at n <= 5000 too so that it is
// checked against brute force.
const char* kDefaultMethods =
    "vadop,vadop_sap,kdop,sap,fcl_refit,fcl_rebuild,bullet,brute,grid,fcl_discrete_refit,fcl_discrete_rebuild";

bool isDiscrete(const std::string& m) { return m.rfind("fcl_discrete", 0) == 0; }
// The VADOP engines: the grid (incremental mode on, the library's default), the grid rebuilt
// every frame (incremental mode off), and the paper's per-axis sweep and prune.
bool isVadop(const std::string& m) { return m == "vadop" || m == "vadop_rebuild" || m == "vadop_sap"; }

struct Options {
  std::string preset;
  std::vector<int> n = {1000, 3000};
  std::vector<double> speed = {0.1, 1.0, 10.0};
  std::vector<int> m = {32};
  std::vector<double> phi = {25.0};
  std::vector<std::string> methods;
  double density = 0.01;
  int frames = 30;
  uint64_t seed = 1;
  bool json = false;
  double max_seconds = 0.0;  // per run; 0 = no limit
  // Checks after every frame of the reference run that no two spheres overlap and every
  // sphere is inside the box (O(n^2) per frame; on by default for n <= 2000).
  int verify_max_n = 2000;
};

[[noreturn]] void usage(const std::string& msg) {
  std::fprintf(stderr,
               "vadop_bench: %s\n"
               "usage: vadop_bench [--preset quick|medium|full] [--json] [--n N,N,...] [--speed S,S,...]\n"
               "                   [--m M,M,...] [--phi DEG,DEG,...] [--methods LIST|all] [--density D]\n"
               "                   [--frames F] [--seed S] [--max-seconds T] [--verify-max-n N]\n"
               "  speed: radii per frame (> 0), or slow (0.1), medium (1), fast (10)\n"
               "  methods: %s (default: %s)\n"
               "  phi: VADOP zone half-width in degrees (0 = the pool's covering radius)\n"
               "exit status: 0 ok, 1 a continuous method missed an impact or a run failed, 2 bad input\n",
               msg.c_str(), "vadop,vadop_rebuild,vadop_sap,kdop,sap,fcl_refit,fcl_rebuild,bullet,brute,grid,fcl_discrete_refit,fcl_discrete_rebuild",
               kDefaultMethods);
  std::exit(2);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) usage("empty item in list '" + s + "'");
    out.push_back(item);
  }
  if (out.empty()) usage("empty list");
  return out;
}

double parseNumber(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(x)) usage(flag + ": not a finite number: '" + v + "'");
  return x;
}

long long parseInteger(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  errno = 0;
  const long long x = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || end != v.c_str() + v.size() || errno != 0) usage(flag + ": not an integer: '" + v + "'");
  return x;
}

double parseSpeed(const std::string& v) {
  if (v == "slow") return 0.1;
  if (v == "medium") return 1.0;
  if (v == "fast") return 10.0;
  const double s = parseNumber("--speed", v);
  if (!(s > 0.0)) usage("--speed must be > 0 radii per frame, got " + v);
  if (s > 1000.0) usage("--speed must be <= 1000 radii per frame, got " + v);
  return s;
}

void applyPreset(Options& o, const std::string& p) {
  o.preset = p;
  if (p == "quick") {
    // CI: small n, few frames, every method; exits non-zero on a miss.
    o.n = {300, 800};
    o.speed = {0.1, 1.0, 10.0};
    o.m = {16, 32};
    o.phi = {25.0};
    o.frames = 8;
  } else if (p == "medium") {
    o.n = {1000, 3000, 10000};
    o.speed = {0.1, 1.0, 10.0};
    o.m = {16, 32, 64};
    o.phi = {25.0};
    o.frames = 20;
    o.max_seconds = 10;
  } else if (p == "full") {
    // Up to 10^5 bodies: VADOP against the peers users would pick (the m sweep and the
    // per-axis engines, whose frames take seconds at this scale, are the medium preset's).
    o.n = {1000, 3000, 10000, 30000, 100000};
    o.speed = {0.1, 1.0, 10.0};
    o.m = {16};
    o.phi = {25.0};
    o.frames = 10;
    o.max_seconds = 60;
    o.methods = split("vadop,vadop_rebuild,grid,sap,fcl_refit,fcl_rebuild,bullet,fcl_discrete_refit,fcl_discrete_rebuild");
  } else {
    usage("unknown preset '" + p + "' (quick, medium, full)");
  }
}

// The command line as (flag, value) pairs ("--json" without a value); exits on a malformed one.
std::vector<std::pair<std::string, std::string>> collectFlags(int argc, char** argv) {
  std::vector<std::pair<std::string, std::string>> flags;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") usage("help");
    if (a == "--json") {
      flags.emplace_back(a, "");
      continue;
    }
    if (a.rfind("--", 0) != 0) usage("unexpected argument '" + a + "'");
    if (i + 1 >= argc) usage("missing value after " + a);
    flags.emplace_back(a, argv[++i]);
  }
  return flags;
}

// The flags that take a comma-separated list; false for any other flag.
bool applyListFlag(Options& o, const std::string& f, const std::string& v) {
  if (f == "--n") {
    o.n.clear();
    for (const auto& s : split(v)) {
      const long long n = parseInteger("--n", s);
      if (n <= 0) usage("--n must be > 0, got " + s);
      if (n > 10000000) usage("--n must be <= 10000000, got " + s);
      o.n.push_back(static_cast<int>(n));
    }
  } else if (f == "--speed") {
    o.speed.clear();
    for (const auto& s : split(v)) o.speed.push_back(parseSpeed(s));
  } else if (f == "--m") {
    o.m.clear();
    for (const auto& s : split(v)) {
      const long long m = parseInteger("--m", s);
      if (m < 3 || m > vadop::AxisPool::kMaxAxes) {
        usage("--m must be in [3, " + std::to_string(vadop::AxisPool::kMaxAxes) + "], got " + s);
      }
      o.m.push_back(static_cast<int>(m));
    }
  } else if (f == "--phi") {
    o.phi.clear();
    for (const auto& s : split(v)) {
      const double p = parseNumber("--phi", s);
      if (p < 0.0 || p > 90.0) usage("--phi must be in [0, 90] degrees, got " + s);
      o.phi.push_back(p);
    }
  } else if (f == "--methods") {
    o.methods.clear();
    for (const auto& s : split(v)) {
      if (s == "all") {
        o.methods.insert(o.methods.end(), kAllMethods.begin(), kAllMethods.end());
        continue;
      }
      // faulty: a self-test of the miss detection (drops candidate pairs); not in "all".
      if (std::find(kAllMethods.begin(), kAllMethods.end(), s) == kAllMethods.end() && s != "faulty") {
        usage("unknown method '" + s + "'");
      }
      o.methods.push_back(s);
    }
  } else {
    return false;
  }
  return true;
}

// The flags that take one value; false for any other flag.
bool applyScalarFlag(Options& o, const std::string& f, const std::string& v) {
  if (f == "--density") {
    o.density = parseNumber("--density", v);
    if (!(o.density > 0.0 && o.density <= 0.5)) usage("--density must be in (0, 0.5], got " + v);
  } else if (f == "--frames") {
    const long long fr = parseInteger("--frames", v);
    if (fr <= 0 || fr > 1000000) usage("--frames must be in [1, 1000000], got " + v);
    o.frames = static_cast<int>(fr);
  } else if (f == "--seed") {
    const long long s = parseInteger("--seed", v);
    if (s < 0) usage("--seed must be >= 0, got " + v);
    o.seed = static_cast<uint64_t>(s);
  } else if (f == "--verify-max-n") {
    const long long vn = parseInteger("--verify-max-n", v);
    if (vn < 0) usage("--verify-max-n must be >= 0, got " + v);
    o.verify_max_n = static_cast<int>(std::min<long long>(vn, 1 << 30));
  } else if (f == "--max-seconds") {
    o.max_seconds = parseNumber("--max-seconds", v);
    if (o.max_seconds < 0) usage("--max-seconds must be >= 0, got " + v);
  } else {
    return false;
  }
  return true;
}

Options parse(int argc, char** argv) {
  Options o;
  const std::vector<std::pair<std::string, std::string>> flags = collectFlags(argc, argv);
  for (const auto& [f, v] : flags) {
    if (f == "--preset") applyPreset(o, v);  // first, so that explicit flags override it
  }
  for (const auto& [f, v] : flags) {
    if (f == "--preset") continue;
    if (f == "--json") {
      o.json = true;
    } else if (!applyListFlag(o, f, v) && !applyScalarFlag(o, f, v)) {
      usage("unknown option " + f);
    }
  }
  if (o.methods.empty()) o.methods = split(kDefaultMethods);
  // Deduplicate, keeping the order.
  std::vector<std::string> uniq;
  for (const auto& m : o.methods)
    if (std::find(uniq.begin(), uniq.end(), m) == uniq.end()) uniq.push_back(m);
  o.methods = uniq;
  return o;
}

struct RunSpec {
  std::string method;
  int m = 0;         // pool size (vadop, kdop), 3 (sap), 0 otherwise
  double phi = -1;   // vadop only (degrees as configured; 0 = rho)
};

std::unique_ptr<vadop::BroadPhase> makeBroadPhase(const RunSpec& s) {
  if (isVadop(s.method)) {
    vadop::VadopConfig c;
    c.axes = s.m;
    c.phi_deg = s.phi;
    if (s.method == "vadop_sap") return std::make_unique<vadop::SweepPruneBroadPhase>(c);
    if (s.method == "vadop_rebuild") return std::make_unique<vadop::VadopGridBroadPhase>(c, 0.0, 0.0);
    return std::make_unique<vadop::VadopGridBroadPhase>(c);
  }
  if (s.method == "kdop") return vadop::SweepPruneBroadPhase::makeEveryAxis(s.m);
  if (s.method == "sap") return vadop::SweepPruneBroadPhase::makeEveryAxis(3);
  if (s.method == "fcl_refit") return vadop_bench::makeFclBroadPhase(FclMode::kRefit, BoxKind::kSwept);
  if (s.method == "fcl_rebuild") return vadop_bench::makeFclBroadPhase(FclMode::kRebuild, BoxKind::kSwept);
  if (s.method == "fcl_discrete_refit") return vadop_bench::makeFclBroadPhase(FclMode::kRefit, BoxKind::kDiscrete);
  if (s.method == "fcl_discrete_rebuild") return vadop_bench::makeFclBroadPhase(FclMode::kRebuild, BoxKind::kDiscrete);
  if (s.method == "bullet") return vadop_bench::makeBulletBroadPhase();
  if (s.method == "brute") return std::make_unique<vadop::BruteForceBroadPhase>();
  if (s.method == "grid") return vadop::VadopGridBroadPhase::makeBoxOnly();
  if (s.method == "faulty") return vadop_bench::makeFaultyBroadPhase();
  throw std::logic_error("unknown method " + s.method);
}

// The ground truth of the miss check: brute force (whose queries scan every body), or beyond
// kBruteMaxN (too slow) FCL's tree rebuilt every frame on the bench's own boxes, whose frame
// shares no code with the library's engines (the library's grid does: it is VADOP without the
// axes); its mid-frame queries share BroadPhase's index of the bodies changed since the
// update, which test_world_query checks against an independent scan.
std::string referenceMethod(int n) { return n <= kBruteMaxN ? "brute" : "fcl_rebuild"; }

// ---------------------------------------------------------------------------------------------
// Measurements

double procStatusMb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const size_t len = std::strlen(key);
  while (std::getline(in, line)) {
    if (line.compare(0, len, key) == 0 && line.size() > len && line[len] == ':') {
      return std::strtod(line.c_str() + len + 1, nullptr) / 1024.0;  // kB -> MB
    }
  }
  return -1.0;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  // Nearest rank.
  size_t k = static_cast<size_t>(std::ceil(q * v.size()));
  k = std::clamp<size_t>(k, 1, v.size());
  return v[k - 1];
}

struct Series {
  std::vector<double> total, update, sort, test, response, requery, cpu;
  double endpoints = 0, swaps = 0, overlap_tests = 0, reinserted = 0;  // sums over the timed frames
  void add(const FrameStats& s) {
    endpoints += s.sp_endpoints;
    swaps += s.sp_swaps;
    overlap_tests += s.sp_overlap_tests;
    reinserted += s.sp_reinserted;
    total.push_back(s.total() * 1e3);
    cpu.push_back(s.cpu_s * 1e3);
    update.push_back(s.update_s * 1e3);
    sort.push_back(s.sort_s * 1e3);
    test.push_back(s.test_s * 1e3);
    response.push_back(s.response_s * 1e3);
    requery.push_back(s.requery_s * 1e3);
  }
};

double round3(double x) { return std::round(x * 1000.0) / 1000.0; }

class Progress {
 public:
  Progress(std::string label, int frames) : label_(std::move(label)), frames_(frames), on_(isatty(2)) {}
  void frame(int done, double last_ms) {
    if (!on_) return;
    const int width = 24;
    const int fill = frames_ > 0 ? done * width / frames_ : width;
    std::fprintf(stderr, "\r\033[K%s [%.*s%*s] %d/%d  %.2f ms/frame", label_.c_str(), fill,
                 "########################", width - fill, "", done, frames_, last_ms);
    std::fflush(stderr);
  }
  void done() {
    if (!on_) return;
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }

 private:
  std::string label_;
  int frames_;
  bool on_;
};

// TimeOfImpact lists: exact comparison; on a difference, the multiset differences by (a, b, time).
void diffImpacts(const std::vector<LoggedImpact>& ref, const std::vector<LoggedImpact>& got, size_t& missed,
                 size_t& extra) {
  auto key = [](const LoggedImpact& x) { return std::make_tuple(x.a, x.b, x.time); };
  std::multiset<std::tuple<uint32_t, uint32_t, double>> a, b;
  for (const auto& x : ref) a.insert(key(x));
  for (const auto& x : got) b.insert(key(x));
  missed = 0;
  extra = 0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() || ib != b.end()) {
    if (ib == b.end() || (ia != a.end() && *ia < *ib)) {
      ++missed;
      ++ia;
    } else if (ia == a.end() || *ib < *ia) {
      ++extra;
      ++ib;
    } else {
      ++ia;
      ++ib;
    }
  }
}

// The reference's impacts of frame f, run from `motions` at the frame start.
std::vector<LoggedImpact> oracleFrame(const Scene& scene, const std::vector<vadop::Motion>& motions, int f) {
  const std::string ref = referenceMethod(scene.params.n);
  ContinuousWorld oracle(scene, motions, makeBroadPhase(RunSpec{ref}));
  FrameStats st;
  std::vector<LoggedImpact> log;
  oracle.runFrame(f, st, &log);
  return log;
}

enum class ChildRole { kReference, kMethod, kDiscreteEval };

// The physics is right: at the end of a frame no two spheres overlap (the narrow phase stops
// them at a gap of tolerance / 2) and every sphere is inside the box.
void verifyState(const Scene& scene, const std::vector<vadop::Motion>& motions, double t, int f) {
  const double r = scene.params.radius, wall = scene.half - r + 1e-9;
  const double min_d2 = 4.0 * r * r * (1.0 - 1e-12);
  std::vector<Eigen::Vector3d> p(motions.size());
  for (size_t i = 0; i < p.size(); ++i) {
    p[i] = motions[i].positionAt(t);
    if (p[i].cwiseAbs().maxCoeff() > wall) {
      throw std::runtime_error("verify: sphere " + std::to_string(i) + " outside the box after frame " + std::to_string(f));
    }
  }
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t k = i + 1; k < p.size(); ++k)
      if ((p[i] - p[k]).squaredNorm() < min_d2) {
        throw std::runtime_error("verify: spheres " + std::to_string(i) + " and " + std::to_string(k) +
                                 " overlap after frame " + std::to_string(f));
      }
}

// One method's run in this (child) process: the frames, the figures booked per frame, and the
// comparison of each frame's impacts with the reference's.
class MethodRun {
 public:
  MethodRun(const Options& o, const Scene& scene, ChildRole role, const std::string& label)
      : o_(o), scene_(scene), role_(role), progress_(label, o.frames), start_(Clock::now()) {}

  // Every frame of a discrete method (its pairs checked against the continuous reference in
  // the evaluation pass).
  void runDiscrete(std::unique_ptr<vadop::BroadPhase> bp) {
    DiscreteWorld world(scene_, std::move(bp));
    std::vector<vadop::Pair> detected;
    for (int f = 0; f < o_.frames; ++f) {
      std::vector<vadop::Motion> snapshot;
      if (role_ == ChildRole::kDiscreteEval) snapshot = world.motions();
      FrameStats st;
      world.runFrame(f, st, detected);
      if (role_ == ChildRole::kDiscreteEval) countUndetected(snapshot, f, detected);
      if (recordFrame(f, st)) break;
    }
    bp_bytes_ = world.broadPhase().memoryBytes();
    progress_.done();
  }

  // Every frame of a continuous method: the reference writes its impacts to the log, the
  // others compare theirs with it.
  void runContinuous(std::unique_ptr<vadop::BroadPhase> bp, const std::string& log_path) {
    ContinuousWorld world(scene_, std::move(bp));
    std::FILE* logf = std::fopen(log_path.c_str(), role_ == ChildRole::kReference ? "wb" : "rb");
    if (!logf) throw std::runtime_error("cannot open the reference log " + log_path);
    std::vector<LoggedImpact> log;
    for (int f = 0; f < o_.frames; ++f) {
      std::vector<vadop::Motion> snapshot;
      if (!on_path_) snapshot = world.motions();
      FrameStats st;
      log.clear();
      world.runFrame(f, st, &log);
      if (role_ == ChildRole::kReference) {
        if (scene_.params.n <= o_.verify_max_n) verifyState(scene_, world.motions(), (f + 1) * world.frameLength(), f);
        const uint64_t count = log.size();
        std::fwrite(&count, sizeof count, 1, logf);
        if (count) std::fwrite(log.data(), sizeof(LoggedImpact), log.size(), logf);
      } else {
        compareWithReference(on_path_ ? readReferenceFrame(logf) : oracleFrame(scene_, snapshot, f), log, f);
      }
      requery_pairs_.push_back(static_cast<double>(st.requery_pairs));
      if (const auto* vg = dynamic_cast<const vadop::VadopGridBroadPhase*>(&world.broadPhase())) {
        incremental_frames_ += vg->stats().incremental ? 1 : 0;
      }
      if (recordFrame(f, st)) break;
    }
    std::fclose(logf);
    bp_bytes_ = world.broadPhase().memoryBytes();
    world_bytes_ = world.memoryBytes();
    progress_.done();
  }

  // The frame times, candidates and counters of the engines.
  void reportTimings(Json& j, bool is_vadop_grid, bool is_sweep_prune) const {
    auto mean = [](const std::vector<double>& v) {
      double s = 0;
      for (double x : v) s += x;
      return v.empty() ? 0.0 : s / v.size();
    };
    j["frames"] = frames_done_;
    j["timed_frames"] = series_.total.size();
    j["frame_ms_median"] = round3(percentile(series_.total, 0.5));
    j["frame_ms_p95"] = round3(percentile(series_.total, 0.95));
    j["update_ms"] = round3(percentile(series_.update, 0.5));
    j["update_ms_p95"] = round3(percentile(series_.update, 0.95));
    j["sort_ms"] = round3(percentile(series_.sort, 0.5));
    j["sort_ms_p95"] = round3(percentile(series_.sort, 0.95));
    j["test_ms"] = round3(percentile(series_.test, 0.5));
    j["test_ms_p95"] = round3(percentile(series_.test, 0.95));
    j["response_ms"] = round3(percentile(series_.response, 0.5));
    j["response_ms_p95"] = round3(percentile(series_.response, 0.95));
    j["requery_ms"] = round3(percentile(series_.requery, 0.5));
    j["frame_cpu_ms_median"] = round3(percentile(series_.cpu, 0.5));
    j["frame_cpu_ms_p95"] = round3(percentile(series_.cpu, 0.95));
    j["first_frame_ms"] = round3(first_frame_ms_);
    j["candidates"] = round3(mean(candidates_));
    j["candidates_p95"] = round3(percentile(candidates_, 0.95));
    j["requery_pairs"] = round3(mean(requery_pairs_));
    if (is_vadop_grid) j["incremental_frames"] = incremental_frames_;  // frames found from fat boxes
    if (is_sweep_prune && !series_.total.empty()) {
      const double k = 1.0 / series_.total.size();
      j["sweep_prune"] = Json{{"endpoints", round3(series_.endpoints * k)},
                              {"swaps", round3(series_.swaps * k)},
                              {"overlap_tests", round3(series_.overlap_tests * k)},
                              {"reinserted", round3(series_.reinserted * k)}};
    }
  }

  // The impacts found and those missed against the reference, with what they were judged by.
  void reportImpacts(Json& j, bool continuous, const std::string& reference) const {
    j["impacts"] = impacts_;
    j["impacts_per_frame"] = round3(frames_done_ ? static_cast<double>(impacts_) / frames_done_ : 0.0);
    j["wall_hits"] = wall_hits_;
    j["continuous"] = continuous;
    if (role_ == ChildRole::kReference) {
      j["missed"] = 0;
      j["extra"] = 0;
      j["miss_basis"] = "is the reference";
    } else if (continuous) {
      j["missed"] = missed_;
      j["extra"] = extra_;
      j["miss_basis"] = "per-frame impact list vs the reference run (same path); off that path, vs the reference "
                        "run from the method's own state";
    } else if (role_ == ChildRole::kDiscreteEval) {
      j["missed"] = missed_;
      j["extra"] = nullptr;
      j["miss_basis"] = "evaluation pass";
    } else {
      j["missed"] = nullptr;  // filled from the evaluation child
      j["extra"] = nullptr;
      j["miss_basis"] = "pairs touching during the frame (continuous reference from the same state) not found "
                        "overlapping at the frame pose";
    }
    j["reference"] = reference;
    j["reference_impacts"] = reference_impacts_;
  }

  void reportRun(Json& j, double peak, double baseline) const {
    j["diverged_frame"] = diverged_frame_;
    j["peak_rss_mb"] = round3(peak);
    j["baseline_rss_mb"] = round3(baseline);
    j["bp_memory_mb"] = round3(bp_bytes_ / 1048576.0);
    j["world_memory_mb"] = round3(world_bytes_ / 1048576.0);
    j["truncated"] = truncated_;
    j["seconds"] = round3(std::chrono::duration<double>(Clock::now() - start_).count());
  }

 private:
  // Books one frame's figures; true when the run must stop (the time budget, never for the
  // reference, never before kMinFrames).
  bool recordFrame(int f, const FrameStats& st) {
    if (f == 0 && o_.frames > 1) {
      first_frame_ms_ = st.total() * 1e3;
    } else {
      series_.add(st);
    }
    candidates_.push_back(static_cast<double>(st.candidates));
    impacts_ += st.impacts;
    wall_hits_ += st.wall_hits;
    ++frames_done_;
    progress_.frame(frames_done_, st.total() * 1e3);
    if (role_ != ChildRole::kReference && o_.max_seconds > 0 && frames_done_ >= kMinFrames &&
        std::chrono::duration<double>(Clock::now() - start_).count() > o_.max_seconds && f + 1 < o_.frames) {
      truncated_ = true;
    }
    return truncated_;
  }

  // Pairs that truly touch during the frame (the continuous reference from the same state),
  // against the pairs found overlapping at the frame pose.
  void countUndetected(const std::vector<vadop::Motion>& snapshot, int f, const std::vector<vadop::Pair>& detected) {
    std::set<std::pair<uint32_t, uint32_t>> truth;
    for (const auto& x : oracleFrame(scene_, snapshot, f)) truth.insert({x.a, x.b});
    reference_impacts_ += truth.size();
    for (const auto& p : truth) {
      if (!std::binary_search(detected.begin(), detected.end(), vadop::Pair{p.first, p.second})) ++missed_;
    }
  }

  static std::vector<LoggedImpact> readReferenceFrame(std::FILE* logf) {
    std::vector<LoggedImpact> truth;
    uint64_t count = 0;
    if (std::fread(&count, sizeof count, 1, logf) != 1) throw std::runtime_error("short reference log");
    truth.resize(count);
    if (count && std::fread(truth.data(), sizeof(LoggedImpact), count, logf) != count) {
      throw std::runtime_error("short reference log");
    }
    return truth;
  }

  // A frame's impacts against the reference's; the first difference leaves the reference's
  // path (later frames are judged from the method's own state).
  void compareWithReference(const std::vector<LoggedImpact>& truth, const std::vector<LoggedImpact>& log, int f) {
    reference_impacts_ += truth.size();
    if (truth == log) return;
    size_t mi = 0, ex = 0;
    diffImpacts(truth, log, mi, ex);
    missed_ += mi;
    extra_ += ex;
    if (on_path_) {
      on_path_ = false;
      diverged_frame_ = f;
    }
  }

  const Options& o_;
  const Scene& scene_;
  const ChildRole role_;
  Progress progress_;
  const Clock::time_point start_;
  Series series_;
  std::vector<double> candidates_, requery_pairs_;
  size_t incremental_frames_ = 0;
  size_t impacts_ = 0, wall_hits_ = 0, missed_ = 0, extra_ = 0, reference_impacts_ = 0;
  long diverged_frame_ = -1;
  int frames_done_ = 0;
  bool truncated_ = false;
  bool on_path_ = true;
  double first_frame_ms_ = 0.0;
  size_t bp_bytes_ = 0, world_bytes_ = 0;
};

// Runs one method in this (child) process and returns its JSON line.
Json runMethod(const Options& o, const Scene& scene, const RunSpec& spec, ChildRole role, const std::string& log_path,
               const std::string& label) {
  const double baseline = procStatusMb("VmRSS");
  const int n = scene.params.n;
  Json j;
  j["method"] = spec.method;
  j["n"] = n;
  j["speed"] = scene.params.speed;
  j["m"] = spec.m > 0 ? Json(spec.m) : Json(nullptr);
  j["phi"] = nullptr;
  j["density"] = scene.params.density;
  j["seed"] = scene.params.seed;

  std::unique_ptr<vadop::BroadPhase> bp = makeBroadPhase(spec);
  if (const auto* sp = dynamic_cast<const vadop::SweepPruneBroadPhase*>(bp.get()); sp && sp->velocityAligned()) {
    j["phi"] = round3(sp->phi() * 180.0 / M_PI);
  }
  if (const auto* vg = dynamic_cast<const vadop::VadopGridBroadPhase*>(bp.get()); vg && vg->velocityAligned()) {
    j["phi"] = round3(vg->phi() * 180.0 / M_PI);
  }
  const bool discrete = isDiscrete(spec.method);
  const bool is_sweep_prune = dynamic_cast<const vadop::SweepPruneBroadPhase*>(bp.get()) != nullptr;
  const bool is_vadop_grid = dynamic_cast<const vadop::VadopGridBroadPhase*>(bp.get()) != nullptr;
  MethodRun run(o, scene, role, label);
  if (discrete) {
    run.runDiscrete(std::move(bp));
  } else {
    run.runContinuous(std::move(bp), log_path);
  }
  const double peak = procStatusMb("VmHWM");
  run.reportTimings(j, is_vadop_grid, is_sweep_prune);
  run.reportImpacts(j, !discrete, referenceMethod(n));
  run.reportRun(j, peak, baseline);
  return j;
}

// Forks a child that runs the method and sends its JSON line back through a pipe.
Json runInChild(const Options& o, const Scene& scene, const RunSpec& spec, ChildRole role, const std::string& log_path,
                const std::string& label) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    close(fds[0]);
    int code = 0;
    std::string out;
    try {
      out = runMethod(o, scene, spec, role, log_path, label).dump();
    } catch (const std::exception& e) {
      Json err;
      err["method"] = spec.method;
      err["n"] = scene.params.n;
      err["speed"] = scene.params.speed;
      err["error"] = e.what();
      out = err.dump();
      code = 3;
    }
    out += "\n";
    size_t off = 0;
    while (off < out.size()) {
      const ssize_t w = write(fds[1], out.data() + off, out.size() - off);
      if (w <= 0) break;
      off += static_cast<size_t>(w);
    }
    close(fds[1]);
    _exit(code);
  }
  close(fds[1]);
  std::string text;
  char buf[4096];
  for (;;) {
    const ssize_t r = read(fds[0], buf, sizeof buf);
    if (r <= 0) break;
    text.append(buf, static_cast<size_t>(r));
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!text.empty()) {
    try {
      return Json::parse(text);
    } catch (const std::exception&) {
    }
  }
  Json err;
  err["method"] = spec.method;
  err["n"] = scene.params.n;
  err["speed"] = scene.params.speed;
  err["error"] = WIFSIGNALED(status) ? "child killed by signal " + std::to_string(WTERMSIG(status))
                                     : "child exited with status " + std::to_string(WEXITSTATUS(status));
  return err;
}

void printHuman(const Json& j, bool header) {
  if (header) {
    std::printf("%-22s %7s %6s %4s %6s %10s %10s %8s %8s %8s %8s %11s %9s %8s %8s\n", "method", "n", "speed", "m", "phi",
                "frame_ms", "p95_ms", "c_u", "c_s", "c_t", "c_r", "cand/frame", "impacts", "missed", "rss_MB");
  }
  if (j.contains("error")) {
    std::printf("%-22s %7d %6g  ERROR: %s\n", j["method"].get<std::string>().c_str(), j["n"].get<int>(),
                j["speed"].get<double>(), j["error"].get<std::string>().c_str());
    return;
  }
  auto num = [&](const char* k) { return j[k].is_null() ? -1.0 : j[k].get<double>(); };
  std::printf("%-22s %7d %6g %4s %6s %10.3f %10.3f %8.3f %8.3f %8.3f %8.3f %11.1f %9zu %8s %8.1f%s\n",
              j["method"].get<std::string>().c_str(), j["n"].get<int>(), j["speed"].get<double>(),
              j["m"].is_null() ? "-" : std::to_string(j["m"].get<int>()).c_str(),
              j["phi"].is_null() ? "-" : std::to_string(j["phi"].get<double>()).substr(0, 5).c_str(), num("frame_ms_median"),
              num("frame_ms_p95"), num("update_ms"), num("sort_ms"), num("test_ms"), num("response_ms"), num("candidates"),
              j["impacts"].get<size_t>(), j["missed"].is_null() ? "-" : std::to_string(j["missed"].get<size_t>()).c_str(),
              num("peak_rss_mb"), j["truncated"].get<bool>() ? " (truncated)" : "");
  std::fflush(stdout);
}

}  // namespace

// The runs the options ask for: each method with each pool size and zone width it takes.
std::vector<RunSpec> expandSpecs(const Options& o) {
  std::vector<RunSpec> specs;
  for (const auto& method : o.methods) {
    if (isVadop(method)) {
      for (int m : o.m)
        for (double phi : o.phi) specs.push_back(RunSpec{method, m, phi});
    } else if (method == "kdop") {
      for (int m : o.m) specs.push_back(RunSpec{method, m, -1});
    } else if (method == "sap") {
      specs.push_back(RunSpec{method, 3, -1});
    } else {
      specs.push_back(RunSpec{method, 0, -1});
    }
  }
  return specs;
}

// Every configuration and scene size built once before anything runs (bad input: exit 2).
void validateConfigurations(const Options& o, const std::vector<RunSpec>& specs) {
  for (const auto& s : specs) {
    try {
      (void)makeBroadPhase(s);
    } catch (const vadop::InvalidArgument& e) {
      usage(s.method + (s.m ? " m=" + std::to_string(s.m) : "") +
            (s.phi >= 0 ? " phi=" + std::to_string(s.phi) : "") + ": " + e.what());
    }
  }
  for (int n : o.n) {
    SceneParams p;
    p.n = n;
    p.density = o.density;
    p.seed = o.seed;
    try {
      (void)vadop_bench::makeScene(p);
    } catch (const std::exception& e) {
      usage(e.what());
    }
  }
}

// How many child runs the progress labels count: the reference, each method (a discrete one
// twice: its run and its evaluation pass), per n and speed.
size_t countRuns(const Options& o, const std::vector<RunSpec>& specs) {
  size_t total_runs = 0;
  for (int n : o.n) {
    for (const auto& s : specs) {
      if (s.method == "brute" && n > kBruteMaxN) continue;
      if (s.method == referenceMethod(n)) continue;
      total_runs += isDiscrete(s.method) ? 2 : 1;
    }
    ++total_runs;  // the reference
  }
  return total_runs * o.speed.size();
}

// Prints each run's line (JSON or the human table) and remembers whether any failed or missed.
class Reporter {
 public:
  explicit Reporter(bool json) : json_(json) {}
  void emit(const Json& j, int n, double speed) {
    if (json_) {
      std::printf("%s\n", j.dump().c_str());
      std::fflush(stdout);
    } else {
      printHuman(j, header_);
      header_ = false;
    }
    if (j.contains("error")) {
      std::fprintf(stderr, "vadop_bench: %s n=%d speed=%g failed: %s\n", j["method"].get<std::string>().c_str(), n,
                   speed, j["error"].get<std::string>().c_str());
      exit_code_ = 1;
    } else if (j["continuous"].get<bool>() && (j["missed"].get<size_t>() > 0 || j["extra"].get<size_t>() > 0)) {
      std::fprintf(stderr, "vadop_bench: %s n=%d speed=%g: %zu impacts missed, %zu extra (diverged at frame %ld)\n",
                   j["method"].get<std::string>().c_str(), n, speed, j["missed"].get<size_t>(),
                   j["extra"].get<size_t>(), j["diverged_frame"].get<long>());
      exit_code_ = 1;
    }
  }
  int exitCode() const { return exit_code_; }

 private:
  bool json_;
  bool header_ = true;
  int exit_code_ = 0;
};

// A new temporary file for the reference's impact log; empty when none can be created.
std::string makeReferenceLog() {
  const char* tmpdir = std::getenv("TMPDIR");
  const std::string log_template = std::string(tmpdir && *tmpdir ? tmpdir : "/tmp") + "/vadop_bench_ref_XXXXXX";
  std::vector<char> path(log_template.begin(), log_template.end());
  path.push_back('\0');
  const int fd = mkstemp(path.data());
  if (fd < 0) return "";
  close(fd);
  return std::string(path.data());
}

// One scene (n bodies at one speed): the reference, then every other method against its log.
class SceneRuns {
 public:
  SceneRuns(const Options& o, const std::vector<RunSpec>& specs, Reporter& reporter)
      : o_(o), specs_(specs), total_runs_(countRuns(o, specs)), reporter_(reporter) {}

  // False when the reference's log cannot be created.
  bool run(int n, double speed) {
    SceneParams p;
    p.n = n;
    p.density = o_.density;
    p.speed = speed;
    p.seed = o_.seed;
    const Scene scene = vadop_bench::makeScene(p);
    const std::string log_path = makeReferenceLog();
    if (log_path.empty()) {
      std::fprintf(stderr, "vadop_bench: cannot create a temporary file\n");
      return false;
    }
    const RunSpec ref{referenceMethod(n)};
    const Json ref_json = runInChild(o_, scene, ref, ChildRole::kReference, log_path, label(ref, " (reference)", n, speed));
    if (ref_json.contains("error")) {
      reporter_.emit(ref_json, n, speed);
      std::remove(log_path.c_str());
      return true;
    }
    // The reference is printed only if it was asked for (brute force, or the grid).
    if (std::find(o_.methods.begin(), o_.methods.end(), ref.method) != o_.methods.end()) {
      reporter_.emit(ref_json, n, speed);
    }
    for (const auto& s : specs_) {
      if (s.method == ref.method) continue;
      if (s.method == "brute" && n > kBruteMaxN) continue;
      reporter_.emit(runMethodInChildren(scene, s, log_path, n, speed), n, speed);
    }
    std::remove(log_path.c_str());
    return true;
  }

 private:
  std::string label(const RunSpec& s, const char* suffix, int n, double speed) {
    std::ostringstream os;
    os << "[" << ++run_index_ << "/" << total_runs_ << "] " << s.method;
    if (isVadop(s.method) || s.method == "kdop") os << " m=" << s.m;
    os << suffix << " n=" << n << " speed=" << speed;
    return os.str();
  }

  // A method's line; a discrete method's misses come from a second child, its evaluation pass.
  Json runMethodInChildren(const Scene& scene, const RunSpec& s, const std::string& log_path, int n, double speed) {
    Json j = runInChild(o_, scene, s, ChildRole::kMethod, log_path, label(s, "", n, speed));
    if (isDiscrete(s.method) && !j.contains("error")) {
      const Json e = runInChild(o_, scene, s, ChildRole::kDiscreteEval, log_path, label(s, " (miss count)", n, speed));
      if (e.contains("error")) {
        j = e;
      } else {
        j["missed"] = e["missed"];
        j["extra"] = nullptr;
        j["reference_impacts"] = e["reference_impacts"];
        j["frames_evaluated"] = e["frames"];
      }
    }
    return j;
  }

  const Options& o_;
  const std::vector<RunSpec>& specs_;
  const size_t total_runs_;
  size_t run_index_ = 0;
  Reporter& reporter_;
};

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const std::vector<RunSpec> specs = expandSpecs(o);
  validateConfigurations(o, specs);
  Reporter reporter(o.json);
  SceneRuns runs(o, specs, reporter);
  for (int n : o.n) {
    if (std::find(o.methods.begin(), o.methods.end(), "brute") != o.methods.end() && n > kBruteMaxN) {
      std::fprintf(stderr, "vadop_bench: brute force skipped at n = %d (> %d); the reference there is the grid\n", n,
                   kBruteMaxN);
    }
    for (double speed : o.speed) {
      if (!runs.run(n, speed)) return 1;
    }
  }
  return reporter.exitCode();
}
