// Random scenes for the World / vadop_predict tests: mixed shapes (every type), moving and
// rotating bodies, dense enough for hundreds of contacts among 1,000 bodies. Written as the
// JSON text vadop_predict reads, so the same scene feeds the World API and the tool.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

namespace vadop {
namespace testing_scene {

struct GenParams {
  int n = 1000;
  double box = 12.0;           // positions in [-box, box]^3
  double max_speed = 4.0;      // m/s
  double rotating_fraction = 0.3;
  double static_fraction = 0.2;
  double horizon = 1.0;
  // Bodies on a timed path of 2 to 4 keyframes over the window (instead of a constant twist).
  double path_fraction = 0.0;
};

inline std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

inline std::string vec(double x, double y, double z) { return "[" + num(x) + "," + num(y) + "," + num(z) + "]"; }

// A scene as JSON text. Ids are "b<index>" (some with a suffix, so that ids are not in
// lexicographic order of the input).
inline std::string randomSceneJson(uint64_t seed, const GenParams& p = {}) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::uniform_real_distribution<double> pos(-p.box, p.box);
  std::normal_distribution<double> g(0.0, 1.0);
  auto size = [&] { return 0.2 + 0.8 * u01(rng); };
  std::string s = "{\"horizon\": " + num(p.horizon) + ", \"bodies\": [\n";
  for (int i = 0; i < p.n; ++i) {
    std::string shape;
    switch (std::uniform_int_distribution<int>(0, 5)(rng)) {
      case 0: shape = "{\"type\":\"sphere\",\"radius\":" + num(size()) + "}"; break;
      case 1: shape = "{\"type\":\"box\",\"size\":" + vec(size(), size(), size()) + "}"; break;
      case 2: shape = "{\"type\":\"cylinder\",\"radius\":" + num(0.5 * size()) + ",\"length\":" + num(size()) + "}"; break;
      case 3: shape = "{\"type\":\"capsule\",\"radius\":" + num(0.4 * size()) + ",\"length\":" + num(size()) + "}"; break;
      case 4: {
        shape = "{\"type\":\"convex\",\"points\":[";
        const double r = size();
        for (int k = 0; k < 8; ++k) {
          shape += (k ? "," : "") + vec(r * (2 * u01(rng) - 1), r * (2 * u01(rng) - 1), r * (2 * u01(rng) - 1));
        }
        shape += "]}";
        break;
      }
      default: {  // an octahedron surface as a triangle mesh
        const double r = size();
        shape = "{\"type\":\"mesh\",\"vertices\":[" + vec(r, 0, 0) + "," + vec(-r, 0, 0) + "," + vec(0, r, 0) + "," +
                vec(0, -r, 0) + "," + vec(0, 0, r) + "," + vec(0, 0, -r) +
                "],\"triangles\":[[0,2,4],[2,1,4],[1,3,4],[3,0,4],[2,0,5],[1,2,5],[3,1,5],[0,3,5]]}";
        break;
      }
    }
    std::string body = "{\"id\":\"b" + std::to_string(i) + (i % 7 == 3 ? "_x" : "") + "\",\"shape\":" + shape;
    if (p.path_fraction > 0.0 && u01(rng) < p.path_fraction) {
      const int keys = 2 + static_cast<int>(rng() % 3);
      body += ",\"path\":[";
      for (int k = 0; k < keys; ++k) {
        const double t = p.horizon * (k - 0.3 + 0.5 * u01(rng)) / (keys - 1);
        body += std::string(k ? "," : "") + "{\"t\":" + num(t) + ",\"position\":" + vec(pos(rng), pos(rng), pos(rng)) +
                ",\"orientation\":[" + num(g(rng)) + "," + num(g(rng)) + "," + num(g(rng)) + "," + num(g(rng) + 3.0) + "]}";
      }
      body += std::string("],\"after_path\":\"") + (u01(rng) < 0.5 ? "hold" : "continue") + "\"";
      s += body + "}" + (i + 1 < p.n ? ",\n" : "\n");
      continue;
    }
    body += ",\"position\":" + vec(pos(rng), pos(rng), pos(rng));
    if (u01(rng) < 0.5) {
      double q[4] = {g(rng), g(rng), g(rng), g(rng)};
      body += ",\"orientation\":[" + num(q[0]) + "," + num(q[1]) + "," + num(q[2]) + "," + num(q[3]) + "]";
    }
    if (u01(rng) >= p.static_fraction) {
      const double speed = p.max_speed * u01(rng);
      const double x = g(rng), y = g(rng), z = g(rng);
      const double len = std::sqrt(x * x + y * y + z * z) + 1e-12;
      body += ",\"linear_velocity\":" + vec(speed * x / len, speed * y / len, speed * z / len);
    }
    if (u01(rng) < p.rotating_fraction) body += ",\"angular_velocity\":" + vec(2 * g(rng), 2 * g(rng), 2 * g(rng));
    s += body + "}" + (i + 1 < p.n ? ",\n" : "\n");
  }
  return s + "]}\n";
}

}  // namespace testing_scene
}  // namespace vadop
