// What a laser and a depth sensor at the centre of the wandering fleet's room see (the bench's
// --scan and --cloud): a planar LaserScan ray-cast against the room's walls and the bodies,
// each body taken as a vertical cylinder of radius kBodyRadius, within every bench shape
// (cheap: each body fills only the beams its circle spans), and a PointCloud2 of points on the
// floor, the walls and the bodies (the same circles). Both in the frame "laser", kLaserHeight m
// above the fixed frame's origin (the room's centre), unrotated. It does not model occlusion in the cloud, noise or
// the bodies' true shapes: it is a workload of the right size and spread, not a sensor model.
#pragma once

#include "wandering_fleet.h"

#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace vadop_ros {

class FleetSensors {
 public:
  // m: within every bench shape (sphere 0.3, box 0.6 x 0.4, cylinder 0.3, capsule 0.2) in the
  // laser's plane and the cloud's band, so the filter drops a body's points with any margin:
  // self_margin too, which gated bodies are filtered with by every sensor.
  static constexpr double kBodyRadius = 0.2;
  static constexpr double kLaserHeight = 0.1;  // m: the scan's plane cuts every body
  static constexpr double kFloorZ = -0.5;      // m: below every body (the cloud's min_z drops it)
  static constexpr double kWallHeight = 2.0;   // m

  // A 270-degree scan of `beams` beams.
  explicit FleetSensors(size_t beams = 1081) : beams_(beams) {
    scan_.header.frame_id = "laser";
    scan_.angle_min = static_cast<float>(-0.75 * M_PI);
    scan_.angle_increment = static_cast<float>(1.5 * M_PI / static_cast<double>(beams - 1));
    scan_.angle_max = scan_.angle_min + static_cast<float>(beams - 1) * scan_.angle_increment;
    scan_.range_min = 0.05f;
    scan_.range_max = 100.0f;
    scan_.ranges.resize(beams);
  }

  // The scan of the fleet as it is, stamped `stamp`.
  const sensor_msgs::LaserScan& scan(const WanderingFleet& fleet, const ros::Time& stamp) {
    scan_.header.stamp = stamp;
    const double h = fleet.halfWidth(), inc = scan_.angle_increment, a0 = scan_.angle_min;
    for (size_t i = 0; i < beams_; ++i) {  // the walls
      const double a = a0 + static_cast<double>(i) * inc;
      scan_.ranges[i] = static_cast<float>(std::min(h / std::max(std::fabs(std::cos(a)), 1e-9),
                                                    h / std::max(std::fabs(std::sin(a)), 1e-9)));
    }
    const long full = std::lround(2 * M_PI / inc);  // beams in a full turn
    for (const WanderingFleet::Body& b : fleet.bodies()) {
      const double d = std::hypot(b.x, b.y), r = kBodyRadius;
      if (d <= r) continue;  // the laser inside a body: it sees out of it
      const double theta = std::atan2(b.y, b.x), half = std::asin(r / d);
      for (long j = static_cast<long>(std::ceil((theta - half - a0) / inc));
           j <= static_cast<long>(std::floor((theta + half - a0) / inc)); ++j) {
        const long i = ((j % full) + full) % full;
        if (i >= static_cast<long>(beams_)) continue;
        const double delta = a0 + static_cast<double>(j) * inc - theta, s = d * std::sin(delta);
        const double range = d * std::cos(delta) - std::sqrt(std::max(0.0, r * r - s * s));
        scan_.ranges[i] = std::min(scan_.ranges[i], static_cast<float>(range));
      }
    }
    return scan_;
  }

  // `count` points stamped `stamp`: a third on the floor, a third on the walls, a third on the
  // bodies (spread evenly over them, at heights up to 0.2 m).
  const sensor_msgs::PointCloud2& cloud(const WanderingFleet& fleet, const ros::Time& stamp, size_t count,
                                        std::mt19937& rng) {
    cloud_.header.frame_id = "laser";
    cloud_.header.stamp = stamp;
    sensor_msgs::PointCloud2Modifier mod(cloud_);
    mod.setPointCloud2FieldsByString(1, "xyz");
    mod.resize(count);
    sensor_msgs::PointCloud2Iterator<float> x(cloud_, "x"), y(cloud_, "y"), z(cloud_, "z");
    const double h = fleet.halfWidth();
    const size_t n = fleet.bodies().size();
    for (size_t k = 0; k < count; ++k, ++x, ++y, ++z) {
      double px = 0, py = 0, pz = 0;
      const size_t part = 3 * k / count;
      if (part == 0 || n == 0) {  // the floor
        px = h * (2 * u_(rng) - 1), py = h * (2 * u_(rng) - 1), pz = kFloorZ;
      } else if (part == 1) {  // a wall
        const double along = h * (2 * u_(rng) - 1), side = (k % 2 == 0) ? h : -h;
        px = (k % 4 < 2) ? side : along, py = (k % 4 < 2) ? along : side, pz = kWallHeight * u_(rng) - 0.25;
      } else {  // a body
        const WanderingFleet::Body& b = fleet[k % n];
        const double a = 2 * M_PI * u_(rng);
        px = b.x + kBodyRadius * std::cos(a), py = b.y + kBodyRadius * std::sin(a), pz = b.z + 0.2 * u_(rng);
      }
      *x = static_cast<float>(px);
      *y = static_cast<float>(py);
      *z = static_cast<float>(pz - kLaserHeight);
    }
    return cloud_;
  }

 private:
  size_t beams_;
  sensor_msgs::LaserScan scan_;
  sensor_msgs::PointCloud2 cloud_;
  std::uniform_real_distribution<double> u_{0.0, 1.0};
};

}  // namespace vadop_ros
