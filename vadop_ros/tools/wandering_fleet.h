// The synthetic load of the monitor's benchmarks (vadop_monitor_bench, vadop_gate_latency): a
// planar fleet of unicycles wandering a square room, `area` m^2 of floor per body, at 0.3 to
// 1.5 m/s, each drawing a new turn rate in [-turn, turn] about every 3 s and bouncing off the
// walls like a mirror. Not a traffic model: bodies pass through each other. Options: a share of
// fast bodies (speeds times `fast_factor`), and 3D motion (drones: each also climbs or sinks at
// up to 0.5 m/s between the floor and `ceiling`, bouncing there).
#pragma once

#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

namespace vadop_ros {

class WanderingFleet {
 public:
  struct Body {
    double x = 0, y = 0, yaw = 0;  // m, rad
    double v = 0, w = 0;           // m/s, rad/s (body frame: forward, turn)
    double z = 0, vz = 0;          // m, m/s (3D only)
  };

  WanderingFleet(size_t n, double area, double turn, std::mt19937& rng, double fast_share = 0.0,
                 double fast_factor = 5.0, double ceiling = 0.0)
      : half_(0.5 * std::sqrt(area * static_cast<double>(n))), turn_(turn), ceiling_(ceiling), bodies_(n) {
    for (Body& s : bodies_) {
      s.x = (2 * u_(rng) - 1) * (half_ - 0.5);
      s.y = (2 * u_(rng) - 1) * (half_ - 0.5);
      s.yaw = (2 * u_(rng) - 1) * M_PI;
      s.v = 0.3 + 1.2 * u_(rng);
      s.w = (2 * u_(rng) - 1) * turn_;
      if (u_(rng) < fast_share) s.v *= fast_factor;
      if (ceiling_ > 0.0) {
        s.z = ceiling_ * u_(rng);
        s.vz = (2 * u_(rng) - 1) * 0.5;
      }
    }
  }

  void step(double dt, std::mt19937& rng) {
    for (Body& s : bodies_) {
      if (u_(rng) < dt / 3.0) s.w = (2 * u_(rng) - 1) * turn_;
      s.yaw += s.w * dt;
      s.x += s.v * std::cos(s.yaw) * dt;
      s.y += s.v * std::sin(s.yaw) * dt;
      if (std::fabs(s.x) > half_) {
        s.x = std::copysign(half_, s.x);
        s.yaw = M_PI - s.yaw;
      }
      if (std::fabs(s.y) > half_) {
        s.y = std::copysign(half_, s.y);
        s.yaw = -s.yaw;
      }
      if (ceiling_ > 0.0) {
        s.z += s.vz * dt;
        if (s.z < 0.0 || s.z > ceiling_) {
          s.z = std::min(std::max(s.z, 0.0), ceiling_);
          s.vz = -s.vz;
        }
      }
    }
  }

  const std::vector<Body>& bodies() const { return bodies_; }
  const Body& operator[](size_t i) const { return bodies_[i]; }
  size_t size() const { return bodies_.size(); }
  double halfWidth() const { return half_; }

 private:
  double half_, turn_, ceiling_;
  std::vector<Body> bodies_;
  std::uniform_real_distribution<double> u_{0.0, 1.0};
};

}  // namespace vadop_ros
