// The monitored bodies: their geometry (primitive shape or URDF collision elements), their
// inputs (sources, source.h: odometry, twist or a fleet's body states, and a path, joint states, a joint trajectory;
// each keeps its latest message) and, each cycle, the motion of every collision element in the
// fixed frame, composed from what the body's sources contribute. No ROS transport of its own:
// the node has each source subscribe itself; tests and the benchmark feed messages through
// onOdometry and the like (forwards to the body's source).
//
// Elements. Each collision element is one entry of the vadop::World, with id "body" for a
// primitive body and "body/link" for a URDF link ("body/link#k" for its k-th collision element,
// k > 0).
//
// Motion of an element over a cycle at time `now`:
//  - the body's latest state is transformed into the fixed frame (tf2, at the message stamp;
//    the latest transform when there is none at that stamp) and its twist rotated into the
//    fixed frame; the element then moves with constant linear and angular velocity from the
//    state's stamp on, which extrapolates it to `now` and over the horizon;
//  - a link rigid with its body (primitive body, URDF body without tf_prefix) gets the
//    rigid-body velocity field: v + w x r, angular velocity w;
//  - a link whose pose comes from tf also gets the velocity of its own motion relative to the
//    body frame, estimated from its two latest distinct tf poses.
// A URDF body with joint states (joint_states_topic, onJointState): its links' poses relative
// to the body frame come from the URDF's kinematics (JointKinematics) at the joint positions
// instead of tf, and over the horizon each joint moves at its reported velocity (clamped at its
// limits) while the body frame moves with its twist: every link is a vadop::LinkChain (the
// joints between the body's reference link and it, on the body frame's twist), whose time of
// impact the library certifies along the joint motion itself. Before the first joint state the
// joints are at zero; joints a message does not name keep their last state; joint states older
// than stale_timeout stop moving. A joint trajectory (joint_trajectory_topic, onJointTrajectory)
// overrides the joints it names while it runs (until its last point): before its first point
// they are at that point, between points they follow the cubic through the points' positions
// and velocities (as ros_control's joint_trajectory_controller interpolates; straight lines
// when the points have no velocities; vadop::JointPath), after its last point they hold it.
// A body with a planned path (path_topic, onPath) follows it instead while the plan reaches
// beyond `now`: its body frame moves from its pose at `now` (as above) through the plan's poses
// stamped after `now`, between consecutive ones with the constant twist that joins them
// (vadop::TimedPath), then holds or goes on with the last piece's twist (after_path); every
// element keeps its pose relative to the body frame at `now`, but for a joint-states body's
// links, whose chains then start from the body frame along the plan (a mobile manipulator
// moving its arm while it drives its plan). A plan whose last pose is not after `now`, an
// empty plan, or a stale body: the twist as above.
//
// Bad input never throws and never affects another body:
//  - NaN/Inf anywhere in a message, a zero-norm quaternion or a value beyond the library's
//    range (vadop/error.h: |position component| <= kMaxCoordinate, |linear velocity
//    component| <= kMaxLinearSpeed, |angular velocity component| <= kMaxAngularSpeed): dropped,
//    counted, a warning (throttled per body), the body marked in its status for a while;
//  - stamps (odometry and TwistStamped alike; a zero stamp means the receipt time):
//    a message stamped further than max_stamp_skew (~max_stamp_skew, default 5 s) from the
//    node's clock at its receipt, ahead or behind, is dropped as invalid like a NaN (warning
//    naming the body and the stamp). A stamp not newer than the last accepted one (out of
//    order, duplicate) is ignored and counted, but only while that last stamp is not ahead of
//    the new message's receipt time: a stamp in the future (within the skew) holds back older
//    stamps only until the clock reaches it, so no single message can block later good ones;
//  - each cycle every element's motion (after transformation) is checked over
//    [now, now + kMotionCheckWindow] against the same range (|position| and |pivot offset|
//    <= kMaxCoordinate, |position| within the window <= kMaxReach, |velocities| <= the limits,
//    |t_ref| <= kMaxTime): an element outside it is left out of the world this cycle, with a
//    warning (throttled per body) and the body marked bad input. Static obstacles too;
//  - no accepted message for stale_timeout (by receipt time), or the last one received after
//    the clock by more than kClockLag (the clock went back past it: its age is unknown): the
//    body stands still at its last pose (zero velocity) and is flagged stale;
//  - a transform missing: the body (or that link) is skipped this cycle; a warning (throttled)
//    once it has been missing for kTfWarnAfter. The body frame's motion out of the range above
//    (a pose from tf stamped far from the clock): skipped the same way, said why;
//  - URDF that does not parse / a link that cannot be converted: an error naming the body (and
//    link) in its status; the rest is monitored.
#pragma once

#include "vadop_ros/joint_kinematics.h"
#include "vadop_ros/params.h"
#include "vadop_ros/source.h"
#include "vadop_ros/urdf_shapes.h"

#include <vadop/motion.h>
#include <vadop/shapes.h>

#include <geometry_msgs/TwistStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/JointState.h>
#include <trajectory_msgs/JointTrajectory.h>
#include <vadop/BodyStateArray.h>
#include <ros/time.h>

#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace vadop {
class LinkChain;  // vadop/joint_chain.h (not included: see predictor.h)
class TimedPath;  // vadop/timed_path.h (likewise)
}

namespace vadop_ros {

// Time arithmetic that cannot overflow. ros::Time - ros::Time is a ros::Duration, which throws
// ("Duration is out of dual 32-bit range") beyond 2^31 s, while a valid stamp goes up to
// 2^32 - 1 s: any two stamps are compared in int64 nanoseconds instead (exact; |a - b| < 2^63).
inline int64_t nsecBetween(const ros::Time& a, const ros::Time& b) {
  return static_cast<int64_t>(a.toNSec()) - static_cast<int64_t>(b.toNSec());
}
// a - b in seconds.
inline double secondsBetween(const ros::Time& a, const ros::Time& b) {
  return static_cast<double>(nsecBetween(a, b)) * 1e-9;
}
// t + s seconds, saturated to [0, 2^32 - 1 s] (ros::Time's range); t when s is NaN.
ros::Time addSeconds(const ros::Time& t, double s);
// "" when `stamp` is within max_skew seconds of `receipt` (the node's clock), else why not
// (a message so far off would blind a body, or be extrapolated over hours).
std::string stampSkewError(const ros::Time& stamp, const ros::Time& receipt, double max_skew);
// Whether a state received at `receipt` still describes its body at `now`: received at most
// `timeout` seconds before, and not after `now` by more than a simulated clock may lag its
// messages (BodyRegistry::kClockLag). A receipt further ahead means the clock went back past it:
// its age is unknown, so it counts as stale (a stale body stands still; a gate stops it).
bool receiptFresh(const ros::Time& receipt, const ros::Time& now, double timeout);

// tf as the registry sees it: a tf2_ros::Buffer in the node, a table in tests.
class TransformSource {
 public:
  virtual ~TransformSource() = default;
  // Pose of frame `source` in frame `target` at `time` (ros::Time(0): the latest available).
  // Returns false and sets `error` when there is none.
  virtual bool lookup(const std::string& target, const std::string& source, const ros::Time& time,
                      Eigen::Isometry3d& pose, ros::Time& stamp, std::string& error) = 0;
  // True when lookup may run on several threads at once (tf2's buffer locks its own state);
  // BodyRegistry::update then updates bodies in parallel.
  virtual bool concurrent() const { return false; }
  // The parent of `frame` in tf's tree at `time` (ros::Time(0): the latest); false when it has
  // none or is unknown. A sensor's frame is followed up to the body that carries it.
  virtual bool parent(const std::string& /*frame*/, const ros::Time& /*time*/, std::string& /*parent*/) {
    return false;
  }
};

// Reads a string parameter (a robot_description); false when it does not exist.
using ParamReader = std::function<bool(const std::string& name, std::string& value)>;

enum class InputResult { kAccepted, kInvalid, kOutOfOrder };

enum class BodyState {
  kWaiting,     // no message yet: not monitored
  kOk,
  kStale,       // no message for stale_timeout: standing still at its last pose
  kTfMissing,   // a transform was missing this cycle: skipped (or some links skipped)
  kNoGeometry,  // nothing to monitor (URDF missing or every collision element failed)
  kStatic,      // a static obstacle
};
const char* toString(BodyState s);

struct BodyStatus {
  BodyState state = BodyState::kWaiting;
  uint64_t accepted = 0;
  uint64_t dropped_invalid = 0;     // NaN/Inf, zero quaternion, out of range, stamp skew
  uint64_t elements_left_out = 0;   // element-cycles whose motion was out of range (or refused)
  uint64_t dropped_out_of_order = 0;
  std::string last_invalid;         // why the last invalid message (or element) was dropped
  ros::Time last_invalid_receipt;   // zero if none (for an element: the cycle time)
  ros::Time last_receipt;           // of the last accepted message
  std::string tf_error;             // this cycle's missing transform, if any
  size_t links_skipped = 0;         // this cycle, tf links without a transform
  std::vector<std::string> geometry_errors;  // URDF / link conversion errors
  // This cycle's prediction: whether it follows the body's plan (path_topic), whether the links
  // move with their joints, whether it follows a joint trajectory. The counts of each input are
  // its source's (Source::counts).
  bool on_path = false;
  bool joints_moving = false;
  bool on_trajectory = false;
  // Whether the node last said this body went stale (it says so once, and once when it is back).
  bool announced_stale = false;
};

struct Element {
  std::string id;     // World id
  size_t body = 0;    // index into bodies()
  std::string link;   // URDF link name; empty for a primitive body or obstacle
  vadop::Shape shape; // unpadded
  std::string mesh_uri;
  Eigen::Vector3d mesh_scale = Eigen::Vector3d::Ones();
  // Rigid elements: the element frame in the body frame (for a URDF link: the link pose with
  // every joint at zero, times the collision origin). Elements from tf: the collision origin
  // in the link frame.
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  // Rigid URDF links: link pose in the root link frame times the collision origin; offset is
  // this relative to the body's reference link (resolved when the body frame is known).
  Eigen::Isometry3d root_offset = Eigen::Isometry3d::Identity();
  std::string tf_frame;  // the link's tf frame when its pose comes from tf, else empty

  // Output of update(): whether the element has a motion this cycle, and that motion (fixed
  // frame; t_ref in the registry's seconds, see seconds()).
  bool active = false;
  vadop::Motion motion;
  // The element's motion beyond one twist this cycle (null: `motion` alone): its body's planned
  // path (a chain without joints), or its link moved by the joints on the body frame. Its pose
  // at the cycle time equals motion's.
  std::shared_ptr<const vadop::LinkChain> chain;

  // Own motion estimate from tf (link pose in the body frame at two distinct stamps).
  bool has_rel = false;
  ros::Time rel_stamp;
  Eigen::Isometry3d rel_pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d rel_v = Eigen::Vector3d::Zero();  // body frame, of the link origin
  Eigen::Vector3d rel_w = Eigen::Vector3d::Zero();  // body frame
};

// The motion of a frame at `pose` (fixed frame, at t_ref seconds) whose origin has velocity v
// and which turns at w, both constant in the frame (a constant body twist): about its screw
// axis, so it follows the arc, or a translation with spin when that axis is farther than 10 km.
// Throws vadop::InvalidArgument for non-finite input.
vadop::Motion twistMotion(const Eigen::Isometry3d& pose, const Eigen::Vector3d& v, const Eigen::Vector3d& w,
                          double t_ref);

// A body frame moving with constant linear and angular velocity (fixed frame) from t_ref (the
// registry's seconds): pose at t_ref; stale when the state timed out (v = w = 0, t_ref = now).
// Valid only when `motion` (twistMotion of the rest) is within the library's range over the
// prediction window, so that its readers (the plan, the velocity gate) need not check it again.
struct FrameMotion {
  bool valid = false;
  bool stale = false;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  double t_ref = 0.0;
  vadop::Motion motion;
};

// What one vadop/BodyStateArray brought (BodyRegistry::onBodyStates), or a states_topic's
// totals (BodyRegistry::bodyStatesTopics; arrays counted there only).
struct BodyStatesCounts {
  uint64_t arrays = 0;
  uint64_t accepted = 0;
  uint64_t dropped = 0;       // bad entries: NaN/Inf, zero quaternion, out of range, stamp skew
  uint64_t out_of_order = 0;  // not newer than the body's last state
  uint64_t unknown = 0;       // entries naming no body of the topic: ignored
};
// The bodies of each states_topic by name (src/sources/body_states_source.cpp).
class BodyStatesRoutes;

// A monitored body: its geometry (elements, URDF links and kinematics), its inputs (sources:
// the kinds of source.h its parameters ask for) and its status. Static obstacles have no source.
struct Body {
  std::string name;
  bool is_static = false;
  BodyParams params;  // moving bodies
  std::vector<size_t> elements;
  // URDF: links joined by a joint (never self-collisions) and whether links move (tf).
  std::vector<std::pair<std::string, std::string>> adjacent;
  std::map<std::string, Eigen::Isometry3d> link_in_root;
  std::string root_link;
  std::string reference_for;  // body frame the rigid offsets were computed for
  // The URDF's kinematics when a source moves the joints (shared by the bodies of one
  // description), and the URDF link that is the body frame.
  std::shared_ptr<const JointKinematics> kinematics;
  std::string reference_link;

  // Its inputs, the velocity source (odometry or twist) first; has_state once that source has
  // accepted a message (static obstacles: always).
  std::vector<std::unique_ptr<Source>> sources;
  bool has_state = false;
  // The source of kind `kind` (Source::kind()), or null.
  const Source* source(const char* kind) const;
  // The velocity source's state (null for a static obstacle).
  const VelocityState* velocityState() const;

  BodyStatus status;
  // The body frame's motion in the fixed frame as of the last update (of all bodies, or of
  // this one by updateBody): valid when the pose and every link's transform were found.
  FrameMotion frame_motion;
  // Per-kind warning throttle (wall clock seconds of the last warning).
  double last_warn_invalid = -1e300, last_warn_tf = -1e300;
  ros::Time tf_missing_since;  // zero while the transforms are there
};

// The source of a body's predicted motion this cycle, for the diagnostics: "path" (its planned
// path), "odometry" or "twist" (its velocity extrapolated), "stale" (standing still), "none".
const char* motionSource(const Body& b);

class BodyRegistry {
 public:
  // Builds the bodies and obstacles of `params`. robot_description texts are read with
  // `read_param` (parsed once per parameter name). Geometry errors do not throw: they are
  // recorded in the body's status (see geometryErrors()).
  BodyRegistry(const MonitorParams& params, const ParamReader& read_param, const MeshLoader& load_mesh);

  const std::vector<Body>& bodies() const { return bodies_; }
  const std::vector<Element>& elements() const { return elements_; }
  // Index of the body (or obstacle) with this name, or -1.
  int find(const std::string& name) const;
  // Every geometry error, one line each, naming the body and link.
  std::vector<std::string> geometryErrors() const;

  // Message inputs for the moving body `body` (index into bodies()); `receipt` is the ROS time
  // at which it arrived (it decides staleness; it replaces a zero stamp). The stamp policy is
  // in the header comment: beyond max_stamp_skew from `receipt` -> kInvalid.
  InputResult onOdometry(size_t body, const nav_msgs::Odometry& msg, const ros::Time& receipt);
  // What the node's odometry callback does: the message checked and posted into the body's slot,
  // without collecting it (the next update() or updateBody() does). Any thread, one at a time
  // per body, concurrently with everything else here (the only entry point that may be).
  InputResult postOdometry(size_t body, const nav_msgs::Odometry& msg, const ros::Time& receipt);
  InputResult onTwist(size_t body, const geometry_msgs::TwistStamped& msg, const ros::Time& receipt);
  // A fleet's states on the states_topic `topic`: each entry goes to the body of that topic it
  // names, as an odometry message would (its pose in header.frame_id at header.stamp, its twist
  // in the body frame; the same checks and stamp policy, per body). Entries naming no body of
  // the topic are counted and ignored; a bad entry is dropped (counted, a throttled warning
  // naming the entry and the field), the others kept. Returns what this array brought.
  BodyStatesCounts onBodyStates(const std::string& topic, const vadop::BodyStateArray& msg, const ros::Time& receipt);
  // Every states_topic with its totals so far (sorted by topic), for the diagnostics; empty
  // before the first array or subscription.
  std::vector<std::pair<std::string, BodyStatesCounts>> bodyStatesTopics() const;
  // A planned path of the body frame (path_topic): each pose stamped with the time the body is
  // there, in header.frame_id (transformed into the fixed frame with tf at header.stamp, else the
  // latest transform). Dropped as kInvalid, with a throttled warning naming the body and the
  // field, and the previous plan kept: no frame, a frame tf cannot resolve, a header stamp
  // beyond max_stamp_skew from `receipt`, a pose in another frame, NaN/Inf or out of range, a
  // zero quaternion, a zero pose stamp, stamps that do not increase or farther than
  // kRebaseAfterSeconds from `receipt`. Older than the accepted plan: kOutOfOrder. An empty
  // path clears the plan (the planner has none).
  InputResult onPath(size_t body, const nav_msgs::Path& msg, const ros::Time& receipt, TransformSource& tf);
  // Joint positions and velocities of a joint_states_topic body, matched by name to the URDF's
  // movable joints; a missing velocity array counts as zeros. Dropped as kInvalid (throttled
  // warning naming the body and the field; the previous state kept): a name that is not a
  // movable joint of the URDF or repeats, position / velocity sizes that differ from name's,
  // NaN/Inf or beyond the library's range, a stamp beyond max_stamp_skew. A stamp not newer
  // than the last accepted one: kOutOfOrder (as odometry).
  InputResult onJointState(size_t body, const sensor_msgs::JointState& msg, const ros::Time& receipt);
  // A joint trajectory as MoveIt executes it: point times are header.stamp (its receipt when
  // zero) + time_from_start. Dropped as kInvalid (throttled warning naming the body and the
  // field; the previous trajectory kept): an unknown or repeated joint name, a point whose
  // positions (or velocities, when given) do not match joint_names, NaN/Inf or out of range,
  // a negative time_from_start or times that do not increase, a header stamp beyond
  // max_stamp_skew. No points: the running trajectory is cancelled.
  InputResult onJointTrajectory(size_t body, const trajectory_msgs::JointTrajectory& msg, const ros::Time& receipt);

  // Computes every element's motion at `now` (sets Element::active and motion, body states).
  // Bodies are independent: with several threads (setThreads) and a TransformSource that takes
  // concurrent lookups, they are shared out among the threads; the result is the same.
  void update(const ros::Time& now, TransformSource& tf);
  // Threads of update() (0: one per hardware thread; the monitor's ~threads). Default 1.
  void setThreads(int threads);
  // The same for one moving body, from its latest state (a velocity gate between cycles); the
  // time base stays. False (the body's elements inactive or partly so) when there is no
  // update() yet, the index is not a moving body, it has no state or a transform is missing.
  bool updateBody(size_t body, const ros::Time& now, TransformSource& tf);

  // Forgets every state (time jumped backwards, e.g. a bag restarted); keeps the geometry.
  void reset();
  // How many resets so far: a body's has_state turns false only through one.
  uint64_t resets() const { return resets_; }

  // The library works in seconds since a base time, set by the first update (or reset) and
  // moved to `now` by update() whenever |seconds(now)| exceeds kRebaseAfterSeconds (every
  // moving element's motion is recomputed each cycle from its ros::Time stamps; static ones
  // have zero velocity), so these seconds stay far inside vadop::kMaxTime whatever the clock.
  double seconds(const ros::Time& t) const { return secondsBetween(t, base_); }
  const ros::Time& timeBase() const { return base_; }
  static constexpr double kRebaseAfterSeconds = 3600.0;
  // Times the base moved (the first base included).
  uint64_t rebases() const { return rebases_; }

  // ~max_stamp_skew (s); MonitorCore sets it from MonitorParams::max_stamp_skew.
  void setMaxStampSkew(double seconds) { max_stamp_skew_ = seconds; }
  double maxStampSkew() const { return max_stamp_skew_; }

  // Window over which an element's motion is range-checked each cycle (s): the largest horizon.
  static constexpr double kMotionCheckWindow = 60.0;
  // "" when `m` stays inside the library's range (vadop/error.h) over [t0, t1], else why not.
  static std::string motionRangeError(const vadop::Motion& m, double t0, double t1);
  // Element `element` was left out of the prediction (the world refused it): marks its body
  // bad input (status and a throttled warning), at ROS time `now`.
  void markElementBad(size_t element, const std::string& why, const ros::Time& now);

  double staleTimeout() const { return stale_timeout_; }
  // The time of the first update since construction or reset() (zero before it).
  const ros::Time& firstUpdate() const { return first_update_; }
  const std::string& fixedFrame() const { return fixed_frame_; }
  // Seconds during which a dropped message keeps its body marked in the diagnostics.
  static constexpr double kInvalidMarkSeconds = 5.0;
  // Wall seconds between two warnings of one kind for one body.
  static constexpr double kWarnPeriod = 5.0;
  // How far (s) the node's clock may lag a message's stamp at its receipt with that message
  // still ordered against the previous one (see acceptStamp).
  static constexpr double kClockLag = 0.25;
  // A missing transform is only warned about once it has been missing this long (s, ROS
  // time): tf takes a moment to fill at start-up. The status flags it at once.
  static constexpr double kTfWarnAfter = 2.0;

 // For the sources (source.h) ------------------------------------------------------------
  Body& body(size_t i) { return bodies_.at(i); }
  // A dropped message: counted in the body's dropped_invalid, `why` kept in its status and
  // warned about (throttled per body).
  void dropMessage(Body& b, const std::string& why, const ros::Time& receipt) { rejectInput(b, why, receipt); }
  // The velocity state's stamp policy (see the header): `stamp` (zero: `receipt`) beyond
  // max_stamp_skew -> kInvalid (dropped); not newer than `last` while `last` is not ahead of the
  // receipt by more than kClockLag -> kOutOfOrder (counted); else kAccepted and `last` = stamp.
  InputResult acceptStamp(Body& b, ros::Time stamp, const ros::Time& receipt, ros::Time& last);
  // The same policy without a body (any thread): `stamp` (zero: set to `receipt`) against the
  // last accepted stamp `last` (meaningful when `has_state`); kInvalid with `why` set for a
  // stamp beyond `max_skew`. Counts and warnings are the caller's.
  static InputResult stampDecision(ros::Time& stamp, const ros::Time& receipt, bool has_state, const ros::Time& last,
                                   double max_skew, std::string& why);
  // What the body's callbacks posted since (Source::collect): its latest state, counts and
  // drops. update() and updateBody() do it; so do the message entry points above, for callers
  // that feed the registry directly (tests, the bench). Under the node's lock.
  void collect(size_t body) { collect(bodies_.at(body)); }
  // "" when `stamp` is within max_stamp_skew of `receipt`, else why not ("stamp ... ahead of ...").
  std::string stampSkewError(const ros::Time& stamp, const ros::Time& receipt) const;
  // tf.lookup that never throws (tf2 itself computes ros::Durations from arbitrary stamps).
  static bool lookup(TransformSource& tf, const std::string& target, const std::string& source,
                     const ros::Time& time, Eigen::Isometry3d& pose, ros::Time& stamp, std::string& error);
  // A transform the body needs is missing: its status now, a throttled warning after kTfWarnAfter.
  void warnTf(Body& b, const std::string& error, const ros::Time& now);
  // The bodies of each states_topic by name, built on first use (the body-states source).
  BodyStatesRoutes& bodyStatesRoutes();

 private:
  class UrdfCache;
  // The source of type S of body `body` (the message entry points above, defined beside each
  // source); throws std::invalid_argument naming `key` when the body has none.
  template <class S>
  S& sourceOf(size_t body, const char* key);
  // The body's elements: its primitive shape, or every collision element of its URDF. False
  // (and the body flagged "no geometry") when the URDF cannot be had.
  bool addGeometry(size_t body_index, bool has_shape, const vadop::Shape& shape, const std::string& description,
                   bool links_from_tf, const std::string& tf_prefix, UrdfCache& urdfs);
  void addUrdfGeometry(size_t body_index, const std::string& description, const UrdfShapes& urdf,
                       bool links_from_tf, const std::string& tf_prefix);
  void addMovingBody(const BodyParams& bp, UrdfCache& urdfs);
  // The URDF's kinematics for a body whose sources move its joints; an error in its status when
  // they cannot be had (its links then stay rigid, joints at zero).
  void attachKinematics(Body& b, UrdfCache& urdfs);
  void addStaticObstacle(const StaticObstacleParams& op, UrdfCache& urdfs);
  void checkUniqueIds() const;
  // A dropped message (count_message) or a left-out element: status, throttled warning.
  void rejectInput(Body& b, const std::string& why, const ros::Time& receipt, bool count_message = true);
  void collect(Body& b);
  void resolveReference(Body& b, const std::string& body_frame);
  void updateStatic(Body& b, const ros::Time& now, double t_now, double t_check_end);
  void updateMoving(Body& b, const ros::Time& now, double t_now, double t_check_end, TransformSource& tf);
  // Clears the body's motions of the last cycle; false (with its state) when it has nothing to
  // move: no geometry, or no state yet.
  bool startCycle(Body& b);
  // The body frame's motion from its inputs (`in`, stopped when `stale`), referred to `tr`;
  // false (the body skipped) when it is out of the library's range.
  bool frameMotion(Body& b, const ros::Time& now, double t_now, double t_check_end, const BodyInputs& in, double tr,
                   vadop::Motion& frame);
  // The elements of a body without joint inputs: rigid with the body frame or posed by tf.
  void updateRigidBody(Body& b, const ros::Time& now, double t_now, double t_check_end, TransformSource& tf,
                       const BodyInputs& in, bool stale, const vadop::Motion& frame, double tr);
  // A link posed by tf: its pose and velocity in the fixed frame; false (warned, counted in
  // links_skipped) when its transform is missing.
  bool tfElementMotion(Body& b, Element& e, const ros::Time& now, TransformSource& tf, const BodyInputs& in,
                       bool stale, const ros::Time& motion_ref, Eigen::Isometry3d& pe, Eigen::Vector3d& ve,
                       Eigen::Vector3d& we);
  // Sets an element's motion when it is within the library's range over the window, else leaves
  // the element out (its body marked: "link \"l\": motion" + `out_of_range` + why).
  void acceptMotion(Body& b, Element& e, const vadop::Motion& m, std::shared_ptr<const vadop::LinkChain> chain,
                    const ros::Time& now, double t_now, double t_check_end, const char* out_of_range);
  // The body frame along its plan, from `frame_now` (its pose now) through the plan's poses after
  // now: none when the plan ends before now or cannot be followed (a piece out of the library's
  // range over the window: warned, the twist is used).
  std::optional<vadop::TimedPath> planPath(Body& b, const BodyInputs& in, const ros::Time& now, double t_now,
                                           double t_check_end, const Eigen::Isometry3d& frame_now);
  // Puts the body's active elements on `plan`, each kept where it is on the body (see the header).
  void followPlan(Body& b, const BodyInputs& in, const ros::Time& now, const vadop::TimedPath& plan, double t_now,
                  double t_check_end, const Eigen::Isometry3d& frame_now);
  void warnPlanNotFollowed(Body& b, const ros::Time& now, const std::string& why);
  // The elements of a joint-input body (see the header), its frame moving with `frame`, or along
  // `plan` when not null.
  void updateJointBody(Body& b, const BodyInputs& in, const ros::Time& now, double t_now, double t_check_end,
                       const vadop::Motion& frame, bool stale, const vadop::TimedPath* plan);
  // Rigid at the joints' current positions: every link moves with the body frame's twist.
  void holdJoints(Body& b, const BodyInputs& in, const ros::Time& now, double t_now, double t_check_end,
                  const vadop::Motion& frame);

  std::string fixed_frame_;
  double stale_timeout_ = 0.5;
  int threads_ = 1;  // of update(), resolved
  std::vector<Body> bodies_;
  std::vector<Element> elements_;
  ros::Time base_;
  bool has_base_ = false;
  ros::Time first_update_;
  uint64_t rebases_ = 0;
  uint64_t resets_ = 0;
  double max_stamp_skew_ = 5.0;  // MonitorParams' default until setMaxStampSkew
  std::shared_ptr<BodyStatesRoutes> states_routes_;  // null until bodyStatesRoutes()
};

template <class S>
S& BodyRegistry::sourceOf(size_t body, const char* key) {
  Body& b = bodies_.at(body);
  for (const std::unique_ptr<Source>& source : b.sources) {
    if (auto* s = dynamic_cast<S*>(source.get())) return *s;
  }
  throw std::invalid_argument("body \"" + b.name + "\" has no " + key);
}

}  // namespace vadop_ros
