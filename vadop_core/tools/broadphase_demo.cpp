// vadop_broadphase_demo: spheres flying in a box with reflecting walls, the scene of the
// VADOP paper. Runs the broad phases side by side on the same paths and prints, per method,
// the median time per frame, candidate pairs per frame, peak memory, and whether every pair
// whose swept spheres truly intersect was a candidate (checked against the exact brute force
// when n is small enough). Not the benchmark (that is vadop_bench): a look at the broad phase.
#include "vadop/broad_phase.h"
#include "vadop/error.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Options {
  int n = 3000;
  int frames = 60;
  double speed = 1.0;      // radii per frame
  double density = 0.01;   // sphere volume / box volume
  int axes = 32;
  double phi_deg = 25.0;
  std::string methods = "vadop,vadop_sap,sap,kdop,brute";
  uint64_t seed = 1;
  double static_fraction = 0.0;  // share of bodies standing still (parked robots, furniture)
  std::string slow_rule = "zone";
};

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr,
               "error: %s\n"
               "usage: vadop_broadphase_demo [--n N] [--frames F] [--speed RADII_PER_FRAME] [--density D]\n"
               "                             [--axes M] [--phi DEG] [--methods vadop,vadop_sap,sap,kdop,brute] [--seed S]\n"
               "                             [--static-fraction F] [--slow-rule zone|all]\n",
               msg);
  std::exit(2);
}

double number(const char* flag, const char* value) {
  char* end = nullptr;
  const double v = std::strtod(value, &end);
  if (end == value || *end != '\0' || !std::isfinite(v)) usage((std::string(flag) + " needs a number").c_str());
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") usage("help requested");
    if (i + 1 >= argc) usage(("missing value after " + a).c_str());
    const char* v = argv[++i];
    if (a == "--n") o.n = static_cast<int>(number("--n", v));
    else if (a == "--frames") o.frames = static_cast<int>(number("--frames", v));
    else if (a == "--speed") o.speed = number("--speed", v);
    else if (a == "--density") o.density = number("--density", v);
    else if (a == "--axes") o.axes = static_cast<int>(number("--axes", v));
    else if (a == "--phi") o.phi_deg = number("--phi", v);
    else if (a == "--methods") o.methods = v;
    else if (a == "--seed") o.seed = static_cast<uint64_t>(number("--seed", v));
    else if (a == "--static-fraction") o.static_fraction = number("--static-fraction", v);
    else if (a == "--slow-rule") o.slow_rule = v;
    else usage(("unknown option " + a).c_str());
  }
  if (o.n <= 1) usage("--n must be >= 2");
  if (o.frames <= 0) usage("--frames must be > 0");
  if (o.speed < 0) usage("--speed must be >= 0");
  if (!(o.density > 0 && o.density <= 0.5)) usage("--density must be in (0, 0.5]");
  if (!(o.static_fraction >= 0 && o.static_fraction <= 1)) usage("--static-fraction must be in [0, 1]");
  if (o.slow_rule != "zone" && o.slow_rule != "all") usage("--slow-rule must be zone or all");
  return o;
}

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

}  // namespace

namespace {

// Spheres of `radius` at random places in the box of half-side `half`, each moving o.speed
// radii per frame in a random direction (o.static_fraction of them at rest).
std::vector<vadop::Motion> makeMotions(const Options& o, double radius, double fps, double half) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> pos(-half + radius, half - radius);
  std::normal_distribution<double> g;
  std::vector<vadop::Motion> motions(o.n);
  for (auto& m : motions) {
    Eigen::Vector3d v(g(rng), g(rng), g(rng));
    v = v.normalized() * o.speed * radius * fps;
    if (std::uniform_real_distribution<double>(0, 1)(rng) < o.static_fraction) v.setZero();
    m = vadop::makeMotion(Eigen::Vector3d(pos(rng), pos(rng), pos(rng)), Eigen::Quaterniond::Identity(), v,
                          Eigen::Vector3d::Zero(), 0.0);
  }
  return motions;
}

// The --methods list; false (with the error printed) on an unknown name.
bool parseMethods(const std::string& methods, std::vector<std::string>& wanted) {
  std::stringstream ss(methods);
  for (std::string w; std::getline(ss, w, ',');) {
    if (w != "brute" && w != "vadop" && w != "vadop_sap" && w != "sap" && w != "kdop") {
      std::fprintf(stderr, "error: unknown method '%s' (vadop, vadop_sap, sap, kdop, brute)\n", w.c_str());
      return false;
    }
    wanted.push_back(w);
  }
  return true;
}

// Throws vadop::InvalidArgument on a bad configuration.
std::unique_ptr<vadop::BroadPhase> makeBroadPhase(const std::string& name, const Options& o) {
  if (name == "brute") return std::make_unique<vadop::BruteForceBroadPhase>();
  if (name == "vadop" || name == "vadop_sap") {
    vadop::VadopConfig c;
    c.axes = o.axes;
    c.phi_deg = o.phi_deg;
    c.slow_rule = o.slow_rule == "all" ? vadop::SlowAxisRule::kAllAxes : vadop::SlowAxisRule::kFixedZone;
    if (name == "vadop") return std::make_unique<vadop::VadopGridBroadPhase>(c);
    return std::make_unique<vadop::SweepPruneBroadPhase>(c);
  }
  if (name == "sap") return vadop::SweepPruneBroadPhase::makeEveryAxis(3);
  return vadop::SweepPruneBroadPhase::makeEveryAxis(o.axes);
}

// Reflects the spheres off the walls at a frame boundary (a velocity change, as after a response).
void bounceOffWalls(std::vector<vadop::Motion>& m, vadop::BroadPhase& bp, double t0, double half, double radius) {
  for (size_t i = 0; i < m.size(); ++i) {
    const Eigen::Vector3d p = m[i].positionAt(t0);
    Eigen::Vector3d v = m[i].linear_velocity;
    bool bounce = false;
    for (int k = 0; k < 3; ++k) {
      if ((p[k] > half - radius && v[k] > 0) || (p[k] < -half + radius && v[k] < 0)) {
        v[k] = -v[k];
        bounce = true;
      }
    }
    if (bounce) {
      m[i] = vadop::makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero(), t0);
      bp.setMotion(static_cast<vadop::BodyId>(i), m[i]);
    }
  }
}

// One method's frames: times, counters, and whether it found every pair brute force found.
struct MethodFigures {
  std::vector<double> ms;
  size_t candidates = 0, swaps = 0, tests = 0;
  bool complete = true;
};

// Runs the frames with `bp`; brute force fills `truth`, the others are checked against it.
MethodFigures runFrames(const Options& o, const std::string& name, vadop::BroadPhase& bp,
                        std::vector<vadop::Motion> m, double dt, double half, double radius,
                        std::vector<std::vector<vadop::Pair>>& truth) {
  MethodFigures out;
  for (int f = 0; f < o.frames; ++f) {
    const double t0 = f * dt;
    bounceOffWalls(m, bp, t0, half, radius);
    const auto start = std::chrono::steady_clock::now();
    bp.update(t0, t0 + dt);
    out.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    out.candidates += bp.pairs().size();
    if (const auto* sp = dynamic_cast<const vadop::SweepPruneBroadPhase*>(&bp)) {
      out.swaps += sp->stats().swaps;
      out.tests += sp->stats().overlap_tests;
    }
    if (name == "brute") {
      truth.push_back(bp.pairs());
    } else if (!truth.empty()) {
      for (const auto& p : truth[f]) {
        if (!std::binary_search(bp.pairs().begin(), bp.pairs().end(), p)) out.complete = false;
      }
    }
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const double radius = 1.0, fps = 30.0, dt = 1.0 / fps;
  const double volume = o.n * 4.0 / 3.0 * M_PI * radius * radius * radius / o.density;
  const double half = 0.5 * std::cbrt(volume);

  // The paths: positions and velocities per frame, the same for every method.
  const std::vector<vadop::Motion> motions = makeMotions(o, radius, fps, half);

  std::printf("%d spheres of radius %.1f in a box of side %.1f (density %.3f), %.2f radii/frame, %d frames\n", o.n,
              radius, 2 * half, o.density, o.speed, o.frames);
  std::printf("%-9s %10s %10s %14s %12s %12s %10s %s\n", "method", "median ms", "max ms", "candidates/fr", "swaps/fr",
              "tests/fr", "memory MB", "complete");

  const auto sphere = std::make_shared<const vadop::Shape>(vadop::makeSphere(radius));
  std::vector<std::vector<vadop::Pair>> truth;  // exact swept-sphere pairs, from brute force
  // Brute force first, so the others can be checked against it.
  std::vector<std::string> wanted;
  if (!parseMethods(o.methods, wanted)) return 2;
  for (const char* name : {"brute", "vadop", "vadop_sap", "sap", "kdop"}) {
    if (std::find(wanted.begin(), wanted.end(), name) == wanted.end()) continue;
    if (std::string(name) == "brute" && o.n > 5000) {
      std::printf("%-9s skipped (n > 5000)\n", name);
      continue;
    }
    std::unique_ptr<vadop::BroadPhase> bp;
    try {
      bp = makeBroadPhase(name, o);
    } catch (const vadop::InvalidArgument& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 2;
    }
    for (const auto& mo : motions) bp->add(sphere, mo);
    const MethodFigures r = runFrames(o, name, *bp, motions, dt, half, radius, truth);
    std::vector<double> sorted = r.ms;
    std::sort(sorted.begin(), sorted.end());
    std::printf("%-9s %10.3f %10.3f %14.1f %12.0f %12.0f %10.1f %s\n", name, sorted[sorted.size() / 2], sorted.back(),
                static_cast<double>(r.candidates) / o.frames, static_cast<double>(r.swaps) / o.frames,
                static_cast<double>(r.tests) / o.frames, bp->memoryBytes() / 1048576.0,
                std::string(name) == "brute" ? "(reference)" : truth.empty() ? "not checked" : r.complete ? "yes" : "NO");
    if (!r.complete) return 1;
  }
  std::printf("peak RSS of the process: %.1f MB\n", peakRssMb());
  return 0;
}
