// libFuzzer target: the node's message path. The input bytes are decoded into a sequence of
// operations on a MonitorCore built from a small fixed configuration (three primitive bodies,
// one with TwistStamped and a pose from tf; a rigid URDF body and a URDF body whose links come
// from tf, both test/data/two_link.urdf; two static obstacles; temporal coherence on, so that
// certificates meet every hostile input too):
//   odometry / twist / planned-path / joint-state / joint-trajectory messages with arbitrary doubles (NaN, Inf, huge, tiny) and arbitrary
//   stamps (sec up to 2^32 - 1) and receipt times; tf poses with arbitrary values and stamps;
//   clock steps, jumps forward and back (a jump back resets, as the node's timer does);
//   horizon / rate / padding through MonitorCore::reconfigure (the node's dynamic_reconfigure
//   path); cycles; markers.
// After every cycle (and at the end, after a last cycle):
//  - no exception escapes (libFuzzer reports an uncaught one as a crash);
//  - every published impact has finite fields, time_to_impact in [0, horizon], a unit normal,
//    time_of_impact = stamp + time_to_impact (saturated at the end of ROS time), and names two
//    bodies of the configuration, not both static;
//  - the settings in effect are finite and in their ranges whatever was requested.
// A broken invariant prints it and calls __builtin_trap (the input is saved as a crash).
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/params.h"

#include "yaml_xmlrpc.h"

#include <fuzzer/FuzzedDataProvider.h>
#include <ros/console.h>
#include <ros/time.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>

namespace {

using vadop_ros::MonitorCore;

constexpr size_t kMaxOps = 200;

class FuzzTf : public vadop_ros::TransformSource {
 public:
  struct Entry {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // in "odom"
    ros::Time stamp;
  };
  std::map<std::string, Entry> frames;

  bool lookup(const std::string& target, const std::string& source, const ros::Time&, Eigen::Isometry3d& pose,
              ros::Time& stamp, std::string& error) override {
    const Entry* t = find(target);
    const Entry* s = find(source);
    if (!t || !s) {
      error = "frame does not exist";
      return false;
    }
    pose = t->pose.inverse() * s->pose;
    stamp = std::max(t->stamp, s->stamp);
    return true;
  }

 private:
  const Entry* find(const std::string& f) const {
    static const Entry root;
    if (f == "odom") return &root;
    const auto it = frames.find(f);
    return it == frames.end() ? nullptr : &it->second;
  }
};

std::string urdfText() {
  std::string text = vadop_test::readFile(VADOP_TEST_DATA_DIR "/two_link.urdf");
  const std::string key = "@DATA_DIR@";
  for (size_t p = text.find(key); p != std::string::npos; p = text.find(key)) text.replace(p, key.size(), VADOP_TEST_DATA_DIR);
  return text;
}

const char* kConfig = R"(
fixed_frame: odom
rate: 30.0
horizon: 2.0
stale_timeout: 0.5
max_stamp_skew: 5.0
coherence_clearance: 0.05
bodies:
  - {name: a, odom_topic: /a, path_topic: /a/plan, shape: {type: sphere, radius: 0.5}}
  - {name: b, odom_topic: /b, shape: {type: box, size: [1, 0.5, 0.3]}}
  - {name: c, twist_topic: /c, frame: c_link, shape: {type: capsule, radius: 0.2, length: 1.0}}
  - {name: robot, odom_topic: /robot, path_topic: /robot/plan, after_path: hold, robot_description: /robot_description}
  - {name: arm, odom_topic: /arm, robot_description: /robot_description, tf_prefix: arm}
  - {name: jarm, odom_topic: /jarm, robot_description: /robot_description, joint_states_topic: /jarm/joints,
     joint_trajectory_topic: /jarm/trajectory}
static_obstacles:
  - {name: wall, shape: {type: box, size: [0.2, 10, 2]}, pose: {position: [5, 0, 0]}}
  - {name: post, shape: {type: cylinder, radius: 0.1, length: 2}, pose: {position: [0, 3, 0]}}
tracks:
  - {topic: /people, default_shape: {type: cylinder, radius: 0.3, length: 1.8}, timeout: 0.5}
  - {topic: /carts, timeout: 2.0}
ignore_pairs: [["people/7", "*"]]
)";

// The default loader, its results (and errors: a package:// URI runs rospack) kept across
// inputs: one core per input must cost microseconds, not a process.
vadop_ros::MeshData cachedMesh(const std::string& uri, const Eigen::Vector3d& scale) {
  static const vadop_ros::MeshLoader load = vadop_ros::makeDefaultMeshLoader();
  static std::map<std::string, std::pair<vadop_ros::MeshData, std::string>> cache;
  const std::string key = uri + " " + std::to_string(scale.x()) + " " + std::to_string(scale.y()) + " " +
                          std::to_string(scale.z());
  auto it = cache.find(key);
  if (it == cache.end()) {
    std::pair<vadop_ros::MeshData, std::string> entry;
    try {
      entry.first = load(uri, scale);
    } catch (const std::exception& e) {
      entry.second = e.what();
    }
    it = cache.emplace(key, std::move(entry)).first;
  }
  if (!it->second.second.empty()) throw std::runtime_error(it->second.second);
  return it->second.first;
}

std::unique_ptr<MonitorCore> makeCore() {
  static const std::string urdf = urdfText();
  static const vadop_ros::MonitorParams params = vadop_ros::parseParams(vadop_test::yaml(kConfig));
  return std::make_unique<MonitorCore>(
      params,
      [](const std::string& name, std::string& value) {
        if (name != "/robot_description") return false;
        value = urdf;
        return true;
      },
      cachedMesh);
}

[[noreturn]] void broken(const std::string& what) {
  std::fprintf(stderr, "fuzz_monitor: invariant broken: %s\n", what.c_str());
  std::fflush(stderr);
  __builtin_trap();
}

// A double: mostly ordinary values, often the hostile ones.
double pickDouble(FuzzedDataProvider& in) {
  static const double kSpecial[] = {std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity(),
                                    0.0, -0.0, 1e-300, 5e-324, 1e300, -1e300, 1e200, 1e7, -1e7, 1.0000001e7, 2e7,
                                    1e4, -1e4, 1.0001e4, 1e9, 1e12, std::numeric_limits<double>::max()};
  switch (in.ConsumeIntegralInRange<int>(0, 3)) {
    case 0: return kSpecial[in.ConsumeIntegralInRange<size_t>(0, sizeof kSpecial / sizeof kSpecial[0] - 1)];
    case 1: return in.ConsumeFloatingPoint<double>();
    default: return in.ConsumeFloatingPointInRange<double>(-20.0, 20.0);
  }
}

// A time: near `now` (within a few seconds, the common case) or anywhere in ROS time.
ros::Time pickTime(FuzzedDataProvider& in, const ros::Time& now) {
  if (in.ConsumeBool()) {
    return vadop_ros::addSeconds(now, in.ConsumeFloatingPointInRange<double>(-8.0, 8.0));
  }
  const uint32_t sec = in.ConsumeIntegral<uint32_t>();
  const uint32_t nsec = in.ConsumeIntegralInRange<uint32_t>(0, 999999999);
  return ros::Time(sec, nsec);
}

void checkCycle(const MonitorCore& core, const vadop::ImpactArray& out, const ros::Time& now) {
  const auto s = core.settings();
  if (!(std::isfinite(s.horizon) && s.horizon >= 0.0 && s.horizon <= vadop_ros::kMaxHorizon)) broken("horizon");
  if (!(std::isfinite(s.rate) && s.rate >= vadop_ros::kMinRate && s.rate <= vadop_ros::kMaxRate)) broken("rate");
  if (!(std::isfinite(s.padding) && s.padding >= 0.0 && s.padding <= vadop_ros::kMaxPadding)) broken("padding");
  if (out.header.stamp != now) broken("header stamp");
  std::map<std::string, bool> bodies;  // name -> static
  for (const auto& b : core.registry().bodies()) bodies[b.name] = b.is_static;
  for (const auto& t : core.tracks().slots()) {
    if (t.alive) bodies[t.name] = false;  // in the world this cycle (expired ones left before it)
  }
  for (const vadop::Impact& i : out.impacts) {
    const std::string pair = i.body_a + "/" + i.link_a + " <-> " + i.body_b + "/" + i.link_b;
    if (i.body_a == "people/7" || i.body_b == "people/7") broken("~ignore_pairs [people/7, *] not applied: " + pair);
    if (!bodies.count(i.body_a) || !bodies.count(i.body_b)) broken("impact names an unknown body: " + pair);
    if (bodies[i.body_a] && bodies[i.body_b]) broken("static-static impact: " + pair);
    if (!(std::isfinite(i.time_to_impact) && i.time_to_impact >= 0.0 && i.time_to_impact <= s.horizon)) {
      broken("time_to_impact " + std::to_string(i.time_to_impact) + " outside [0, horizon]: " + pair);
    }
    if (!(std::isfinite(i.point.x) && std::isfinite(i.point.y) && std::isfinite(i.point.z))) broken("point: " + pair);
    if (!std::isfinite(i.closing_speed)) broken("closing_speed: " + pair);
    const double n = std::sqrt(i.normal.x * i.normal.x + i.normal.y * i.normal.y + i.normal.z * i.normal.z);
    if (!(std::fabs(n - 1.0) <= 1e-6)) broken("normal of length " + std::to_string(n) + ": " + pair);
    const double dt = vadop_ros::secondsBetween(i.time_of_impact, now);
    if (i.time_of_impact != ros::TIME_MAX && !(std::fabs(dt - i.time_to_impact) <= 1e-6)) {
      broken("time_of_impact - stamp != time_to_impact: " + pair);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  ros::Time::init();
  // The warnings of dropped messages would flood the output.
  if (ros::console::set_logger_level(ROSCONSOLE_ROOT_LOGGER_NAME, ros::console::levels::Fatal)) {
    ros::console::notifyLoggerLevelsChanged();
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // One core per input: the configuration is fixed, its construction (URDF, meshes) is cheap.
  std::unique_ptr<MonitorCore> core = makeCore();
  FuzzTf tf;
  FuzzedDataProvider in(data, size);
  ros::Time now(1700000000, 0);
  ros::Time last_cycle;
  const auto& bodies = core->registry().bodies();
  std::vector<size_t> odom_bodies, twist_bodies;
  for (size_t i = 0; i < bodies.size(); ++i) {
    if (bodies[i].is_static) continue;
    (bodies[i].params.source == vadop_ros::VelocitySource::kOdometry ? odom_bodies : twist_bodies).push_back(i);
  }
  static const char* kFrames[] = {"c_link", "a_child", "arm/base_link", "arm/mast", "arm/arm", "arm/pkg_mesh"};
  auto cycle = [&]() {
    if (!last_cycle.isZero() && now < last_cycle) core->reset();  // as the node's timer does
    last_cycle = now;
    const vadop::ImpactArray& out = core->cycle(now, tf);
    checkCycle(*core, out, now);
  };

  for (size_t op = 0; op < kMaxOps && in.remaining_bytes() > 0; ++op) {
    switch (in.ConsumeIntegralInRange<int>(0, 12)) {
      case 0: {  // odometry
        nav_msgs::Odometry m;
        const size_t bi = odom_bodies[in.ConsumeIntegralInRange<size_t>(0, odom_bodies.size() - 1)];
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        m.header.frame_id = in.ConsumeBool() ? "odom" : kFrames[in.ConsumeIntegralInRange<int>(0, 5)];
        m.child_frame_id = in.ConsumeBool() ? "" : "a_child";
        auto& p = m.pose.pose;
        p.position.x = pickDouble(in);
        p.position.y = pickDouble(in);
        p.position.z = pickDouble(in);
        if (in.ConsumeBool()) {
          p.orientation.w = 1.0;
        } else {
          p.orientation.x = pickDouble(in);
          p.orientation.y = pickDouble(in);
          p.orientation.z = pickDouble(in);
          p.orientation.w = pickDouble(in);
        }
        auto& t = m.twist.twist;
        t.linear.x = pickDouble(in);
        t.linear.y = pickDouble(in);
        t.linear.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
        t.angular.x = in.ConsumeBool() ? 0.0 : pickDouble(in);
        t.angular.y = in.ConsumeBool() ? 0.0 : pickDouble(in);
        t.angular.z = pickDouble(in);
        core->registry().onOdometry(bi, m, in.ConsumeBool() ? now : pickTime(in, now));
        break;
      }
      case 1: {  // twist
        geometry_msgs::TwistStamped m;
        const size_t bi = twist_bodies[in.ConsumeIntegralInRange<size_t>(0, twist_bodies.size() - 1)];
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        m.header.frame_id = in.ConsumeBool() ? "" : kFrames[in.ConsumeIntegralInRange<int>(0, 5)];
        m.twist.linear.x = pickDouble(in);
        m.twist.linear.y = pickDouble(in);
        m.twist.linear.z = pickDouble(in);
        m.twist.angular.x = pickDouble(in);
        m.twist.angular.y = pickDouble(in);
        m.twist.angular.z = pickDouble(in);
        core->registry().onTwist(bi, m, in.ConsumeBool() ? now : pickTime(in, now));
        break;
      }
      case 2: {  // a tf frame's pose and stamp
        FuzzTf::Entry& e = tf.frames[kFrames[in.ConsumeIntegralInRange<int>(0, 5)]];
        e.pose = Eigen::Isometry3d::Identity();
        e.pose.translation() = Eigen::Vector3d(pickDouble(in), pickDouble(in), pickDouble(in));
        const double yaw = pickDouble(in);
        if (std::isfinite(yaw)) e.pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        e.stamp = pickTime(in, now);
        break;
      }
      case 3:  // the clock steps forward
        now = vadop_ros::addSeconds(now, in.ConsumeFloatingPointInRange<double>(0.0, 2.0));
        break;
      case 4:  // the clock jumps (forward or back, anywhere)
        now = ros::Time(in.ConsumeIntegral<uint32_t>(), in.ConsumeIntegralInRange<uint32_t>(0, 999999999));
        break;
      case 5: {  // dynamic_reconfigure
        vadop_ros::RuntimeSettings s = core->settings();
        const int which = in.ConsumeIntegralInRange<int>(0, 3);
        if (which == 0 || which == 3) s.horizon = pickDouble(in);
        if (which == 1 || which == 3) s.rate = pickDouble(in);
        if (which == 2 || which == 3) s.padding = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(0, 0.5)
                                                                   : pickDouble(in);
        std::vector<std::string> errors;
        core->reconfigure(s, &errors);
        break;
      }
      case 6:
        cycle();
        break;
      case 7:
        cycle();
        (void)core->markers();
        break;
      case 8:
        core->reset();
        break;
      case 9: {  // a planned path (bodies a and robot have a path_topic)
        nav_msgs::Path m;
        const size_t bi = core->registry().find(in.ConsumeBool() ? "a" : "robot");
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        m.header.frame_id = in.ConsumeBool() ? "odom" : kFrames[in.ConsumeIntegralInRange<int>(0, 5)];
        const size_t n = in.ConsumeIntegralInRange<size_t>(0, 12);
        ros::Time t = in.ConsumeBool() ? now : pickTime(in, now);
        for (size_t k = 0; k < n; ++k) {
          geometry_msgs::PoseStamped p;
          // Mostly increasing stamps (a usable plan), sometimes anything.
          t = in.ConsumeBool() ? vadop_ros::addSeconds(t, in.ConsumeFloatingPointInRange<double>(0.0, 0.5))
                               : pickTime(in, now);
          p.header.stamp = t;
          p.pose.position.x = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-5.0, 5.0) : pickDouble(in);
          p.pose.position.y = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-5.0, 5.0) : pickDouble(in);
          p.pose.position.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
          p.pose.orientation.w = in.ConsumeBool() ? 1.0 : pickDouble(in);
          p.pose.orientation.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
          m.poses.push_back(p);
        }
        core->registry().onPath(bi, m, in.ConsumeBool() ? now : pickTime(in, now), tf);
        break;
      }
      case 10: {  // joint states of jarm (its URDF's one movable joint is arm_joint)
        sensor_msgs::JointState m;
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        static const char* kJoints[] = {"arm_joint", "mast_joint", "nope", ""};
        const size_t n = in.ConsumeIntegralInRange<size_t>(0, 3);
        for (size_t k = 0; k < n; ++k) {
          m.name.push_back(in.ConsumeBool() ? "arm_joint" : kJoints[in.ConsumeIntegralInRange<int>(0, 3)]);
          if (in.ConsumeIntegralInRange<int>(0, 7) > 0) m.position.push_back(in.ConsumeBool() ? 0.3 : pickDouble(in));
          if (in.ConsumeBool()) m.velocity.push_back(in.ConsumeBool() ? 0.5 : pickDouble(in));
        }
        core->registry().onJointState(static_cast<size_t>(core->registry().find("jarm")), m,
                                      in.ConsumeBool() ? now : pickTime(in, now));
        break;
      }
      case 11: {  // a joint trajectory of jarm
        trajectory_msgs::JointTrajectory m;
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        if (in.ConsumeIntegralInRange<int>(0, 7) > 0) m.joint_names.push_back("arm_joint");
        if (in.ConsumeIntegralInRange<int>(0, 7) == 0) m.joint_names.push_back(in.ConsumeBool() ? "arm_joint" : "nope");
        const size_t points = in.ConsumeIntegralInRange<size_t>(0, 6);
        double from_start = 0.0;
        for (size_t k = 0; k < points; ++k) {
          trajectory_msgs::JointTrajectoryPoint p;
          for (size_t i = 0; i < m.joint_names.size() + (in.ConsumeIntegralInRange<int>(0, 7) == 0 ? 1 : 0); ++i) {
            p.positions.push_back(in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-3.0, 3.0) : pickDouble(in));
            if (in.ConsumeBool()) p.velocities.push_back(in.ConsumeBool() ? 0.5 : pickDouble(in));
          }
          from_start += in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(0.0, 1.0) : pickDouble(in);
          p.time_from_start = std::isfinite(from_start) && std::fabs(from_start) < 1e6 ? ros::Duration(from_start)
                                                                                      : ros::Duration(0.5);
          m.points.push_back(p);
        }
        core->registry().onJointTrajectory(static_cast<size_t>(core->registry().find("jarm")), m,
                                           in.ConsumeBool() ? now : pickTime(in, now));
        break;
      }
      case 12: {  // a tracker's array (ids from a small set: objects appear, move, repeat, vanish)
        vadop::TrackedObjectArray m;
        m.header.stamp = in.ConsumeBool() ? ros::Time() : pickTime(in, now);
        m.header.frame_id = in.ConsumeBool() ? "odom" : kFrames[in.ConsumeIntegralInRange<int>(0, 5)];
        const size_t n = in.ConsumeIntegralInRange<size_t>(0, 8);
        for (size_t k = 0; k < n; ++k) {
          vadop::TrackedObject o;
          o.id = in.ConsumeBool() ? std::to_string(in.ConsumeIntegralInRange<int>(0, 9)) : in.ConsumeRandomLengthString(4);
          o.shape.type = static_cast<uint8_t>(in.ConsumeIntegralInRange<int>(0, 5));
          const size_t dims = in.ConsumeIntegralInRange<size_t>(0, 4);
          for (size_t d = 0; d < dims; ++d) o.shape.dimensions.push_back(in.ConsumeBool() ? 0.5 : pickDouble(in));
          o.pose.position.x = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-5.0, 5.0) : pickDouble(in);
          o.pose.position.y = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-5.0, 5.0) : pickDouble(in);
          o.pose.position.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
          o.pose.orientation.w = in.ConsumeBool() ? 1.0 : pickDouble(in);
          o.pose.orientation.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
          o.twist.linear.x = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-2.0, 2.0) : pickDouble(in);
          o.twist.linear.y = in.ConsumeBool() ? 0.0 : pickDouble(in);
          o.twist.angular.z = in.ConsumeBool() ? 0.0 : pickDouble(in);
          m.objects.push_back(o);
        }
        core->tracks().onArray(in.ConsumeBool() ? 0 : 1, m, in.ConsumeBool() ? now : pickTime(in, now), tf);
        break;
      }
    }
  }
  cycle();
  return 0;
}
