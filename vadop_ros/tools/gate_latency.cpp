// vadop_gate_latency: the velocity gates' latency through ROS. A driver node for a running
// vadop_monitor configured with N bodies: G gated ones "g_<i>" (odom_topic /g_<i>/odom,
// cmd_vel_in /g_<i>/nav_vel, cmd_vel_out /g_<i>/cmd_vel) and N - G others "b_<i>"
// (/b_<i>/odom): it publishes every
// body's odometry at --rate Hz (the bodies wander a square room at 6 m^2 per body, 0.3-1.5
// m/s, bouncing off its walls: wandering_fleet.h, as in vadop_monitor_bench) and each gate's command (the body's
// current twist) at --cmd-rate Hz, staggered, and measures for every command the time until
// its gated command arrives back (two transport hops and the node's work). At the end it
// prints those figures and the node's own (its /diagnostics: from the command's arrival at
// the node to the publication of the gated one, including any wait behind a cycle), and
// exits. launch/gate_latency.launch starts both:
//   roslaunch vadop gate_latency.launch bodies:=1000 gates:=10 seconds:=20
#include "wandering_fleet.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <vector>

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

// The driver's settings (its private parameters).
struct Settings {
  int bodies = 1000, gates = 10;
  double seconds = 20.0, rate = 30.0, cmd_rate = 10.0;
};

// The driver: the fleet's odometry and the gates' commands out, the gated commands and the
// node's /diagnostics in; the figures measured, guarded by one lock (the spinner's thread
// writes them, the main thread sends and reports).
class LatencyDriver {
 public:
  LatencyDriver(ros::NodeHandle& nh, const Settings& s)
      : s_(s), sim_(static_cast<size_t>(s.bodies), 6.0, 0.5, rng_), odom_(s.bodies), cmd_(s.gates), out_(s.gates),
        sent_(s.gates), waiting_(s.gates, false) {
    msg_.header.frame_id = "odom";
    for (int i = 0; i < s_.bodies; ++i) odom_[i] = nh.advertise<nav_msgs::Odometry>("/" + name(i) + "/odom", 5);
    for (int g = 0; g < s_.gates; ++g) {
      cmd_[g] = nh.advertise<geometry_msgs::Twist>("/" + name(g) + "/nav_vel", 5);
      out_[g] = nh.subscribe<geometry_msgs::Twist>(
          "/" + name(g) + "/cmd_vel", 5, [this, g](const geometry_msgs::TwistConstPtr&) { onGated(g); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    }
    diag_ = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 10, [this](const diagnostic_msgs::DiagnosticArrayConstPtr& msg) { onDiagnostics(*msg); });
  }

  // Waits (at most 120 s) for the monitor: every gate's output connected.
  void waitForMonitor() const {
    const ros::WallTime wait_end = ros::WallTime::now() + ros::WallDuration(120.0);
    while (ros::ok() && ros::WallTime::now() < wait_end) {
      bool ready = true;
      for (int g = 0; g < s_.gates; ++g) {
        ready = ready && cmd_[g].getNumSubscribers() > 0 && out_[g].getNumPublishers() > 0;
      }
      if (ready && odom_[s_.bodies - 1].getNumSubscribers() > 0) break;
      ros::WallDuration(0.2).sleep();
    }
  }

  // The fleet at --rate for --seconds after a warm-up of 2 s (commands sent then are not
  // measured).
  void drive() {
    const double dt = 1.0 / s_.rate;
    const ros::WallTime start = ros::WallTime::now();
    const double warmup = 2.0;
    ros::WallTime next = start;
    int tick = 0;
    const int cmd_every = std::max(1, static_cast<int>(std::lround(s_.rate / s_.cmd_rate)));
    while (ros::ok() && (ros::WallTime::now() - start).toSec() < s_.seconds + warmup) {
      const ros::Time stamp = ros::Time::now();
      sim_.step(dt, rng_);
      publishOdometry(stamp);
      sendCommands(tick, cmd_every, (ros::WallTime::now() - start).toSec() >= warmup);
      ++tick;
      next += ros::WallDuration(dt);
      const ros::WallDuration left = next - ros::WallTime::now();
      if (left.toSec() > 0) left.sleep();
    }
  }

  // The figures; the exit status (1: no command came back).
  int report() {
    std::lock_guard<std::mutex> guard(lock_);
    std::printf("vadop_gate_latency: %d bodies, %d gates, %zu commands measured\n", s_.bodies, s_.gates,
                round_trip_.size());
    std::printf("  round trip (driver -> node -> driver), ms: median %.3f, p99 %.3f, max %.3f\n",
                percentile(round_trip_, 0.5), percentile(round_trip_, 0.99),
                round_trip_.empty() ? std::nan("") : *std::max_element(round_trip_.begin(), round_trip_.end()));
    std::vector<double> med, p99;
    for (const auto& kv : node_latency_) {
      med.push_back(kv.second.first);
      p99.push_back(kv.second.second);
    }
    std::printf("  in the node (arrival -> publication, its last 1000 commands per gate), ms: median of the gates' "
                "medians %.3f, largest p99 %.3f (%zu gates reporting)\n",
                percentile(med, 0.5), p99.empty() ? std::nan("") : *std::max_element(p99.begin(), p99.end()),
                node_latency_.size());
    std::fflush(stdout);
    return round_trip_.empty() ? 1 : 0;
  }

 private:
  // Body i: gate i for i < gates, else the ungated b_<i - gates>.
  std::string name(int i) const { return i < s_.gates ? "g_" + std::to_string(i) : "b_" + std::to_string(i - s_.gates); }

  void onGated(int g) {
    std::lock_guard<std::mutex> guard(lock_);
    if (!waiting_[g]) return;
    waiting_[g] = false;
    round_trip_.push_back((ros::WallTime::now() - sent_[g]).toSec() * 1e3);
  }

  void onDiagnostics(const diagnostic_msgs::DiagnosticArray& msg) {
    std::lock_guard<std::mutex> guard(lock_);
    for (const auto& st : msg.status) {
      if (st.name.find(": gate ") == std::string::npos) continue;
      double med = std::nan(""), p99 = std::nan("");
      for (const auto& kv : st.values) {
        if (kv.key == "latency median (ms)") med = std::atof(kv.value.c_str());
        if (kv.key == "latency p99 (ms)") p99 = std::atof(kv.value.c_str());
      }
      node_latency_[st.name] = {med, p99};
    }
  }

  void publishOdometry(const ros::Time& stamp) {
    for (int i = 0; i < s_.bodies; ++i) {
      const vadop_ros::WanderingFleet::Body& s = sim_[static_cast<size_t>(i)];
      msg_.header.stamp = stamp;
      msg_.child_frame_id = name(i);
      msg_.pose.pose.position.x = s.x;
      msg_.pose.pose.position.y = s.y;
      msg_.pose.pose.orientation.z = std::sin(s.yaw / 2);
      msg_.pose.pose.orientation.w = std::cos(s.yaw / 2);
      msg_.twist.twist.linear.x = s.v;
      msg_.twist.twist.angular.z = s.w;
      odom_[i].publish(msg_);
    }
  }

  // Each gate's command (its body's current twist), staggered over the ticks: gate g on ticks
  // where tick % cmd_every == g % cmd_every; its round trip measured when `measuring`.
  void sendCommands(int tick, int cmd_every, bool measuring) {
    for (int g = 0; g < s_.gates; ++g) {
      if (tick % cmd_every != g % cmd_every) continue;
      geometry_msgs::Twist t;
      t.linear.x = sim_[static_cast<size_t>(g)].v;
      t.angular.z = sim_[static_cast<size_t>(g)].w;
      {
        std::lock_guard<std::mutex> guard(lock_);
        sent_[g] = ros::WallTime::now();
        waiting_[g] = measuring;
      }
      cmd_[g].publish(t);
    }
  }

  const Settings s_;
  std::mt19937 rng_{1};
  vadop_ros::WanderingFleet sim_;
  std::vector<ros::Publisher> odom_, cmd_;
  std::vector<ros::Subscriber> out_;
  ros::Subscriber diag_;
  nav_msgs::Odometry msg_;
  std::mutex lock_;
  std::vector<ros::WallTime> sent_;
  std::vector<bool> waiting_;
  std::vector<double> round_trip_;
  std::map<std::string, std::pair<double, double>> node_latency_;  // gate -> (median, p99)
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vadop_gate_latency");
  ros::NodeHandle nh, pnh("~");
  Settings s;
  s.bodies = pnh.param("bodies", 1000);
  s.gates = std::min(pnh.param("gates", 10), s.bodies);
  s.seconds = pnh.param("seconds", 20.0);
  s.rate = pnh.param("rate", 30.0);
  s.cmd_rate = pnh.param("cmd_rate", 10.0);
  if (s.bodies < 1 || s.gates < 1 || !(s.seconds > 0) || !(s.rate > 0) || !(s.cmd_rate > 0)) {
    ROS_FATAL("vadop_gate_latency: need bodies >= 1, gates >= 1 and positive seconds, rate, cmd_rate");
    return 2;
  }
  LatencyDriver driver(nh, s);
  ros::AsyncSpinner spinner(1);
  spinner.start();
  driver.waitForMonitor();
  ROS_INFO("vadop_gate_latency: %d bodies, %d gates, odometry at %.0f Hz, commands at %.0f Hz, %.0f s", s.bodies,
           s.gates, s.rate, s.cmd_rate, s.seconds);
  driver.drive();
  ros::WallDuration(1.5).sleep();  // a last /diagnostics
  return driver.report();
}
