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

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vadop_gate_latency");
  ros::NodeHandle nh, pnh("~");
  const int n = pnh.param("bodies", 1000);
  const int gates = std::min(pnh.param("gates", 10), n);
  const double seconds = pnh.param("seconds", 20.0);
  const double rate = pnh.param("rate", 30.0);
  const double cmd_rate = pnh.param("cmd_rate", 10.0);
  if (n < 1 || gates < 1 || !(seconds > 0) || !(rate > 0) || !(cmd_rate > 0)) {
    ROS_FATAL("vadop_gate_latency: need bodies >= 1, gates >= 1 and positive seconds, rate, cmd_rate");
    return 2;
  }
  std::mt19937 rng(1);
  vadop_ros::WanderingFleet sim(static_cast<size_t>(n), 6.0, 0.5, rng);
  std::vector<ros::Publisher> odom(n), cmd(gates);
  std::vector<ros::Subscriber> out(gates);
  std::mutex lock;
  std::vector<ros::WallTime> sent(gates);
  std::vector<bool> waiting(gates, false);
  std::vector<double> round_trip;
  std::map<std::string, std::pair<double, double>> node_latency;  // gate -> (median, p99)
  // Body i: gate i for i < gates, else the ungated b_<i - gates>.
  auto name = [gates](int i) { return i < gates ? "g_" + std::to_string(i) : "b_" + std::to_string(i - gates); };
  for (int i = 0; i < n; ++i) odom[i] = nh.advertise<nav_msgs::Odometry>("/" + name(i) + "/odom", 5);
  for (int g = 0; g < gates; ++g) {
    cmd[g] = nh.advertise<geometry_msgs::Twist>("/" + name(g) + "/nav_vel", 5);
    out[g] = nh.subscribe<geometry_msgs::Twist>(
        "/" + name(g) + "/cmd_vel", 5,
        [&, g](const geometry_msgs::TwistConstPtr&) {
          std::lock_guard<std::mutex> guard(lock);
          if (!waiting[g]) return;
          waiting[g] = false;
          round_trip.push_back((ros::WallTime::now() - sent[g]).toSec() * 1e3);
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
  ros::Subscriber diag = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& msg) {
        std::lock_guard<std::mutex> guard(lock);
        for (const auto& st : msg->status) {
          if (st.name.find(": gate ") == std::string::npos) continue;
          double med = std::nan(""), p99 = std::nan("");
          for (const auto& kv : st.values) {
            if (kv.key == "latency median (ms)") med = std::atof(kv.value.c_str());
            if (kv.key == "latency p99 (ms)") p99 = std::atof(kv.value.c_str());
          }
          node_latency[st.name] = {med, p99};
        }
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Wait for the monitor: every gate's output connected.
  const ros::WallTime wait_end = ros::WallTime::now() + ros::WallDuration(120.0);
  while (ros::ok() && ros::WallTime::now() < wait_end) {
    bool ready = true;
    for (int g = 0; g < gates; ++g) ready = ready && cmd[g].getNumSubscribers() > 0 && out[g].getNumPublishers() > 0;
    if (ready && odom[n - 1].getNumSubscribers() > 0) break;
    ros::WallDuration(0.2).sleep();
  }
  ROS_INFO("vadop_gate_latency: %d bodies, %d gates, odometry at %.0f Hz, commands at %.0f Hz, %.0f s", n, gates, rate,
           cmd_rate, seconds);
  const double dt = 1.0 / rate;
  const ros::WallTime start = ros::WallTime::now();
  const double warmup = 2.0;
  nav_msgs::Odometry msg;
  msg.header.frame_id = "odom";
  ros::WallTime next = start;
  int tick = 0;
  const int cmd_every = std::max(1, static_cast<int>(std::lround(rate / cmd_rate)));
  while (ros::ok() && (ros::WallTime::now() - start).toSec() < seconds + warmup) {
    const ros::Time stamp = ros::Time::now();
    sim.step(dt, rng);
    for (int i = 0; i < n; ++i) {
      const vadop_ros::WanderingFleet::Body& s = sim[static_cast<size_t>(i)];
      msg.header.stamp = stamp;
      msg.child_frame_id = name(i);
      msg.pose.pose.position.x = s.x;
      msg.pose.pose.position.y = s.y;
      msg.pose.pose.orientation.z = std::sin(s.yaw / 2);
      msg.pose.pose.orientation.w = std::cos(s.yaw / 2);
      msg.twist.twist.linear.x = s.v;
      msg.twist.twist.angular.z = s.w;
      odom[i].publish(msg);
    }
    // Commands staggered over the ticks: gate g on ticks where tick % cmd_every == g % cmd_every.
    const bool measuring = (ros::WallTime::now() - start).toSec() >= warmup;
    for (int g = 0; g < gates; ++g) {
      if (tick % cmd_every != g % cmd_every) continue;
      geometry_msgs::Twist t;
      t.linear.x = sim[static_cast<size_t>(g)].v;
      t.angular.z = sim[static_cast<size_t>(g)].w;
      {
        std::lock_guard<std::mutex> guard(lock);
        sent[g] = ros::WallTime::now();
        waiting[g] = measuring;
      }
      cmd[g].publish(t);
    }
    ++tick;
    next += ros::WallDuration(dt);
    const ros::WallDuration left = next - ros::WallTime::now();
    if (left.toSec() > 0) left.sleep();
  }
  ros::WallDuration(1.5).sleep();  // a last /diagnostics
  std::lock_guard<std::mutex> guard(lock);
  std::printf("vadop_gate_latency: %d bodies, %d gates, %zu commands measured\n", n, gates, round_trip.size());
  std::printf("  round trip (driver -> node -> driver), ms: median %.3f, p99 %.3f, max %.3f\n",
              percentile(round_trip, 0.5), percentile(round_trip, 0.99),
              round_trip.empty() ? std::nan("") : *std::max_element(round_trip.begin(), round_trip.end()));
  std::vector<double> med, p99;
  for (const auto& kv : node_latency) {
    med.push_back(kv.second.first);
    p99.push_back(kv.second.second);
  }
  std::printf("  in the node (arrival -> publication, its last 1000 commands per gate), ms: median of the gates' "
              "medians %.3f, largest p99 %.3f (%zu gates reporting)\n",
              percentile(med, 0.5), p99.empty() ? std::nan("") : *std::max_element(p99.begin(), p99.end()),
              node_latency.size());
  std::fflush(stdout);
  return round_trip.empty() ? 1 : 0;
}
