// What a sensor's points cost the monitor (issue 49): a point set (makePointSet) as one static
// body among a fleet, rebuilt on every message.
//  build:   makePointSet + World::add (the mesh's sphere tree) + World::remove of the previous
//           set, for a 1,081-beam scan and clouds of 5,000 and 30,000 points;
//  predict: World::predict (2 s, the node's 8 time slices, 1 thread) of 1,000 wandering bodies
//           (the monitor bench's fleet: 6 m^2 each, 0.3 to 1.5 m/s) alone, with a scan around
//           one robot, with a depth camera's cloud in front of another (30,000 points, raw or
//           voxel-filtered at 5 cm), and with both;
//  gate:    World::firstContactAlong of that robot on a gate's manoeuvre (the command held
//           0.1 s + 0.3 s, then braking at 1 m/s^2: appendKeyframes, appendBrakingKeyframes
//           within 1 mm), with and without the sensors.
// Configurations interleaved within each round; prints the median and the range over rounds of
// each round's mean (thread CPU time). Not a test: a plain program.
// Run: vadop_point_set_bench [rounds, default 5] [cycles per round, default 20]
#include "vadop/shapes.h"
#include "vadop/timed_path.h"
#include "vadop/world.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

namespace {

using Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Series {
  std::string name;
  std::vector<double> ms;  // one mean per round
  void print() const {
    std::vector<double> s = ms;
    std::sort(s.begin(), s.end());
    std::printf("  %-44s median %8.3f ms  (%.3f .. %.3f)\n", name.c_str(), s[s.size() / 2], s.front(), s.back());
  }
};

// The monitor bench's fleet: unicycles in a square room, 6 m^2 each, new turn rates now and then.
struct Fleet {
  struct Body {
    double x, y, yaw, v, w;
  };
  std::vector<Body> bodies;
  double half;
  std::mt19937 rng{7};
  std::uniform_real_distribution<double> u{0.0, 1.0};
  explicit Fleet(size_t n) : half(0.5 * std::sqrt(6.0 * static_cast<double>(n))) {
    for (size_t i = 0; i < n; ++i) {
      bodies.push_back({(2 * u(rng) - 1) * (half - 0.5), (2 * u(rng) - 1) * (half - 0.5), (2 * u(rng) - 1) * kPi,
                        0.3 + 1.2 * u(rng), (2 * u(rng) - 1) * 0.5});
    }
  }
  void step(double dt) {
    for (Body& b : bodies) {
      if (u(rng) < dt / 3.0) b.w = (2 * u(rng) - 1) * 0.5;
      b.yaw += b.w * dt;
      b.x = std::clamp(b.x + b.v * std::cos(b.yaw) * dt, -half, half);
      b.y = std::clamp(b.y + b.v * std::sin(b.yaw) * dt, -half, half);
    }
  }
  // A vehicle's arc: the screw about the turn's axis.
  vadop::Motion motion(size_t i, double t, double scale = 1.0) const {
    const Body& b = bodies[i];
    const Vector3d v = scale * Vector3d(b.v * std::cos(b.yaw), b.v * std::sin(b.yaw), 0.0), w(0.0, 0.0, scale * b.w);
    vadop::Motion m = vadop::makeMotion(Vector3d(b.x, b.y, 0.25),
                                        Eigen::Quaterniond(Eigen::AngleAxisd(b.yaw, Vector3d::UnitZ())), v, w, t);
    m.pivot_offset = vadop::screwPivotOffset(v, w);
    m.linear_velocity = vadop::screwPivotVelocity(v, w);
    return m;
  }
};

// A 270-degree scan of 1,081 beams from `at`, 0.3 m up: walls 0.9 to 5.1 m away.
std::vector<Vector3d> scan(const Vector3d& at) {
  std::vector<Vector3d> out;
  for (int i = 0; i < 1081; ++i) {
    const double th = -0.75 * kPi + 1.5 * kPi * i / 1080.0;
    const double range = 3.0 + 1.8 * std::sin(2.0 * th) + 0.3 * std::sin(9.0 * th);
    out.push_back(at + Vector3d(range * std::cos(th), range * std::sin(th), 0.3));
  }
  return out;
}

// A depth camera's 30,000 points in front of `at` (along +x): a wall 3 m away (4 m x 2 m), a
// box (1 m) at 1.5 m, with 1 cm of noise.
std::vector<Vector3d> cloud(const Vector3d& at, size_t n) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Vector3d> out;
  while (out.size() < n) {
    Vector3d p;
    if (u(rng) < 0.7) {
      p = Vector3d(3.0, 4.0 * u(rng) - 2.0, 2.0 * u(rng));
    } else {  // the box's front and top faces
      p = u(rng) < 0.5 ? Vector3d(1.5, u(rng) - 0.5, u(rng)) : Vector3d(1.5 + u(rng), u(rng) - 0.5, 1.0);
    }
    out.push_back(at + p + Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  return out;
}

// At most one point per voxel (the first).
std::vector<Vector3d> voxelFilter(const std::vector<Vector3d>& points, double voxel) {
  std::unordered_set<long long> seen;
  std::vector<Vector3d> out;
  for (const Vector3d& p : points) {
    const long long i = static_cast<long long>(std::floor(p.x() / voxel)) & 0x1fffff;
    const long long j = static_cast<long long>(std::floor(p.y() / voxel)) & 0x1fffff;
    const long long k = static_cast<long long>(std::floor(p.z() / voxel)) & 0x1fffff;
    if (seen.insert((i << 42) | (j << 21) | k).second) out.push_back(p);
  }
  return out;
}

// The sensor's body as the node makes it: its points about their centroid, posed there, at rest.
struct SensorBody {
  vadop::Shape shape;
  vadop::Motion motion;
};

SensorBody sensorBody(const std::vector<Vector3d>& points) {
  Vector3d c = Vector3d::Zero();
  for (const Vector3d& p : points) c += p;
  c /= static_cast<double>(points.size());
  std::vector<Vector3d> rel;
  rel.reserve(points.size());
  for (const Vector3d& p : points) rel.push_back(p - c);
  return {vadop::makePointSet(std::move(rel), 0.02),
          vadop::makeMotion(c, Eigen::Quaterniond::Identity(), Vector3d::Zero(), Vector3d::Zero())};
}

// The gate's manoeuvre of a body moving with m at t: held 0.1 s + 0.3 s, braking at 1 m/s^2.
vadop::TimedPath manoeuvre(const vadop::Motion& m, double t, double radius, double* deviation) {
  std::vector<vadop::Keyframe> keys;
  vadop::appendKeyframes(m, t, t + 0.4, keys);
  *deviation = vadop::appendBrakingKeyframes(m, t + 0.4, vadop::originSpeed(m) / 1.0, radius, 1e-3, keys);
  return vadop::TimedPath(keys, vadop::AfterPath::kHold);
}


// A sensor body replaced (remove + makePointSet + add) for each size of point set.
void timeRebuilds(const std::vector<Vector3d>& scan_points, const std::vector<Vector3d>& filtered,
                  const std::vector<Vector3d>& raw, int rounds, int cycles) {
  std::vector<Series> series;
  const std::vector<std::pair<std::string, const std::vector<Vector3d>*>> sets = {
      {"scan 1,081", &scan_points}, {"cloud 5 cm voxels", &filtered}, {"cloud 30,000 raw", &raw}};
  std::vector<Vector3d> five(raw.begin(), raw.begin() + 5000);
  series.resize(sets.size() + 1);
  for (size_t k = 0; k < sets.size(); ++k) series[k].name = "build " + sets[k].first;
  series.back().name = "build cloud 5,000 (first of the raw)";
  vadop::World world;
  world.add("sensor", vadop::makeSphere(1.0), vadop::Motion());
  for (int r = 0; r < rounds; ++r) {
    for (size_t k = 0; k <= sets.size(); ++k) {
      const std::vector<Vector3d>& pts = k < sets.size() ? *sets[k].second : five;
      const double t0 = cpuSeconds();
      for (int c = 0; c < cycles; ++c) {
        world.remove("sensor");
        const SensorBody b = sensorBody(pts);
        world.add("sensor", b.shape, b.motion);
      }
      series[k].ms.push_back(1e3 * (cpuSeconds() - t0) / cycles);
    }
  }
  std::printf("sensor body replaced (makePointSet + World::add + remove), %d rounds x %d:\n", rounds, cycles);
  for (const Series& s : series) s.print();
}

// The worlds stepped together: the fleet alone, with a scan, a voxelised cloud, both, a raw cloud.
struct Config {
  std::string name;
  bool scan, cloud, raw;
};

std::vector<std::unique_ptr<vadop::World>> makeWorlds(const std::vector<Config>& configs, const Fleet& fleet,
                                                      const vadop::Shape& robot, const std::vector<Vector3d>& scan_points,
                                                      const std::vector<Vector3d>& filtered,
                                                      const std::vector<Vector3d>& raw) {
  std::vector<std::unique_ptr<vadop::World>> worlds;
  for (const Config& c : configs) {
    worlds.push_back(std::make_unique<vadop::World>());
    vadop::World& w = *worlds.back();
    for (size_t i = 0; i < fleet.bodies.size(); ++i) w.add("r" + std::to_string(i), robot, fleet.motion(i, 0.0));
    if (c.scan) {
      const SensorBody b = sensorBody(scan_points);
      w.add("scan", b.shape, b.motion);
    }
    if (c.cloud || c.raw) {
      const SensorBody b = sensorBody(c.raw ? raw : filtered);
      w.add("cloud", b.shape, b.motion);
    }
  }
  return worlds;
}

// The gate of robot 0 (in the scan): 20 candidate commands, as a scale search's worst case; the
// commands that meet a contact are counted in `hits`. Returns the CPU seconds per command.
double timeGate(vadop::World& w, const Fleet& fleet, const vadop::Shape& robot, double t, size_t& hits) {
  const double t0 = cpuSeconds();
  for (int s = 1; s <= 20; ++s) {
    const vadop::Motion m = fleet.motion(0, t, s / 20.0);
    double deviation = 0.0;
    const vadop::TimedPath path = manoeuvre(m, t, robot.bounding_radius, &deviation);
    vadop::World::PathQuery q;
    q.deviation = deviation;
    if (w.firstContactAlong({"r0"}, {path}, t, 0.4 + vadop::originSpeed(m) + 0.1, q)) ++hits;
  }
  return (cpuSeconds() - t0) / 20.0;
}

void timePredictAndGates(Fleet& fleet, const std::vector<Vector3d>& scan_points, const std::vector<Vector3d>& filtered,
                         const std::vector<Vector3d>& raw, int rounds, int cycles) {
  const std::vector<Config> configs = {{"fleet only", false, false, false},
                                       {"fleet + scan", true, false, false},
                                       {"fleet + cloud (voxels)", false, true, false},
                                       {"fleet + scan + cloud (voxels)", true, true, false},
                                       {"fleet + cloud (30,000 raw)", false, false, true}};
  const vadop::Shape robot = vadop::makeBox(Vector3d(0.6, 0.4, 0.5));
  std::vector<std::unique_ptr<vadop::World>> worlds = makeWorlds(configs, fleet, robot, scan_points, filtered, raw);
  std::vector<Series> predict(configs.size()), gate(configs.size());
  std::vector<size_t> contacts(configs.size(), 0), gate_hits(configs.size(), 0);
  for (size_t k = 0; k < configs.size(); ++k) {
    predict[k].name = "predict " + configs[k].name;
    gate[k].name = "gate (robot 0, 20 commands) " + configs[k].name;
  }
  double t = 0.0;
  const double dt = 1.0 / 30.0;
  for (int r = 0; r < rounds; ++r) {
    std::vector<double> predict_s(configs.size(), 0.0), gate_s(configs.size(), 0.0);
    for (int c = 0; c < cycles; ++c) {
      fleet.step(dt);
      t += dt;
      for (size_t k = 0; k < configs.size(); ++k) {
        vadop::World& w = *worlds[k];
        for (size_t i = 0; i < fleet.bodies.size(); ++i) w.setMotion("r" + std::to_string(i), fleet.motion(i, t));
        const double t0 = cpuSeconds();
        contacts[k] += w.predict(t, 2.0).size();
        predict_s[k] += cpuSeconds() - t0;
        gate_s[k] += timeGate(w, fleet, robot, t, gate_hits[k]);
      }
    }
    for (size_t k = 0; k < configs.size(); ++k) {
      predict[k].ms.push_back(1e3 * predict_s[k] / cycles);
      gate[k].ms.push_back(1e3 * gate_s[k] / cycles);
    }
  }
  std::printf("World::predict, 1,000 bodies, 2 s, %d rounds x %d cycles (contacts found in all):\n", rounds, cycles);
  for (size_t k = 0; k < configs.size(); ++k) {
    predict[k].print();
    std::printf("    contacts %zu\n", contacts[k]);
  }
  std::printf("World::firstContactAlong per command (gate of robot 0):\n");
  for (size_t k = 0; k < configs.size(); ++k) {
    gate[k].print();
    std::printf("    commands meeting a contact %zu\n", gate_hits[k]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const int cycles = argc > 2 ? std::max(1, std::atoi(argv[2])) : 20;
  Fleet fleet(1000);
  const Vector3d robot0(fleet.bodies[0].x, fleet.bodies[0].y, 0.0), robot1(fleet.bodies[1].x, fleet.bodies[1].y, 0.0);
  const std::vector<Vector3d> scan_points = scan(robot0);
  const std::vector<Vector3d> raw = cloud(robot1, 30000);
  const std::vector<Vector3d> filtered = voxelFilter(raw, 0.05);
  std::printf("scan %zu points, cloud %zu points, voxel-filtered (5 cm) %zu points\n", scan_points.size(), raw.size(),
              filtered.size());
  timeRebuilds(scan_points, filtered, raw, rounds, cycles);
  timePredictAndGates(fleet, scan_points, filtered, raw, rounds, cycles);
  return 0;
}
