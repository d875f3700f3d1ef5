// The private parameters of vadop_monitor: parsed and validated once at start-up.
// config/monitor.yaml documents every parameter with comments.
//
// Every error throws ParamError with a one-line message that names the parameter by its path
// under the node's private namespace, for example
//   ~bodies[2] ("robot_3").shape.radius: must be a number > 0, got -1
// Names: topics and robot_description parameter names follow roscpp's name rules
// (ros::names::validate; '~' names are refused), frames (fixed_frame, frame, tf_prefix) are
// tf2 frame ids (letters, digits, '_', '-', '.', '/' between segments; a leading '/' is removed).
// Numbers: NaN and Inf are refused everywhere; static obstacle positions are within
// vadop::kMaxCoordinate and shape dimensions within vadop::kMaxSize (vadop/error.h).
// Unknown keys at any level are errors naming the nearest valid key when the unknown one looks
// like its typo ("~pading: unknown key; did you mean \"padding\"? ..."): a typo would
// otherwise silently mean a default. Nothing else keeps parameters in the node's private
// namespace (robot_description names resolve in the global one; dynamic_reconfigure and
// diagnostic_updater write keys listed here).
#pragma once

#include <vadop/shapes.h>

#include <Eigen/Geometry>
#include <xmlrpcpp/XmlRpcValue.h>

#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ros {
class NodeHandle;
}

namespace vadop_ros {

class ParamError : public std::runtime_error {
 public:
  explicit ParamError(const std::string& what) : std::runtime_error(what) {}
};

enum class VelocitySource {
  kOdometry,  // nav_msgs/Odometry: pose in header.frame_id, twist in child_frame_id (REP 105)
  kTwist,     // geometry_msgs/TwistStamped; the pose comes from tf of `frame`
  kStates,    // the body's entry (by name) of a vadop/BodyStateArray: as odometry, twist in `frame`
};

// A velocity gate on a moving body (~bodies[i].gate): each geometry_msgs/Twist on cmd_vel_in
// (the body-frame command) is checked against every other body's predicted motion and
// published on cmd_vel_out scaled to what is clear (MonitorCore::checkCommand, VelocityGate).
struct GateParams {
  std::string cmd_vel_in, cmd_vel_out;  // topics, both required, different
  double time_before_collision = 1.0;   // s, (0, 60]: the window checked from each command
  double cmd_timeout = 0.5;             // s, (0, 3600]: no command for this long -> one zero Twist
  double state_timeout = 0.0;           // s, (0, 1e6]; the node's ~stale_timeout when not given
  std::vector<std::string> ignore;      // "body/link" globs (as ~ignore_pairs) the gate leaves out
  // s, [0, 2]: from a command's arrival until the body executes it (transport, the base's
  // controller); meanwhile the last forwarded command goes on.
  double reaction_time = 0.1;
  // Also check the future in which every other body brakes to standstill along its prediction
  // (at its own max_*_decel, at once without them): a scale is clear only when both futures are.
  bool others_may_stop = true;
};

struct BodyParams {
  std::string name;  // unique among bodies and static obstacles; no '/'
  VelocitySource source = VelocitySource::kOdometry;
  std::string topic;  // odom_topic, twist_topic or states_topic
  // The body's tf frame, the one its shape (or URDF reference link) is attached to.
  // Required with twist_topic; with odom_topic empty means the odometry's child_frame_id.
  std::string frame;
  // Exactly one geometry source:
  bool has_shape = false;
  vadop::Shape shape;             // when has_shape: unpadded, built with vadop::make*
  std::string robot_description;  // else: name of the parameter holding the URDF
  // URDF only: when tf_prefix is given (even empty), every link's pose comes from tf, frame
  // "<tf_prefix>/<link>" ("<link>" when empty); otherwise the links are rigid with the body.
  bool links_from_tf = false;
  std::string tf_prefix;
  // How hard the body can brake: m/s^2 in (0, 100] and rad/s^2 in (0, 1000]; both given or
  // neither (0, 0: no braking model). A gate brakes its own body at them; the others_may_stop
  // future brakes the others at theirs (at once when they have none).
  double max_linear_decel = 0.0, max_angular_decel = 0.0;
  bool hasBraking() const { return max_linear_decel > 0.0; }
  bool has_gate = false;
  GateParams gate;
  // Optional planned path (nav_msgs/Path, poses of the body frame with their stamps): while
  // one covers the present, the body is predicted along it instead of its twist (body_registry.h).
  std::string path_topic;  // empty: none
  // After the path's last pose: keep the last piece's twist (true, "continue") or stop there
  // ("hold").
  bool path_continue = true;
  // Optional sensor_msgs/JointState topic (robot_description bodies, not with tf_prefix): the
  // links' poses come from the URDF's kinematics at the joint positions, and they move with
  // the joint velocities over the horizon (body_registry.h).
  std::string joint_states_topic;  // empty: none
  // Optional trajectory_msgs/JointTrajectory topic (robot_description bodies, not with
  // tf_prefix): while a trajectory runs, the joints it names follow it (body_registry.h).
  std::string joint_trajectory_topic;  // empty: none
};

struct StaticObstacleParams {
  std::string name;
  bool has_shape = false;
  vadop::Shape shape;
  std::string robot_description;  // an environment URDF (links at zero joint positions)
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // in the fixed frame
};

// A source of tracked objects (~tracks[i]): a vadop/TrackedObjectArray topic whose objects are
// moving bodies named "<prefix>/<id>" while they keep appearing (tracks.h; parsed by its source,
// src/sources/tracked_objects_source.cpp).
struct TrackParams {
  std::string topic;
  std::string prefix;  // default: the topic's last name ("/people/tracks" -> "tracks"); no spaces
  bool has_default_shape = false;
  vadop::Shape default_shape;  // unpadded: objects whose shape type is 0
  double timeout = 0.5;        // s, (0, 3600]: absent from the arrays this long -> leaves the world
};

// A sensor whose every message is the set of obstacles it sees (~sensors[i]; sensors_source.h,
// parsed by its source, src/sources/sensors_source.cpp): one body "<name>" (no link) of the
// message's points (balls of point_radius) or occupied cells (boxes), static until the next
// message replaces them. config/monitor.yaml documents each key.
enum class SensorType {
  kScan,   // sensor_msgs/LaserScan
  kCloud,  // sensor_msgs/PointCloud2
  kMap,    // nav_msgs/OccupancyGrid
};
struct SensorParams {
  std::string name;  // unique among bodies, static obstacles and sensors; no '/'
  SensorType type = SensorType::kScan;
  std::string topic;
  // s, (0, 3600] ([0, 3600] for a map; 0: a map that never goes stale once received): no
  // accepted message this long -> its points leave the world and the gates stop (stale).
  double timeout = 0.5;
  double point_radius = 0.02;  // m, (0, 1]: each point a ball of this radius (maps: unused)
  // m, in the fixed frame: points outside [min_z, max_z] are dropped (a map's boxes span the band).
  double min_z = -std::numeric_limits<double>::infinity();
  double max_z = std::numeric_limits<double>::infinity();
  double voxel = 0.05;  // m, cloud only, [0, 10]: at most one point per voxel (0: every point)
  // m, [0, 10]: points within a monitored body or tracked object grown by filter_margin (the
  // sensor's own body: self_margin) are dropped.
  double filter_margin = 0.1;
  double self_margin = 0.02;
  int occupied = 65;  // map only, [1, 100]: cells with a value >= this are obstacles
};

// The range of ~rate (Hz), the same as cfg/Monitor.cfg's: below 0.1 Hz the timer's period
// (1 / rate) soon leaves what ros::Duration holds and the node would not cycle.
constexpr double kMinRate = 0.1;
constexpr double kMaxRate = 1000.0;

// Most moving bodies (in all, templates expanded; also the largest `count`). Each one is a topic
// subscription, and ROS's own bookkeeping makes subscribing superlinear: roscpp
// (TopicManager::addSubCallback) and rosmaster (NodeRef.add) compare each new subscription
// with every earlier one of the node. Measured start-up on the 2-core machine (docs/monitor.md, limits): 5,000
// bodies 5.5 s, 20,000 about 40 s, 50,000 188 s; 20,000 keeps it within about a minute.
constexpr int kMaxBodies = 20000;

constexpr int kMaxIngestThreads = 16;

struct MonitorParams {
  std::string fixed_frame = "odom";  // a tf2 frame id; a leading '/' is removed
  double rate = 30.0;           // Hz, [kMinRate, kMaxRate]
  double horizon = 2.0;         // s, [0, 60]
  double padding = 0.0;         // m, [0, 10]
  double stale_timeout = 0.5;   // s, > 0
  // s, (0, 3600]: a message stamped further than this from the node's clock (ahead or behind)
  // is dropped as invalid; see BodyRegistry.
  double max_stamp_skew = 5.0;
  int axes = 32;                // VADOP pool size (vadop::VadopConfig default)
  double phi_deg = 25.0;        // VADOP zone half-width (vadop::VadopConfig default)
  // Threads of the narrow phase each cycle, [0, vadop::kMaxThreads]; 0: one per hardware thread.
  // The impacts are the same for every count.
  int threads = 0;
  // Threads that run the odometry callbacks, [0, kMaxIngestThreads]; 0: roscpp's receiving
  // thread runs them as each message arrives (no queue, no thread woken per message).
  int ingest_threads = 0;
  // Odometry over UDPROS (one datagram a message, no acknowledgements) where the publisher
  // offers it (roscpp does; rospy does not: TCPROS then), else TCPROS.
  bool ingest_udp = false;
  // The world's broad phase (vadop::parseBroadPhaseKind): "grid" (the plain swept-AABB grid,
  // default), "vadop", "sap", "vadop_sap" or "brute"; the impacts are the same, the cost
  // differs. grid is the default because, after the cull (time_slices), the velocity-aligned
  // volumes remove no pair on the monitor's workloads and cost up to 57% more (docs/performance.md).
  std::string broad_phase = "grid";
  // Time slices of the cull before the narrow phase (vadop::WorldConfig::time_slices),
  // [1, vadop::kMaxTimeSlices]; 1: none. The impacts are the same for every count.
  int time_slices = 8;
  // Temporal coherence of the narrow phase (vadop::WorldConfig::coherence): a pair found more
  // than coherence_clearance m apart over the horizon + coherence_lookahead s is not computed
  // again while the bodies' new motions stay within the certificate's bound. 0: off.
  double coherence_clearance = 0.0;  // m, 0 or in [0.001, 10]
  double coherence_lookahead = 0.5;  // s, [0, 10]
  bool self_collision = false;
  std::vector<std::pair<std::string, std::string>> ignore_pairs;
  std::vector<BodyParams> bodies;
  std::vector<StaticObstacleParams> static_obstacles;
  std::vector<TrackParams> tracks;
  std::vector<SensorParams> sensors;
  bool log_impacts = false;     // log every cycle's impacts as readable lines (ROS_INFO)
  bool publish_markers = true;  // ~markers (built only while someone subscribes)
  // This monitor's share of a site split among several (~region, ~region_margin): it predicts
  // the bodies whose frame lies in the box grown by the margin (a gated body always) and
  // reports the pairs with at least one body inside the box (tracked objects and sensor points
  // count as inside: every monitor that holds them reports their pairs). Unbounded by default.
  struct Region {
    bool bounded = false;
    Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();  // fixed frame, m
    bool contains(const Eigen::Vector3d& p, double margin) const {
      return !bounded || ((p.array() >= min.array() - margin).all() && (p.array() <= max.array() + margin).all());
    }
  };
  Region region;
  double region_margin = 0.0;  // m, [0, 1e4]
};

// Parses the private namespace as one XmlRpc struct (what ros::param::get("~") returns).
// An invalid (absent) value means "no parameters": all defaults, no bodies.
// Throws ParamError.
MonitorParams parseParams(const XmlRpc::XmlRpcValue& root);

// The predictor's settings (~axes, ~phi_deg, ~broad_phase, ~time_slices, ~threads,
// ~coherence_*) in their ranges; parseParams calls it, and MonitorCore for params built in code.
// Throws ParamError naming the parameter.
void checkPredictorParams(const MonitorParams& params);

// Start-up warnings about valid parameters that weaken a guarantee (the node logs each one):
// a gated body without decelerations, whose commands are checked as held instead of braked.
std::vector<std::string> paramWarnings(const MonitorParams& params);

// Reads the node's private namespace from the parameter server and parses it.
MonitorParams loadParams(const ros::NodeHandle& private_nh);

// Parses one shape spec ({type: ..., radius/size/length}); `path` prefixes the messages.
vadop::Shape parseShape(const XmlRpc::XmlRpcValue& value, const std::string& path);

}  // namespace vadop_ros
