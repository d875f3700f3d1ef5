// The fleet driver (fleet_driver.h): a fleet's states through ROS transport, for measuring and
// testing vadop_monitor as users feed it (launch/fleet_transport.launch, launch/sharded.launch).
// N robots of the benchmarks' wandering fleet (wandering_fleet.h: ~area m^2 of floor per robot,
// 0.3-1.5 m/s, bouncing off the walls of a square room centred on the origin) stepped and
// published at ~rate Hz, either as one nav_msgs/Odometry topic per robot (~mode odom:
// /robot_<i>/odom) or as one vadop/BodyStateArray (~mode array: ~states_topic, default
// /fleet/states, entries "robot_<i>"), in frame "odom", stamped with the time of the tick; every
// 5 s it logs the rate it achieved. Each message is a new one published as a shared pointer:
// in a nodelet manager (vadop/FleetDriverNodelet) a subscriber there, such as
// vadop/MonitorNodelet, gets it without serialization.
//
// ~clock_step > 0: a simulated clock for tests whose monitors must all predict from the same
// state at the same time (nodes with /use_sim_time true follow it). The driver publishes
// /clock itself, starting at 100 s, and each 1 / ~rate s of wall time: the fleet stepped by
// ~clock_step and published stamped with the clock's time t; half a period later the clock
// advances to t + ~clock_step (the monitors' timers fire then, all at that time, all with the
// state of t: nothing else is published until the next state, half a period later).
//
// Private parameters: ~n (1000, >= 1), ~rate (30, (0, 1000] Hz), ~mode (array | odom),
// ~states_topic (/fleet/states), ~seed (1), ~area (6 m^2, (0, 1e6]), ~clock_step (0 s: the ROS
// clock; at most 60), ~wait_subscribers (0: before the first state, wait until the states (each
// odometry topic) and, with a clock, /clock have this many subscribers), ~sensors (false: also
// a laser and a depth sensor at the room's centre, frame "laser" 0.1 m above "odom" (a static
// transform the driver publishes): a 1,081-beam sensor_msgs/LaserScan on /scan at 15 Hz and a
// 30,000-point sensor_msgs/PointCloud2 on /points at 10 Hz, the bench's (fleet_sensors.h)),
// ~xmlrpc_backlog (0: roscpp's; > 0, at most 65535: the listen backlog of this process's XML-RPC
// server, before the topics are advertised. roscpp listens with a backlog of 5, and one process
// publishing thousands of odometry topics receives a requestTopic call for each as a monitor
// subscribes: the kernel drops the connections beyond the backlog and each caller waits for
// TCP's SYN retransmission. A larger one shows what start-up the monitor reaches when the
// publisher is not the bottleneck; Linux takes a second listen() on a listening socket as its
// new backlog).
#include "fleet_driver.h"

#include <nav_msgs/Odometry.h>
#include <ros/xmlrpc_manager.h>
#include <rosgraph_msgs/Clock.h>

#include <dirent.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <boost/make_shared.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace vadop_ros {
namespace {

// A planar robot's pose and body-frame twist into a message's fields.
template <class Pose, class Twist>
void fill(const WanderingFleet::Body& s, Pose& p, Twist& t) {
  p.position.x = s.x;
  p.position.y = s.y;
  p.orientation.z = std::sin(0.5 * s.yaw);
  p.orientation.w = std::cos(0.5 * s.yaw);
  t.linear.x = s.v;
  t.angular.z = s.w;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

// The port `fd` listens on (TCP, IPv4 or IPv6), or -1 when it is not a listening socket.
int listeningPort(int fd) {
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISSOCK(st.st_mode)) return -1;
  int accepting = 0;
  socklen_t len = sizeof(accepting);
  if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &accepting, &len) != 0 || !accepting) return -1;
  sockaddr_storage addr{};
  len = sizeof(addr);
  if (getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return -1;
  if (addr.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(addr).sin_port);
  if (addr.ss_family == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6&>(addr).sin6_port);
  return -1;
}

// ~xmlrpc_backlog: the backlog of the socket listening on this process's XML-RPC port; false
// when none was found (/proc unreadable, the server not started).
bool setXmlRpcBacklog(int backlog) {
  const int port = static_cast<int>(ros::XMLRPCManager::instance()->getServerPort());
  DIR* dir = port > 0 ? opendir("/proc/self/fd") : nullptr;
  if (!dir) return false;
  bool set = false;
  while (const dirent* entry = readdir(dir)) {
    char* end = nullptr;
    const long fd = std::strtol(entry->d_name, &end, 10);
    if (end == entry->d_name || *end != '\0') continue;  // "." and ".."
    if (listeningPort(static_cast<int>(fd)) == port && listen(static_cast<int>(fd), backlog) == 0) set = true;
  }
  closedir(dir);
  return set;
}

}  // namespace

FleetDriverSettings FleetDriverSettings::read(const ros::NodeHandle& pnh) {
  FleetDriverSettings s;
  pnh.param("n", s.n, s.n);
  pnh.param("rate", s.rate, s.rate);
  pnh.param("mode", s.mode, s.mode);
  pnh.param("states_topic", s.states_topic, s.states_topic);
  pnh.param("seed", s.seed, s.seed);
  pnh.param("area", s.area, s.area);
  pnh.param("clock_step", s.clock_step, s.clock_step);
  pnh.param("wait_subscribers", s.wait_subscribers, s.wait_subscribers);
  pnh.param("sensors", s.sensors, s.sensors);
  pnh.param("xmlrpc_backlog", s.xmlrpc_backlog, s.xmlrpc_backlog);
  require(s.n >= 1, "~n must be >= 1 (got " + std::to_string(s.n) + ")");
  require(s.rate > 0.0 && s.rate <= 1000.0, "~rate must be in (0, 1000] Hz (got " + std::to_string(s.rate) + ")");
  require(s.mode == "odom" || s.mode == "array", "~mode must be odom or array (got \"" + s.mode + "\")");
  require(s.area > 0.0 && s.area <= 1e6, "~area must be in (0, 1e6] m^2 (got " + std::to_string(s.area) + ")");
  require(s.clock_step >= 0.0 && s.clock_step <= 60.0,
          "~clock_step must be in [0, 60] s (got " + std::to_string(s.clock_step) + ")");
  require(s.wait_subscribers >= 0, "~wait_subscribers must be >= 0 (got " + std::to_string(s.wait_subscribers) + ")");
  require(s.xmlrpc_backlog >= 0 && s.xmlrpc_backlog <= 65535,
          "~xmlrpc_backlog must be in [0, 65535] (got " + std::to_string(s.xmlrpc_backlog) + ")");
  return s;
}

FleetDriver::FleetDriver(ros::NodeHandle& nh, const FleetDriverSettings& s)
    : s_(s), rng_(static_cast<unsigned>(s.seed)), fleet_(static_cast<size_t>(s.n), s.area, 0.5, rng_) {
  if (s_.xmlrpc_backlog > 0) {
    if (setXmlRpcBacklog(s_.xmlrpc_backlog)) {
      ROS_INFO("vadop_fleet_driver: XML-RPC server listening with a backlog of %d", s_.xmlrpc_backlog);
    } else {
      ROS_WARN("vadop_fleet_driver: ~xmlrpc_backlog: no socket listening on the XML-RPC port found; roscpp's backlog kept");
    }
  }
  if (s_.mode == "odom") {
    odom_.reserve(s_.n);
    for (int i = 0; i < s_.n; ++i) {
      odom_.push_back(nh.advertise<nav_msgs::Odometry>("/robot_" + std::to_string(i) + "/odom", 5));
    }
  } else {
    array_ = nh.advertise<vadop::BodyStateArray>(s_.states_topic, 2);
    names_.header.frame_id = "odom";
    names_.states.resize(s_.n);
    for (int i = 0; i < s_.n; ++i) names_.states[i].name = "robot_" + std::to_string(i);
  }
  if (s_.clock_step > 0.0) clock_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  if (s_.sensors) {
    scan_ = nh.advertise<sensor_msgs::LaserScan>("/scan", 2);
    cloud_ = nh.advertise<sensor_msgs::PointCloud2>("/points", 2);
    cloud_rng_.seed(static_cast<unsigned>(s.seed) + 104729u);
    geometry_msgs::TransformStamped laser;
    laser.header.stamp = ros::Time::now();
    laser.header.frame_id = "odom";
    laser.child_frame_id = "laser";
    laser.transform.translation.z = FleetSensors::kLaserHeight;
    laser.transform.rotation.w = 1.0;
    laser_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    laser_tf_->sendTransform(laser);
  }
}

void FleetDriver::publishSensors(const ros::Time& stamp) {
  constexpr double kScanRate = 15.0, kCloudRate = 10.0;
  constexpr size_t kCloudPoints = 30000;
  // Due at `next`: then `next` a period on (from now, when the first or more than a period late).
  const auto due = [&stamp](ros::Time& next, double rate) {
    if (stamp < next) return false;
    const ros::Duration period(1.0 / rate);
    next = (next.isZero() || stamp - next > period) ? stamp + period : next + period;
    return true;
  };
  if (due(next_scan_, kScanRate)) {
    scan_.publish(boost::make_shared<sensor_msgs::LaserScan>(sensors_.scan(fleet_, stamp)));
  }
  if (due(next_cloud_, kCloudRate)) {
    cloud_.publish(
        boost::make_shared<sensor_msgs::PointCloud2>(sensors_.cloud(fleet_, stamp, kCloudPoints, cloud_rng_)));
  }
}

std::string FleetDriver::describe() const {
  std::string what = std::to_string(s_.n) + " robots at " + std::to_string(s_.rate) + " Hz as " +
                     (s_.mode == "odom" ? "one nav_msgs/Odometry topic each" : "one vadop/BodyStateArray on " + s_.states_topic);
  if (s_.clock_step > 0.0) what += ", each state " + std::to_string(s_.clock_step) + " s later on its own /clock";
  if (s_.sensors) what += ", with a laser scan (/scan, 15 Hz) and a depth cloud (/points, 10 Hz)";
  return what;
}

void FleetDriver::tick(double dt, const ros::Time& stamp) {
  fleet_.step(dt, rng_);
  if (s_.mode == "odom") {
    for (int i = 0; i < s_.n; ++i) {
      auto m = boost::make_shared<nav_msgs::Odometry>();
      m->header.stamp = stamp;
      m->header.frame_id = "odom";
      fill(fleet_[i], m->pose.pose, m->twist.twist);
      odom_[i].publish(m);
    }
  } else {
    auto m = boost::make_shared<vadop::BodyStateArray>(names_);
    m->header.stamp = stamp;
    for (int i = 0; i < s_.n; ++i) fill(fleet_[i], m->states[i].pose, m->states[i].twist);
    array_.publish(m);
  }
  if (s_.sensors) publishSensors(stamp);
}

bool FleetDriver::waitForSubscribers() {
  const auto have = [this] {
    uint32_t states = s_.mode == "odom" ? odom_.front().getNumSubscribers() : array_.getNumSubscribers();
    for (const ros::Publisher& p : odom_) states = std::min(states, p.getNumSubscribers());
    const uint32_t clock = clock_ ? clock_.getNumSubscribers() : states;
    return std::min(states, clock);
  };
  const uint32_t wanted = static_cast<uint32_t>(s_.wait_subscribers);
  ros::WallTime said = ros::WallTime::now();
  while (running() && have() < wanted) {
    if ((ros::WallTime::now() - said).toSec() > 5.0) {
      ROS_INFO("vadop_fleet_driver: waiting for %u subscribers (%u so far)", wanted, have());
      said = ros::WallTime::now();
    }
    ros::WallDuration(0.02).sleep();
  }
  return running();
}

void FleetDriver::runRealTime() {
  ros::Rate loop(s_.rate);
  ros::WallTime window_start = ros::WallTime::now();
  int ticks = 0;
  while (running()) {
    tick(1.0 / s_.rate, ros::Time::now());
    ++ticks;
    const double elapsed = (ros::WallTime::now() - window_start).toSec();
    if (elapsed >= 5.0) {
      ROS_INFO("vadop_fleet_driver: %.1f ticks/s (asked %.1f)", ticks / elapsed, s_.rate);
      ticks = 0;
      window_start = ros::WallTime::now();
    }
    loop.sleep();
  }
}

void FleetDriver::runSimulatedClock() {
  rosgraph_msgs::Clock clock;
  clock.clock = ros::Time(FleetDriverSettings::kClockStart);
  const ros::Duration step(s_.clock_step);
  const ros::WallDuration half(0.5 / s_.rate);
  clock_.publish(clock);
  while (running()) {
    tick(s_.clock_step, clock.clock);
    half.sleep();
    clock.clock += step;
    clock_.publish(clock);
    half.sleep();
  }
}

void FleetDriver::run() {
  if (!waitForSubscribers()) return;
  if (s_.clock_step > 0.0) {
    runSimulatedClock();
  } else {
    runRealTime();
  }
}

}  // namespace vadop_ros
