// FleetDriver: the wandering fleet (wandering_fleet.h) published through ROS transport, for
// measuring and testing vadop_monitor as users feed it; the node vadop_fleet_driver and the
// nodelet vadop/FleetDriverNodelet both run it (fleet_driver.cpp says what it publishes and
// reads). It does not subscribe to anything and knows nothing of the monitor.
#pragma once

#include "fleet_sensors.h"
#include "wandering_fleet.h"

#include <vadop/BodyStateArray.h>

#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <atomic>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace vadop_ros {

struct FleetDriverSettings {
  int n = 1000;
  double rate = 30.0;  // Hz of wall time: states this often
  std::string mode = "array";
  std::string states_topic = "/fleet/states";
  int seed = 1;
  double area = 6.0;                // m^2 of floor per robot
  double clock_step = 0.0;          // s; > 0: the driver's own simulated clock, on /clock
  int wait_subscribers = 0;         // before the first state: this many subscribers of the states
  bool sensors = false;             // also the bench's laser scan (/scan, 15 Hz) and cloud (/points, 10 Hz)
  int xmlrpc_backlog = 0;           // > 0: this process's XML-RPC server listens with this backlog (roscpp's: 5)
  static constexpr double kClockStart = 100.0;  // s, the simulated clock's first time

  // The private parameters; throws std::invalid_argument naming the one out of range.
  static FleetDriverSettings read(const ros::NodeHandle& pnh);
};

class FleetDriver {
 public:
  FleetDriver(ros::NodeHandle& nh, const FleetDriverSettings& s);
  // Publishes until ROS shuts down or stop() is called (from another thread).
  void run();
  void stop() { stop_ = true; }
  std::string describe() const;

 private:
  // The fleet stepped by `dt` and published, stamped `stamp`: new messages each time, published
  // as shared pointers (a subscriber in the same process gets them without serialization, and
  // may keep them: the driver never writes a message it has published).
  void tick(double dt, const ros::Time& stamp);
  // Until the states (and with a clock, /clock) have wait_subscribers subscribers; false when
  // stopped first.
  bool waitForSubscribers();
  void runRealTime();
  void runSimulatedClock();
  bool running() const { return ros::ok() && !stop_; }

  FleetDriverSettings s_;
  std::mt19937 rng_;
  WanderingFleet fleet_;
  std::vector<ros::Publisher> odom_;
  ros::Publisher array_, clock_;
  // ~sensors: what a laser and a depth sensor at the room's centre see, published when due.
  void publishSensors(const ros::Time& stamp);
  FleetSensors sensors_;
  ros::Publisher scan_, cloud_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> laser_tf_;  // "laser" in "odom"
  ros::Time next_scan_, next_cloud_;
  std::mt19937 cloud_rng_;  // the cloud's own: the fleet's sequence is the same without sensors
  vadop::BodyStateArray names_;  // the entries' names, copied into each published array
  std::atomic<bool> stop_{false};
};

}  // namespace vadop_ros
