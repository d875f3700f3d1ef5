// vadop_monitor_bench: cycle time of the monitor's core (MonitorCore: registry update, world
// sync, VADOP broad phase + narrow phase, ImpactArray message) with N moving bodies, without
// ROS transport and without a ROS master. The cycle runs on one thread, its prediction on
// --threads threads (default 1).
//
// Scene: N primitive bodies (spheres, boxes, cylinders, capsules of 0.3-0.6 m) wandering a
// square room at 0.3-1.5 m/s, turning at up to 0.5 rad/s (--turn), at a constant density (default
// 6 m^2 per body, a busy warehouse floor), bouncing off the walls; every body publishes one
// odometry message per cycle (fed to the registry as the node's callbacks would; its cost is
// counted in the cycle time). Simulated time advances by 1/rate per cycle.
//
//   vadop_monitor_bench [--bodies 100,1000,5000] [--cycles 150] [--warmup 15] [--rate 30]
//                       [--horizon 2] [--area 6] [--turn 0.5] [--markers] [--seed 1]
// --area: m^2 of floor per body (density); --turn: largest turn rate (rad/s) of a body.
// --links K (K >= 2): each body is a K-link robot instead, a URDF with links rigid with the
// body (fixed joints, no tf): a cylinder base (r 0.3 m) and K - 1 boxes stacked on it as a mast;
// the links of one body are never tested against each other (MonitorCore::pairIgnored).
// --joints (with --links K): mobile manipulators instead: on the base, an arm of K - 1 links on
// revolute joints (a shoulder turning about z, then elbows about y; links 0.6, 0.4, 0.2 m long,
// the first alone reaching 0.3 m beyond the base's rim), each joint swinging sinusoidally (0.6-1.2 rad
// amplitude, 0.3-1.0 rad/s); every robot publishes one sensor_msgs/JointState per cycle
// (joint_states_topic: its links predicted along the joints' motion, vadop::LinkChain), fed to
// the registry as the odometry is (its cost counted in feed).
//   vadop_monitor_bench --startup 5000,50000   start-up instead: parseParams + MonitorCore for N
//                       bodies (primitive and 3-link URDF templates), no ROS transport
//
// --gates G: the first G bodies have a velocity gate (time_before_collision 1 s); after every
// cycle each of them gets one command (its own current twist, what its planner would send),
// half a period later, and the time of VelocityGate::onCommand (the node's work between the
// receipt of a command and the publication of the gated one, without transport) is measured:
// median, p99 and max, with the scales tried per command and the share of commands slowed or
// stopped. --gate-rule: the gates' rule (Options::gate_rule).
//
// --tracks: the N moving things are tracked objects instead, all in one vadop/TrackedObjectArray
// per cycle (source "people", timeout 0.5 s; spheres, boxes and cylinders by index), fed to
// Tracks::onArray (its cost is `feed`); --churn C: each object leaves with probability C per
// second (its id is no longer reported: it expires 0.5 s later) and a new id takes its place.
//
// --fast F: a share F of the bodies 5 times faster (1.5-7.5 m/s: mixed speeds); --3d H: every
// body also climbs and sinks at up to 0.5 m/s between 0 and H m (drones); --broadphase K: the
// world's broad phase (grid, vadop, sap, vadop_sap, brute; ~broad_phase, default the node's: grid),
// the same narrow phase.
// --time-slices K: ~time_slices (the cull before the narrow phase; default the node's, 8; 1: none);
// the column `culled` counts the broad phase's pairs it dropped per cycle.
// --noise S: every odometry message's twist gets Gaussian noise of S (m/s on the forward speed,
// rad/s on the turn rate). --coherence C[,L]: ~coherence_clearance C m and ~coherence_lookahead
// L s (default: the node's, off; L default 0.5). --paired: a second core
// without coherence is fed the same messages and cycled each cycle, before or after the first in
// turn: the per-cycle CPU ratio, robust to the machine's drift (same impacts checked).
// --scan: a laser at the room's centre (frame "laser", 0.1 m up) publishes a 1,081-beam 270-degree
// sensor_msgs/LaserScan at 15 Hz of the walls and the bodies (each a circle of 0.2 m, ray-cast);
// --cloud: a 30,000-point sensor_msgs/PointCloud2 at 10 Hz from the same frame, a third on the
// floor (below min_z: dropped), a third on the walls, a third on the bodies (voxel 0.05). Each is
// one sensor of the node's `sensors` source (~sensors: "scan", "cloud"), fed to
// SensorsSource::onScan / onCloud as its subscription's handler would, in the cycle at or after
// its stamp; the points on the monitored bodies are filtered there. Their cost is in `feed` and
// also in the column `sensors` (per cycle, averaged over all cycles), with each message's own
// median on the line below. The messages are built outside the timed part, from their own
// random generator (the fleet moves the same with or without them).
// --threads T: the prediction (broad phase, part boxes, narrow phase) on T threads (~threads;
// default 1; 0: all cores). With T > 1 the thread's CPU time no longer covers the cycle: read
// the wall clock.
//
// Prints one line per N, the process's CPU a cycle below it (every thread: the prediction's
// helpers, the gates' commands; not the fleet's and sensors' simulation), and for N = 1000
// whether the mean cycle uses under a third of the period at the given rate.
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/velocity_gate.h"
#include "fleet_sensors.h"
#include "vadop_ros/sensors_source.h"
#include "wandering_fleet.h"

#include <sensor_msgs/JointState.h>
#include <shape_msgs/SolidPrimitive.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

// The benchmark's tf: only the sensors' frame "laser", fixed at the room's centre
// (FleetSensors::kLaserHeight up) under the fixed frame "odom"; the bodies need none.
struct NoTf : vadop_ros::TransformSource {
  bool lookup(const std::string& target, const std::string& source, const ros::Time& time, Eigen::Isometry3d& pose,
              ros::Time& stamp, std::string& error) override {
    if (target == "odom" && source == "laser") {
      pose = Eigen::Isometry3d::Identity();
      pose.translation().z() = vadop_ros::FleetSensors::kLaserHeight;
      stamp = time;
      return true;
    }
    error = "no tf in the benchmark (" + source + ")";
    return false;
  }
  bool concurrent() const override { return true; }
  bool parent(const std::string& frame, const ros::Time&, std::string& parent) override {
    parent = "odom";
    return frame == "laser";
  }
};

double clockMs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
// CPU time of the calling thread (ms): unaffected by other processes competing for the cores.
double threadCpuMs() { return clockMs(CLOCK_THREAD_CPUTIME_ID); }
// Every thread's (the prediction's helpers included).
double processCpuMs() { return clockMs(CLOCK_PROCESS_CPUTIME_ID); }

struct Result {
  size_t n = 0;
  double mean = 0, median = 0, p95 = 0, max = 0;  // wall clock
  double cpu_mean = 0, cpu_p95 = 0;                // thread CPU time
  double feed_mean = 0, predict_mean = 0, markers_mean = 0, registry_mean = 0;
  double candidates = 0, impacts = 0, ignored_tested = 0, reused = 0, culled = 0;
  // --paired: CPU ms median of this core and of the paired one (coherence off), and the median and
  // quartiles of the per-cycle ratio.
  double cpu_median = 0, paired_median = 0, ratio_median = 0, ratio_p25 = 0, ratio_p75 = 0;
  size_t elements = 0;
  // --scan / --cloud: the sensors' handling per cycle (ms, mean over every cycle), each message's
  // median (ms), and the points kept and filtered (on the bodies) of the last message.
  double sensors_mean = 0, scan_median = 0, cloud_median = 0;
  double process_cpu = 0;  // ms a measured cycle, every thread (the gates' commands included; not the simulation)
  size_t scan_kept = 0, cloud_kept = 0;
  uint64_t scan_filtered = 0, cloud_filtered = 0;
  size_t tracked = 0;     // --tracks: objects in the world at the end
  uint64_t expired = 0;   // --tracks: objects that left over the run
  // Gates: latency of onCommand (ms), scales tried per command, commands slowed / stopped.
  std::vector<double> gate_ms;
  double gate_evaluations = 0, gate_slowed = 0, gate_stopped = 0, gate_unchecked = 0;
};

// Start-up without ROS transport (--startup N,...): parseParams of one `count: N` template (as
// the node reads it: one XmlRpc struct), then MonitorCore (registry, geometry, world) for
// primitive bodies and for a 3-link URDF robot with tf links. Wall seconds of each step.
void startup(const std::vector<size_t>& sizes) {
  const std::string urdf =
      "<robot name='r'><link name='base'><collision><geometry><cylinder radius='0.3' length='0.4'/></geometry>"
      "</collision><collision><origin xyz='0 0 0.3'/><geometry><sphere radius='0.1'/></geometry></collision></link>"
      "<link name='mast'><collision><geometry><box size='0.1 0.1 0.5'/></geometry></collision></link>"
      "<link name='head'><collision><geometry><sphere radius='0.15'/></geometry></collision></link>"
      "<joint name='j1' type='revolute'><parent link='base'/><child link='mast'/><axis xyz='0 1 0'/>"
      "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint>"
      "<joint name='j2' type='fixed'><parent link='mast'/><child link='head'/><origin xyz='0 0 0.3'/></joint></robot>";
  std::printf("start-up without ROS transport (wall s): parseParams of a count: N template, MonitorCore\n");
  std::printf("%8s %6s %10s %12s %10s %10s\n", "bodies", "kind", "parse", "MonitorCore", "total", "us/body");
  for (const size_t n : sizes) {
    for (const bool with_urdf : {false, true}) {
      XmlRpc::XmlRpcValue body;
      body["name"] = std::string("b_{i}");
      body["count"] = static_cast<int>(n);
      body["odom_topic"] = std::string("/b_{i}/odom");
      if (with_urdf) {
        body["robot_description"] = std::string("/robot_description");
        body["tf_prefix"] = std::string("b_{i}");
      } else {
        body["shape"]["type"] = std::string("sphere");
        body["shape"]["radius"] = 0.3;
      }
      XmlRpc::XmlRpcValue root;
      root["bodies"][0] = body;
      const auto t0 = std::chrono::steady_clock::now();
      const vadop_ros::MonitorParams p = vadop_ros::parseParams(root);
      const auto t1 = std::chrono::steady_clock::now();
      vadop_ros::MonitorCore core(p, [&](const std::string&, std::string& value) {
        value = urdf;
        return true;
      });
      const auto t2 = std::chrono::steady_clock::now();
      const double parse = std::chrono::duration<double>(t1 - t0).count();
      const double build = std::chrono::duration<double>(t2 - t1).count();
      std::printf("%8zu %6s %10.3f %12.3f %10.3f %10.2f\n", n, with_urdf ? "urdf" : "sphere", parse, build,
                  parse + build, 1e6 * (parse + build) / static_cast<double>(n));
      std::fflush(stdout);
    }
  }
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  return v[i];
}

// A K-link robot: base cylinder, then K - 1 boxes 0.1 x 0.1 x 0.4 m stacked by fixed joints;
// with `arm`, K - 1 arm links on revolute joints instead (--joints).
std::string chainUrdf(int links, bool arm) {
  std::string s = "<robot name='r'><link name='l0'><collision><origin xyz='0 0 0.2'/><geometry>"
                  "<cylinder radius='0.3' length='0.4'/></geometry></collision></link>";
  for (int k = 1; k < links && arm; ++k) {
    // Link k: a box along its x axis, jointed at the end of link k - 1 (the shoulder on the
    // base's top); the shoulder turns about z, the elbows about y.
    const double length = std::max(0.2, 0.8 - 0.2 * k), prev = k == 1 ? 0.0 : std::max(0.2, 0.8 - 0.2 * (k - 1));
    const std::string name = "l" + std::to_string(k), parent = "l" + std::to_string(k - 1);
    s += "<link name='" + name + "'><collision><origin xyz='" + std::to_string(length / 2) +
         " 0 0'/><geometry><box size='" + std::to_string(length) + " 0.1 0.1'/></geometry></collision></link>"
         "<joint name='j" + std::to_string(k) + "' type='revolute'><parent link='" + parent + "'/><child link='" +
         name + "'/><origin xyz='" + (k == 1 ? std::string("0 0 0.45") : std::to_string(prev) + " 0 0") +
         "'/><axis xyz='" + (k == 1 ? "0 0 1" : "0 1 0") +
         "'/><limit lower='-2.8' upper='2.8' effort='10' velocity='2'/></joint>";
  }
  for (int k = 1; k < links && !arm; ++k) {
    const std::string name = "l" + std::to_string(k), parent = "l" + std::to_string(k - 1);
    s += "<link name='" + name + "'><collision><origin xyz='0 0 0.2'/><geometry><box size='0.1 0.1 0.4'/>"
         "</geometry></collision></link><joint name='j" + std::to_string(k) + "' type='fixed'><parent link='" +
         parent + "'/><child link='" + name + "'/><origin xyz='0 0 0.4'/></joint>";
  }
  return s + "</robot>";
}

// What one run measures (the command line's options).
struct Options {
  int cycles = 150, warmup = 15;
  double rate = 30.0, horizon = 2.0, area = 6.0, turn = 0.5;
  bool markers = false;
  unsigned seed = 1;
  int links = 1;
  bool joints = false;  // --joints: the links on revolute joints, driven by joint states
  size_t gates = 0;
  // --gate-rule held|braking|instant: the gates' rule. held (the default gate keys: reaction
  // 0.1 s, others may stop, no decelerations), braking (every body brakes at 1 m/s^2, 2 rad/s^2),
  // instant (no reaction time, others as predicted, no decelerations: the rule before issue 48).
  std::string gate_rule = "held";
  bool tracks = false;
  bool scan = false, cloud = false;  // --scan, --cloud
  double churn = 0.2;
  int threads = 1;
  double fast = 0.0, ceiling = 0.0;
  std::string broad_phase = vadop_ros::MonitorParams{}.broad_phase;
  int time_slices = vadop_ros::MonitorParams{}.time_slices;
  double noise = 0.0;                       // --noise: odometry twist noise (m/s and rad/s, 1 sigma)
  bool paired = false;                      // --paired: also time the same cycle without coherence
  // --coherence C,L (default: the node's, off)
  double clearance = vadop_ros::MonitorParams{}.coherence_clearance;
  double lookahead = vadop_ros::MonitorParams{}.coherence_lookahead;
};

// The node's parameters the options set (bodies and tracks are added by run).
vadop_ros::MonitorParams monitorParams(const Options& o) {
  vadop_ros::MonitorParams p;
  p.fixed_frame = "odom";
  p.rate = o.rate;
  p.horizon = o.horizon;
  p.stale_timeout = 0.5;
  p.threads = o.threads;
  p.broad_phase = o.broad_phase;
  p.time_slices = o.time_slices;
  p.coherence_clearance = o.clearance;
  p.coherence_lookahead = o.lookahead;
  return p;
}

// --scan, --cloud: the sensors "scan" and "cloud" (the cloud's floor below min_z).
void addSensors(const Options& o, vadop_ros::MonitorParams& p) {
  if (o.scan) {
    vadop_ros::SensorParams s;
    s.name = "scan";
    s.type = vadop_ros::SensorType::kScan;
    s.topic = "/scan";
    p.sensors.push_back(s);
  }
  if (o.cloud) {
    vadop_ros::SensorParams c;
    c.name = "cloud";
    c.type = vadop_ros::SensorType::kCloud;
    c.topic = "/points";
    c.voxel = 0.05;
    c.min_z = vadop_ros::FleetSensors::kFloorZ + 0.1;
    p.sensors.push_back(c);
  }
}

// The node's parameters of a run with n bodies: n robots on odometry (primitives, or K-link
// URDF robots with --links; the first --gates of them gated), or with --tracks one source of
// tracked objects.
vadop_ros::MonitorParams fleetParams(size_t n, const Options& o) {
  vadop_ros::MonitorParams p = monitorParams(o);
  if (o.tracks) {
    vadop_ros::TrackParams t;
    t.topic = "/people/tracks";
    t.prefix = "people";
    p.tracks.push_back(t);
  }
  addSensors(o, p);
  for (size_t i = 0; i < (o.tracks ? 0 : n); ++i) {
    vadop_ros::BodyParams b;
    b.name = "body_" + std::to_string(i);
    b.topic = "/" + b.name + "/odom";
    if (i < o.gates) {
      b.has_gate = true;
      b.gate.cmd_vel_in = "/" + b.name + "/nav_vel";
      b.gate.cmd_vel_out = "/" + b.name + "/cmd_vel";
      b.gate.state_timeout = p.stale_timeout;
      if (o.gate_rule == "instant") {
        b.gate.reaction_time = 0.0;
        b.gate.others_may_stop = false;
      }
    }
    if (o.gate_rule == "braking") {
      b.max_linear_decel = 1.0;
      b.max_angular_decel = 2.0;
    }
    if (o.links >= 2) {
      b.robot_description = "/robot_description";
      if (o.joints) b.joint_states_topic = "/" + b.name + "/joint_states";
      p.bodies.push_back(b);
      continue;
    }
    b.has_shape = true;
    switch (i % 4) {
      case 0: b.shape = vadop::makeSphere(0.3); break;
      case 1: b.shape = vadop::makeBox(Eigen::Vector3d(0.6, 0.4, 0.5)); break;
      case 2: b.shape = vadop::makeCylinder(0.3, 0.5); break;
      default: b.shape = vadop::makeCapsule(0.2, 0.4); break;
    }
    p.bodies.push_back(b);
  }
  return p;
}

// Every body's robot_description: `urdf`, or none when it is empty (primitive bodies).
vadop_ros::ParamReader urdfReader(const std::string& urdf) {
  return [urdf](const std::string&, std::string& value) {
    value = urdf;
    return !urdf.empty();
  };
}

// --joints: each joint q = c + A sin(w t + phase).
struct Swing {
  double centre, amplitude, rate, phase;
};

// `count` joints' swings, drawn from their own generator so that the fleet's random sequence
// is the same as without joints.
std::vector<Swing> drawSwings(size_t count, unsigned seed) {
  std::vector<Swing> swing(count);
  std::mt19937 joint_rng(seed + 7919);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Swing& j : swing) j = {-0.5 + u(joint_rng), 0.6 + 0.6 * u(joint_rng), 0.3 + 0.7 * u(joint_rng), 6.3 * u(joint_rng)};
  return swing;
}

// What the fleet reports each cycle, built outside the timed part: every robot's odometry (and
// joint state with --joints), or the tracker's array of every object (--tracks); fed into a
// core as the node's callbacks would, inside it.
class FleetMessages {
 public:
  FleetMessages(size_t n, const Options& o, const std::vector<vadop_ros::BodyParams>& bodies, std::mt19937& rng)
      : n_(n),
        o_(o),
        bodies_(bodies),
        rng_(rng),
        sim_(n, o.area, o.turn, rng, o.fast, 5.0, o.ceiling),
        reported_(n),
        id_(n),
        noise_(0.0, o.noise > 0.0 ? o.noise : 1.0),
        arm_joints_(o.joints ? static_cast<size_t>(o.links - 1) : 0),
        swing_(drawSwings(n * arm_joints_, o.seed)) {
    odometry_.header.frame_id = "odom";
    objects_.header.frame_id = "odom";
    for (uint64_t& x : id_) x = next_id_++;
    for (size_t k = 1; k <= arm_joints_; ++k) joints_.name.push_back("j" + std::to_string(k));
    joints_.position.resize(arm_joints_);
    joints_.velocity.resize(arm_joints_);
  }

  const vadop_ros::WanderingFleet& fleet() const { return sim_; }

  // The fleet dt on to `now`: the tracker's array (with --churn's new ids) and the twists as
  // odometry reports them (noise drawn here, the same for the paired core).
  void step(double dt, const ros::Time& now) {
    sim_.step(dt, rng_);
    if (o_.tracks) trackObjects(dt, now);
    for (size_t i = 0; i < (o_.tracks ? 0 : n_); ++i) reported_[i] = {noisy(sim_[i].v), noisy(sim_[i].w)};
  }

  void feed(vadop_ros::MonitorCore& into, const ros::Time& now, vadop_ros::TransformSource& tf) {
    if (o_.tracks) into.tracks().onArray(0, objects_, now, tf);
    for (size_t i = 0; i < (o_.tracks ? 0 : n_); ++i) {
      const vadop_ros::WanderingFleet::Body& s = sim_[i];
      odometry_.header.stamp = now;
      odometry_.child_frame_id = bodies_[i].name;
      odometry_.pose.pose.position.x = s.x;
      odometry_.pose.pose.position.y = s.y;
      odometry_.pose.pose.position.z = s.z;
      odometry_.twist.twist.linear.z = s.vz;
      odometry_.pose.pose.orientation.z = std::sin(s.yaw / 2);
      odometry_.pose.pose.orientation.w = std::cos(s.yaw / 2);
      odometry_.twist.twist.linear.x = reported_[i].first;
      odometry_.twist.twist.angular.z = reported_[i].second;
      into.registry().onOdometry(i, odometry_, now);
      if (arm_joints_ > 0) feedJoints(into, i, now);
    }
  }

 private:
  double noisy(double x) { return o_.noise > 0.0 ? x + noise_(rng_) : x; }

  void trackObjects(double dt, const ros::Time& now) {
    objects_.header.stamp = now;
    objects_.objects.resize(n_);
    for (size_t i = 0; i < n_; ++i) {
      if (unit_(rng_) < o_.churn * dt) id_[i] = next_id_++;
      const vadop_ros::WanderingFleet::Body& b = sim_[i];
      vadop::TrackedObject& o = objects_.objects[i];
      o.id = std::to_string(id_[i]);
      o.shape.type = static_cast<uint8_t>(1 + i % 3);  // BOX, SPHERE, CYLINDER
      o.shape.dimensions = o.shape.type == shape_msgs::SolidPrimitive::BOX      ? std::vector<double>{0.6, 0.4, 0.5}
                           : o.shape.type == shape_msgs::SolidPrimitive::SPHERE ? std::vector<double>{0.3}
                                                                                : std::vector<double>{1.8, 0.3};
      o.pose.position.x = b.x;
      o.pose.position.y = b.y;
      o.pose.orientation.z = std::sin(b.yaw / 2);
      o.pose.orientation.w = std::cos(b.yaw / 2);
      o.twist.linear.x = b.v * std::cos(b.yaw);
      o.twist.linear.y = b.v * std::sin(b.yaw);
      o.twist.angular.z = b.w;
    }
  }

  void feedJoints(vadop_ros::MonitorCore& into, size_t i, const ros::Time& now) {
    joints_.header.stamp = now;
    const double t = now.toSec();
    for (size_t k = 0; k < arm_joints_; ++k) {
      const Swing& j = swing_[i * arm_joints_ + k];
      joints_.position[k] = j.centre + j.amplitude * std::sin(j.rate * t + j.phase);
      joints_.velocity[k] = j.amplitude * j.rate * std::cos(j.rate * t + j.phase);
    }
    if (into.registry().onJointState(i, joints_, now) != vadop_ros::InputResult::kAccepted) std::abort();
  }

  const size_t n_;
  const Options& o_;
  const std::vector<vadop_ros::BodyParams>& bodies_;
  std::mt19937& rng_;
  vadop_ros::WanderingFleet sim_;
  std::vector<std::pair<double, double>> reported_;  // (forward speed, turn rate) per robot
  nav_msgs::Odometry odometry_;
  vadop::TrackedObjectArray objects_;
  std::vector<uint64_t> id_;  // each tracked object's id
  uint64_t next_id_ = 0;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  std::normal_distribution<double> noise_;
  const size_t arm_joints_;
  std::vector<Swing> swing_;
  sensor_msgs::JointState joints_;
};

// Each gated body's planner sends its current twist at `command_time`: the time of
// VelocityGate::onCommand and what it decided, into r.
void commandGates(std::vector<vadop_ros::VelocityGate>& gates, vadop_ros::MonitorCore& core,
                  const vadop_ros::WanderingFleet& sim, const ros::Time& command_time, vadop_ros::TransformSource& tf,
                  Result& r) {
  for (size_t g = 0; g < gates.size(); ++g) {
    geometry_msgs::Twist cmd;
    cmd.linear.x = sim[g].v;
    cmd.angular.z = sim[g].w;
    const auto g0 = std::chrono::steady_clock::now();
    const geometry_msgs::Twist out = gates[g].onCommand(core, cmd, command_time, tf);
    r.gate_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - g0).count());
    if (!std::isfinite(out.linear.x)) std::abort();
    const vadop_ros::CommandCheck& check = gates[g].lastCheck();
    r.gate_evaluations += static_cast<double>(check.scale.evaluations);
    const std::string& reason = gates[g].state().reason;
    r.gate_slowed += reason == "slow" ? 1 : 0;
    r.gate_stopped += reason == "stop" ? 1 : 0;
    r.gate_unchecked += reason == "stale" ? 1 : 0;
  }
}

// --scan / --cloud: the sensors' messages, each built (outside the timed part) and fed to the
// node's sensors source in the first cycle at or after its stamp (15 Hz and 10 Hz of simulated
// time), as its subscription's handler would.
class SensorFeed {
 public:
  static constexpr double kScanRate = 15.0, kCloudRate = 10.0;
  static constexpr size_t kCloudPoints = 30000;

  SensorFeed(const Options& o, vadop_ros::MonitorCore& core, const ros::Time& start)
      : scan_on_(o.scan), cloud_on_(o.cloud), rng_(o.seed + 104729), next_scan_(start), next_cloud_(start) {
    for (const auto& s : core.bodiesSources()) {
      if (auto* found = dynamic_cast<vadop_ros::SensorsSource*>(s.get())) source_ = found;
    }
    if ((scan_on_ || cloud_on_) && !source_) std::abort();
  }

  // The messages due at `now` built: scanDue() / cloudDue() say which.
  void build(const vadop_ros::WanderingFleet& fleet, const ros::Time& now) {
    scan_due_ = scan_on_ && now >= next_scan_;
    cloud_due_ = cloud_on_ && now >= next_cloud_;
    if (scan_due_) scan_ = &sensors_.scan(fleet, now), next_scan_ += ros::Duration(1.0 / kScanRate);
    if (cloud_due_) cloud_ = &sensors_.cloud(fleet, now, kCloudPoints, rng_), next_cloud_ += ros::Duration(1.0 / kCloudRate);
  }

  // The due messages into the source: their wall ms into scan_ms / cloud_ms (when measured);
  // the total. A message the source does not accept is a bug of the bench.
  double feed(const ros::Time& now, vadop_ros::TransformSource& tf, bool measured, std::vector<double>& scan_ms,
              std::vector<double>& cloud_ms) {
    double total = 0.0;
    if (scan_due_) {
      const auto t0 = std::chrono::steady_clock::now();
      if (source_->onScan(0, *scan_, now, tf) != vadop_ros::InputResult::kAccepted) std::abort();
      total += note(t0, measured, scan_ms);
    }
    if (cloud_due_) {
      const auto t0 = std::chrono::steady_clock::now();
      if (source_->onCloud(scan_on_ ? 1 : 0, *cloud_, now, tf) != vadop_ros::InputResult::kAccepted) std::abort();
      total += note(t0, measured, cloud_ms);
    }
    return total;
  }

  // The last message's points kept and the points filtered over the run (on the bodies), into r.
  void summarize(Result& r) const {
    if (!source_) return;
    for (size_t k = 0; k < source_->sensors(); ++k) {
      const vadop_ros::SensorStatus& st = source_->status(k);
      const bool is_scan = source_->params(k).type == vadop_ros::SensorType::kScan;
      (is_scan ? r.scan_kept : r.cloud_kept) = st.points;
      (is_scan ? r.scan_filtered : r.cloud_filtered) = st.points_filtered_others + st.points_filtered_self;
    }
  }

 private:
  static double note(std::chrono::steady_clock::time_point t0, bool measured, std::vector<double>& into) {
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (measured) into.push_back(ms);
    return ms;
  }

  const bool scan_on_, cloud_on_;
  std::mt19937 rng_;  // the cloud's own: the fleet's sequence is the same without sensors
  vadop_ros::FleetSensors sensors_;
  vadop_ros::SensorsSource* source_ = nullptr;
  ros::Time next_scan_, next_cloud_;
  bool scan_due_ = false, cloud_due_ = false;
  const sensor_msgs::LaserScan* scan_ = nullptr;
  const sensor_msgs::PointCloud2* cloud_ = nullptr;
};

// The measured cycles' times (ms) and counts, summed.
struct CycleSamples {
  std::vector<double> cycle, cpu, feed, predict, markers, registry;
  std::vector<double> sensors, scan, cloud;  // per cycle; per message (--scan, --cloud)
  std::vector<double> paired;  // --paired: the shadow core's CPU ms
  double candidates = 0, impacts = 0, ignored_tested = 0, reused = 0, culled = 0;

  void add(double feed_ms, double cycle_ms, double cpu_ms, double markers_ms, const vadop_ros::CycleStats& st) {
    feed.push_back(feed_ms);
    cycle.push_back(cycle_ms);
    cpu.push_back(cpu_ms);
    predict.push_back(st.predict_seconds * 1e3);
    registry.push_back(st.registry_seconds * 1e3);
    markers.push_back(markers_ms);
    candidates += static_cast<double>(st.candidates);
    ignored_tested += static_cast<double>(st.ignored_tested);
    reused += static_cast<double>(st.reused);
    culled += static_cast<double>(st.slice_culled);
    impacts += static_cast<double>(st.impacts);
  }
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

// The figures of a run into r: means and percentiles of the samples, counts per cycle, and the
// core's state at the end.
void summarize(const CycleSamples& s, int cycles, const vadop_ros::MonitorCore& core, bool tracks, Result& r) {
  r.mean = mean(s.cycle);
  r.median = percentile(s.cycle, 0.5);
  r.p95 = percentile(s.cycle, 0.95);
  r.max = *std::max_element(s.cycle.begin(), s.cycle.end());
  r.cpu_mean = mean(s.cpu);
  if (!s.paired.empty()) {
    std::vector<double> ratio;
    for (size_t k = 0; k < s.cpu.size(); ++k) ratio.push_back(s.cpu[k] / s.paired[k]);
    r.paired_median = percentile(s.paired, 0.5);
    r.cpu_median = percentile(s.cpu, 0.5);
    r.ratio_median = percentile(ratio, 0.5);
    r.ratio_p25 = percentile(ratio, 0.25);
    r.ratio_p75 = percentile(ratio, 0.75);
  }
  r.cpu_p95 = percentile(s.cpu, 0.95);
  r.feed_mean = mean(s.feed);
  r.predict_mean = mean(s.predict);
  r.registry_mean = mean(s.registry);
  r.markers_mean = mean(s.markers);
  r.sensors_mean = mean(s.sensors);
  r.scan_median = s.scan.empty() ? 0.0 : percentile(s.scan, 0.5);
  r.cloud_median = s.cloud.empty() ? 0.0 : percentile(s.cloud, 0.5);
  r.candidates = s.candidates / cycles;
  r.ignored_tested = s.ignored_tested / cycles;
  r.reused = s.reused / cycles;
  r.culled = s.culled / cycles;
  r.impacts = s.impacts / cycles;
  r.elements = core.lastStats().elements_in_world;
  if (tracks) {
    r.tracked = core.lastStats().tracked_objects;
    r.expired = core.tracks().status(0).objects_expired;
  }
}

// --paired: the same cycle on the shadow core (coherence off), its CPU time kept once measured;
// with `compare`, the two cores must have found as many impacts.
void pairedCycle(vadop_ros::MonitorCore& shadow, const vadop_ros::MonitorCore& core, FleetMessages& messages,
                 const ros::Time& now, vadop_ros::TransformSource& tf, bool measured, bool compare,
                 CycleSamples& samples) {
  const double b0 = threadCpuMs();
  messages.feed(shadow, now, tf);
  shadow.cycle(now, tf);
  const double ms = threadCpuMs() - b0;
  if (measured) {
    samples.paired.push_back(ms);
    if (shadow.lastStats().impacts != core.lastStats().impacts && compare) std::abort();
  }
}

Result run(size_t n, const Options& o) {
  std::mt19937 rng(o.seed);
  const vadop_ros::MonitorParams p = fleetParams(n, o);
  const std::string urdf = o.links >= 2 ? chainUrdf(o.links, o.joints) : "";
  vadop_ros::MonitorCore core(p, urdfReader(urdf));
  // --paired: a second core, coherence off, fed the same messages.
  std::unique_ptr<vadop_ros::MonitorCore> shadow;
  if (o.paired) {
    vadop_ros::MonitorParams q = p;
    q.coherence_clearance = 0.0;
    shadow = std::make_unique<vadop_ros::MonitorCore>(q, urdfReader(urdf));
  }
  std::vector<vadop_ros::VelocityGate> gate_list;
  for (size_t i = 0; i < std::min(o.gates, n); ++i) gate_list.emplace_back(i, core.registry());
  Result r;
  FleetMessages messages(n, o, p.bodies, rng);
  NoTf tf;
  const double dt = 1.0 / o.rate;
  ros::Time now(1000.0);
  CycleSamples samples;
  SensorFeed sensors(o, core, now);
  double process_cpu0 = 0.0, simulation_cpu = 0.0;  // the fleet's and sensors' simulation, left out
  for (int c = 0; c < o.warmup + o.cycles; ++c) {
    const bool measured = c >= o.warmup;
    if (c == o.warmup) process_cpu0 = processCpuMs();
    const double sim0 = threadCpuMs();
    now += ros::Duration(dt);
    messages.step(dt, now);
    sensors.build(messages.fleet(), now);
    if (measured) simulation_cpu += threadCpuMs() - sim0;
    // The paired cycle before or after this one in turn.
    if (shadow && c % 2 == 0) pairedCycle(*shadow, core, messages, now, tf, measured, false, samples);
    const double cpu0 = threadCpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    messages.feed(core, now, tf);
    const double sensors_ms = sensors.feed(now, tf, measured, samples.scan, samples.cloud);
    const auto t1 = std::chrono::steady_clock::now();
    core.cycle(now, tf);
    const auto t2 = std::chrono::steady_clock::now();
    const double cpu2 = threadCpuMs();
    if (shadow && c % 2 == 1) pairedCycle(*shadow, core, messages, now, tf, measured, true, samples);
    double mk = 0.0;
    if (o.markers) {
      const auto m = core.markers();
      mk = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t2).count();
      if (m.markers.empty()) std::abort();
    }
    if (!measured) continue;
    if (o.scan || o.cloud) samples.sensors.push_back(sensors_ms);
    // Each gated body's planner sends its current twist half a period after the cycle.
    commandGates(gate_list, core, messages.fleet(), now + ros::Duration(0.5 * dt), tf, r);
    samples.add(std::chrono::duration<double, std::milli>(t1 - t0).count(),
                std::chrono::duration<double, std::milli>(t2 - t0).count(), cpu2 - cpu0, mk, core.lastStats());
  }
  r.process_cpu = (processCpuMs() - process_cpu0 - simulation_cpu) / o.cycles;
  r.n = n;
  summarize(samples, o.cycles, core, o.tracks, r);
  sensors.summarize(r);
  return r;
}

std::vector<size_t> parseList(const std::string& s) {
  std::vector<size_t> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stoul(item));
  return out;
}

// The command line: the body counts to run, or the start-up sizes (--startup), and the options.
struct CommandLine {
  std::vector<size_t> sizes = {100, 1000, 5000};
  std::vector<size_t> startup_sizes;
  Options o;
};

// Sets one option from argv[i] (and its value, argv[++i]); false for an unknown one. Throws
// std::exception on a bad value.
bool parseOption(int argc, char** argv, int& i, CommandLine& cl) {
  const std::string a = argv[i];
  auto next = [&]() -> std::string {
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s needs a value\n", a.c_str());
      std::exit(2);
    }
    return argv[++i];
  };
  Options& o = cl.o;
  if (a == "--bodies") cl.sizes = parseList(next());
  else if (a == "--cycles") o.cycles = std::stoi(next());
  else if (a == "--warmup") o.warmup = std::stoi(next());
  else if (a == "--rate") o.rate = std::stod(next());
  else if (a == "--horizon") o.horizon = std::stod(next());
  else if (a == "--area") o.area = std::stod(next());
  else if (a == "--turn") o.turn = std::stod(next());
  else if (a == "--seed") o.seed = static_cast<unsigned>(std::stoul(next()));
  else if (a == "--markers") o.markers = true;
  else if (a == "--links") o.links = std::stoi(next());
  else if (a == "--joints") o.joints = true;
  else if (a == "--gates") o.gates = std::stoul(next());
  else if (a == "--gate-rule") o.gate_rule = next();
  else if (a == "--startup") cl.startup_sizes = parseList(next());
  else if (a == "--tracks") o.tracks = true;
  else if (a == "--threads") o.threads = std::stoi(next());
  else if (a == "--fast") o.fast = std::stod(next());
  else if (a == "--3d") o.ceiling = std::stod(next());
  else if (a == "--broadphase") o.broad_phase = next();
  else if (a == "--time-slices") o.time_slices = std::stoi(next());
  else if (a == "--churn") o.churn = std::stod(next());
  else if (a == "--noise") o.noise = std::stod(next());
  else if (a == "--paired") o.paired = true;
  else if (a == "--scan") o.scan = true;
  else if (a == "--cloud") o.cloud = true;
  else if (a == "--coherence") {
    const std::string v = next();
    const size_t comma = v.find(',');
    o.clearance = std::stod(v.substr(0, comma));
    if (comma != std::string::npos) o.lookahead = std::stod(v.substr(comma + 1));
  }
  else return false;
  return true;
}

// The command line into cl; -1 to go on, else the exit status (usage, a bad value).
int parseCommandLine(int argc, char** argv, CommandLine& cl) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    try {
      if (parseOption(argc, argv, i, cl)) continue;
      std::fprintf(stderr,
                   "usage: %s [--bodies 100,1000,5000] [--cycles 150] [--warmup 15] [--rate 30] [--horizon 2] "
                   "[--area 6] [--turn 0.5] [--markers] [--seed 1] [--links K [--joints]] [--gates G [--gate-rule held|braking|instant]] [--tracks [--churn C]] "
                   "[--threads T] [--fast F] [--3d H] [--broadphase vadop|grid|sap|vadop_sap|brute] [--time-slices K] [--noise S] "
                   "[--coherence C[,L] [--paired]] [--scan] [--cloud] | "
                   "--startup 5000,50000\n",
                   argv[0]);
      return a == "--help" || a == "-h" ? 0 : 2;
    } catch (const std::exception&) {
      std::fprintf(stderr, "bad value for %s\n", a.c_str());
      return 2;
    }
  }
  return -1;
}

// The options that cannot go together or are out of range: the line saying why, and false.
bool optionsConsistent(const CommandLine& cl) {
  const Options& o = cl.o;
  if (o.gates > 0 && o.tracks) {
    std::fprintf(stderr, "--gates needs robots on odometry; with --tracks every body is a tracked object\n");
    return false;
  }
  if (o.paired && !(o.clearance > 0)) {
    std::fprintf(stderr, "--paired compares against coherence off: give --coherence C[,L] with C > 0\n");
    return false;
  }
  if (o.paired && (o.scan || o.cloud)) {
    std::fprintf(stderr, "--paired feeds odometry only: not with --scan or --cloud\n");
    return false;
  }
  if (o.cycles < 1 || o.warmup < 0 || !(o.rate > 0) || !(o.horizon >= 0) || !(o.area > 0) || !(o.turn >= 0) ||
      cl.sizes.empty() || o.links < 1) {
    std::fprintf(stderr, "bad arguments\n");
    return false;
  }
  try {  // the predictor's settings, named as the node names them
    vadop_ros::checkPredictorParams(monitorParams(o));
  } catch (const vadop_ros::ParamError& e) {
    std::fprintf(stderr, "bad arguments: %s\n", e.what());
    return false;
  }
  return true;
}

// The workload's lines after the first two: robots, broad phase, noise, coherence, and the
// columns' header.
void printWorkload(const Options& o) {
  if (o.links >= 2 && !o.joints) std::printf("  each body a %d-link robot (URDF, links rigid with the body)\n", o.links);
  if (o.joints) {
    std::printf("  each body a mobile manipulator: a base and a %d-link arm on revolute joints, one joint state "
                "per cycle, links predicted along the joints' motion\n", o.links - 1);
  }
  std::printf("  broad phase %s%s%s\n", o.broad_phase.c_str(), o.fast > 0 ? ", a share of fast bodies (5x)" : "",
              o.ceiling > 0 ? ", 3D (climbing and sinking)" : "");
  if (o.scan) std::printf("  a 1,081-beam LaserScan at 15 Hz from the room's centre (sensor \"scan\")\n");
  if (o.cloud) std::printf("  a 30,000-point PointCloud2 at 10 Hz, voxel 0.05 m (sensor \"cloud\")\n");
  if (o.noise > 0) std::printf("  odometry twist noise %.3f (m/s, rad/s; 1 sigma, every message)\n", o.noise);
  if (o.clearance > 0) {
    std::printf("  temporal coherence: clearance %.3f m, lookahead %.2f s (~coherence_clearance, ~coherence_lookahead)\n",
                o.clearance, o.lookahead);
  } else {
    std::printf("  no temporal coherence (--coherence C[,L] turns it on)\n");
  }
  std::printf("  wall = steady clock; cpu = CPU time of the thread (what one core spends, whatever the load)\n");
  std::printf("%7s %9s %9s %9s %9s %9s %9s %8s %10s %10s %9s %11s %9s %9s %9s\n", "bodies", "cpu_mean", "cpu_p95",
              "wall_mean", "wall_med", "wall_p95", "wall_max", "feed", "predict", "markers", "cpu%per", "candidates",
              "impacts", "culled", "registry");
}

// One run's line, and the lines its options add (certificates, paired, tracks, links, gates).
void printResult(const Result& r, const Options& o, double period_ms) {
  std::printf("%7zu %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %8.3f %10.3f %10.3f %8.1f%% %11.1f %9.1f %9.1f %9.3f\n", r.n,
              r.cpu_mean, r.cpu_p95, r.mean, r.median, r.p95, r.max, r.feed_mean, r.predict_mean, r.markers_mean,
              100.0 * r.cpu_mean / period_ms, r.candidates, r.impacts, r.culled, r.registry_mean);
  if (o.clearance > 0) std::printf("  (of the candidate pairs, %.1f per cycle answered by certificates)\n", r.reused);
  if (o.paired) {
    std::printf("  paired, the same cycles without coherence (alternating which runs first): CPU ms median %.3f "
                "against %.3f; per-cycle ratio median %.3f (quartiles %.3f-%.3f)\n",
                r.cpu_median, r.paired_median, r.ratio_median, r.ratio_p25, r.ratio_p75);
  }
  // (--paired: the shadow core's cycles would count too, so not printed.)
  if (!o.paired) {
    std::printf("  process CPU (every thread, the gates' commands included, the fleet's and sensors' simulation "
                "not): %.3f ms a cycle\n", r.process_cpu);
  }
  if (o.scan || o.cloud) {
    std::printf("  sensors: %.3f ms a cycle (in feed); per message median: scan %.3f ms, cloud %.3f ms; "
                "points of the last message kept: scan %zu, cloud %zu; filtered on the bodies over the run: "
                "scan %llu, cloud %llu\n",
                r.sensors_mean, r.scan_median, r.cloud_median, r.scan_kept, r.cloud_kept,
                static_cast<unsigned long long>(r.scan_filtered), static_cast<unsigned long long>(r.cloud_filtered));
  }
  if (o.tracks) {
    std::printf("  (tracked objects in one array per cycle: %zu in the world at the end, %llu expired over the run; "
                "feed = Tracks::onArray)\n",
                r.tracked, static_cast<unsigned long long>(r.expired));
  }
  if (o.links >= 2) {
    std::printf("  (%zu elements in the world; narrow-phase calls per cycle on pairs then ignored: %.1f)\n",
                r.elements, r.ignored_tested);
  }
  std::fflush(stdout);
  if (!r.gate_ms.empty()) {
    const double count = static_cast<double>(r.gate_ms.size());
    std::printf("  gates: %zu commands, latency (ms) median %.3f p99 %.3f max %.3f; %.1f scales tried per command; "
                "slowed %.1f%%, stopped %.1f%%, not checked %.1f%%\n",
                r.gate_ms.size(), percentile(r.gate_ms, 0.5), percentile(r.gate_ms, 0.99),
                *std::max_element(r.gate_ms.begin(), r.gate_ms.end()), r.gate_evaluations / count,
                100.0 * r.gate_slowed / count, 100.0 * r.gate_stopped / count, 100.0 * r.gate_unchecked / count);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CommandLine cl;
  const int status = parseCommandLine(argc, argv, cl);
  if (status >= 0) return status;
  if (!cl.startup_sizes.empty()) {
    startup(cl.startup_sizes);
    return 0;
  }
  if (!optionsConsistent(cl)) return 2;
  const Options& o = cl.o;
  const double period_ms = 1e3 / o.rate;
  std::printf("vadop_monitor_bench: MonitorCore cycle (odometry in + registry + world + ImpactArray), prediction on "
              "%d thread(s)%s\n", o.threads, o.threads == 1 ? "" : " (cpu = the cycle thread's only: read wall)");
  std::printf("  %d cycles after %d warm-up, %.0f Hz (period %.2f ms), horizon %.1f s, %.1f m^2 per body, "
              "0.3-1.5 m/s, turning at up to %.2f rad/s%s\n",
              o.cycles, o.warmup, o.rate, period_ms, o.horizon, o.area, o.turn,
              o.markers ? ", markers built every cycle" : "");
  if (o.joints && o.links < 2) {
    std::fprintf(stderr, "--joints needs --links K with K >= 2\n");
    return 2;
  }
  printWorkload(o);
  int verdict = -1;
  for (const size_t n : cl.sizes) {
    const Result r = run(n, o);
    printResult(r, o, period_ms);
    if (n == 1000) verdict = r.cpu_mean < period_ms / 3.0 ? 1 : 0;
  }
  std::printf("  (ms per cycle, wall clock; feed = odometry into the registry; of the cycle after it, registry = the "
              "registry's update (tf, motions) and its copy into the world, predict = World::predict, the rest the "
              "ImpactArray)\n");
  if (verdict >= 0) {
    std::printf("1000 bodies at %.0f Hz: mean cycle (CPU time) %s a third of the period (%.2f ms) on one core\n",
                o.rate, verdict ? "IS under" : "is NOT under", period_ms / 3.0);
  }
  return 0;
}
