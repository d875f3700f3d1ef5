// vadop_fleet_driver: a fleet's states through ROS transport, for measuring vadop_monitor as
// users feed it (launch/fleet_transport.launch). N robots of the benchmarks' wandering fleet
// (wandering_fleet.h: 6 m^2 of floor per robot, 0.3-1.5 m/s, bouncing off the walls) stepped
// and published at ~rate Hz, either as one nav_msgs/Odometry topic per robot
// (~mode odom: /robot_<i>/odom) or as one vadop/BodyStateArray (~mode array: ~states_topic,
// default /fleet/states, entries "robot_<i>"), in frame "odom", stamped with the time of the
// tick; every second it logs the rate it achieved. Private parameters: ~n (1000), ~rate (30),
// ~mode (array), ~states_topic, ~seed (1).
#include "wandering_fleet.h"

#include <vadop/BodyStateArray.h>

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace {

struct Settings {
  int n = 1000;
  double rate = 30.0;
  std::string mode = "array";
  std::string states_topic = "/fleet/states";
  int seed = 1;
};

// A planar robot's pose and body-frame twist into a message's fields.
template <class Pose, class Twist>
void fill(const vadop_ros::WanderingFleet::Body& s, Pose& p, Twist& t) {
  p.position.x = s.x;
  p.position.y = s.y;
  p.orientation.z = std::sin(0.5 * s.yaw);
  p.orientation.w = std::cos(0.5 * s.yaw);
  t.linear.x = s.v;
  t.angular.z = s.w;
}

class FleetDriver {
 public:
  FleetDriver(ros::NodeHandle& nh, const Settings& s)
      : s_(s), rng_(static_cast<unsigned>(s.seed)), fleet_(static_cast<size_t>(s.n), 6.0, 0.5, rng_) {
    if (s_.mode == "odom") {
      odom_.reserve(s_.n);
      for (int i = 0; i < s_.n; ++i) {
        odom_.push_back(nh.advertise<nav_msgs::Odometry>("/robot_" + std::to_string(i) + "/odom", 5));
      }
      odom_msg_.header.frame_id = "odom";
    } else {
      array_ = nh.advertise<vadop::BodyStateArray>(s_.states_topic, 2);
      array_msg_.header.frame_id = "odom";
      array_msg_.states.resize(s_.n);
      for (int i = 0; i < s_.n; ++i) array_msg_.states[i].name = "robot_" + std::to_string(i);
    }
  }

  // One tick: the fleet stepped by `dt` and published, stamped `now`.
  void tick(double dt, const ros::Time& now) {
    fleet_.step(dt, rng_);
    if (s_.mode == "odom") {
      odom_msg_.header.stamp = now;
      for (int i = 0; i < s_.n; ++i) {
        fill(fleet_[i], odom_msg_.pose.pose, odom_msg_.twist.twist);
        odom_[i].publish(odom_msg_);
      }
    } else {
      array_msg_.header.stamp = now;
      for (int i = 0; i < s_.n; ++i) fill(fleet_[i], array_msg_.states[i].pose, array_msg_.states[i].twist);
      array_.publish(array_msg_);
    }
  }

 private:
  Settings s_;
  std::mt19937 rng_;
  vadop_ros::WanderingFleet fleet_;
  std::vector<ros::Publisher> odom_;
  nav_msgs::Odometry odom_msg_;
  ros::Publisher array_;
  vadop::BodyStateArray array_msg_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vadop_fleet_driver");
  ros::NodeHandle nh, pnh("~");
  Settings s;
  pnh.param("n", s.n, s.n);
  pnh.param("rate", s.rate, s.rate);
  pnh.param("mode", s.mode, s.mode);
  pnh.param("states_topic", s.states_topic, s.states_topic);
  pnh.param("seed", s.seed, s.seed);
  if (s.n < 1 || !(s.rate > 0.0 && s.rate <= 1000.0) || (s.mode != "odom" && s.mode != "array")) {
    ROS_FATAL("vadop_fleet_driver: ~n must be >= 1, ~rate in (0, 1000] Hz and ~mode odom or array (got %d, %g, %s)",
              s.n, s.rate, s.mode.c_str());
    return 1;
  }
  FleetDriver driver(nh, s);
  ROS_INFO("vadop_fleet_driver: %d robots at %.1f Hz as %s", s.n, s.rate,
           s.mode == "odom" ? "one nav_msgs/Odometry topic each" : ("one vadop/BodyStateArray on " + s.states_topic).c_str());
  ros::Rate loop(s.rate);
  ros::WallTime window_start = ros::WallTime::now();
  int ticks = 0;
  while (ros::ok()) {
    driver.tick(1.0 / s.rate, ros::Time::now());
    ++ticks;
    const double elapsed = (ros::WallTime::now() - window_start).toSec();
    if (elapsed >= 5.0) {
      ROS_INFO("vadop_fleet_driver: %.1f ticks/s (asked %.1f)", ticks / elapsed, s.rate);
      ticks = 0;
      window_start = ros::WallTime::now();
    }
    loop.sleep();
  }
  return 0;
}
