// One input of a moving body: a topic, the latest message it brought (checked, counted) and
// what that message says about the body's motion at a cycle. Odometry and twist give the body
// frame's velocity state, a path its plan, joint states and a joint trajectory its joints; each
// kind is one class in src/sources/<kind>_source.cpp, made for a body by one entry of
// sourceKinds() (the registration table: the only place that lists the kinds).
//
// A source does: subscribe to its topic (subscribe), check and keep a message (its own typed
// handler, which the subscription calls under the node's lock, or, for odometry, posts into the
// body's slot without it: collect), forget it (reset), hand its
// contribution to the body's motion at a cycle (contribute: a pointer into what it keeps, never
// a copy, so that a cycle over 10,000 bodies allocates nothing), and report its counts for the
// diagnostics (describe, counts).
// It does not: build geometry (BodyRegistry), compose element motions from the contributions
// (BodyRegistry::update), or warn by itself: a dropped message goes through
// BodyRegistry::dropMessage, so every input of a body shares its status and warning throttle.
//
// Inputs that bring bodies of their own rather than one body's motion (tracked objects, and
// the later sensor inputs: scans, clouds and grids as sets of obstacle points or boxes) are
// body-set sources (BodiesSource below): one per kind, made by one entry of
// bodiesSourceKinds(), holding the set of bodies its latest messages brought in slots that
// MonitorCore syncs into the world each cycle.
#pragma once

#include "vadop_ros/params.h"

#include <Eigen/Geometry>
#include <ros/callback_queue_interface.h>
#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>
#include <ros/time.h>

#include <vadop/shapes.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace diagnostic_updater {
class DiagnosticStatusWrapper;
}

namespace vadop {
class PreparedShape;  // vadop/world.h: prepareShape
}

namespace vadop_ros {

class BodyRegistry;
class TransformSource;
struct Body;

// The body frame's latest velocity state, as the velocity source (odometry or twist) keeps it.
struct VelocityState {
  ros::Time stamp;           // of the state (message stamp; receipt time if zero)
  std::string source_frame;  // odometry: header.frame_id (pose frame)
  std::string child_frame;   // odometry: child_frame_id (twist frame)
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // odometry: child in source frame
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // odometry: child frame; twist: twist_frame
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  std::string twist_frame;   // TwistStamped header.frame_id (empty: the body frame)
};

// A planned path (path source): the body frame's poses in the fixed frame with their stamps
// (empty: none, or an empty path cleared it).
using Plan = std::vector<std::pair<ros::Time, Eigen::Isometry3d>>;

// Joint states (joint states source): per movable joint (JointKinematics::joints() order) its
// position at q_time and its velocity.
struct JointInput {
  bool has_joints = false;
  ros::Time stamp;    // of the last accepted joint state
  ros::Time receipt;
  std::vector<double> q, qd;
  std::vector<ros::Time> q_time;
};

// A joint trajectory (joint trajectory source): the joints it names (kinematics indices), the
// time of each point, and per point their positions and velocities (empty: linear).
struct TrajectoryInput {
  std::vector<int> joints;
  std::vector<ros::Time> time;
  std::vector<std::vector<double>> q, qd;
};

// What a body's sources contribute at one cycle: pointers into what they keep (null: no such
// input) and the body frame's motion found from the velocity state.
struct BodyInputs {
  // The body frame in the fixed frame, its velocity there (fixed frame) and the time they hold
  // at; `frame` names it (one of the body's own strings).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  ros::Time t_ref;
  const std::string* frame = nullptr;
  const Plan* plan = nullptr;
  bool plan_continue = true;  // after the plan's last pose: its last twist (else hold)
  const JointInput* joints = nullptr;
  const TrajectoryInput* trajectory = nullptr;
};

// Counts a source keeps for the diagnostics and tests.
struct SourceCounts {
  uint64_t accepted = 0;
  uint64_t dropped = 0;  // as invalid (also in the body's dropped_invalid)
};

class Source {
 public:
  virtual ~Source() = default;
  // The kind's name ("odometry", "twist", "path", "joint_states", "joint_trajectory").
  virtual const char* kind() const = 0;
  virtual const std::string& topic() const = 0;

  // What the node gives a source to subscribe with: its NodeHandle, the lock every use of the
  // registry holds, the registry, the body's index and tf (for a message in another frame).
  struct Wiring {
    ros::NodeHandle& nh;
    std::mutex& lock;
    BodyRegistry& registry;
    size_t body;
    TransformSource& tf;
    // The queue of the callbacks that take no lock (odometry): the node's ingest queue
    // (~ingest_threads); null: nh's.
    ros::CallbackQueueInterface* ingest_queue = nullptr;
    bool ingest_udp = false;  // odometry over UDPROS where the publisher offers it (~ingest_udp)
  };
  // Subscribes to topic(); each message runs the source's handler under `lock` (odometry: posts
  // into its slot on `ingest_queue`, without the lock), stamped with the node's clock at its
  // receipt.
  virtual ros::Subscriber subscribe(const Wiring& w) = 0;

  // Adds what the source keeps to the body's inputs at `now`. False: the body is skipped this
  // cycle (its frame cannot be found; the source said why through BodyRegistry::warnTf).
  virtual bool contribute(Body& b, BodyRegistry& registry, const ros::Time& now, TransformSource& tf,
                          BodyInputs& in) = 0;
  // Takes what its callback posted since the last call into what contribute reads (the
  // sources whose callbacks run without the node's lock: odometry, body states), with its
  // counts and warnings; the node's lock held. Nothing for the others.
  virtual void collect(Body& /*b*/, BodyRegistry& /*registry*/) {}
  // Forgets every message (time jumped back); keeps the counts.
  virtual void reset() = 0;
  // The velocity state it keeps (odometry, twist), else null.
  virtual const VelocityState* velocityState() const { return nullptr; }

  const SourceCounts& counts() const { return counts_; }
  // The counts as the diagnostics print them ("3 path(s) accepted, 0 dropped").
  virtual std::string describe(const Body& b, const ros::Time& now) const = 0;

 protected:
  SourceCounts counts_;
};

// One input kind: its parameters in a ~bodies entry, whether a body has it and how to make its
// source.
struct SourceKind {
  const char* name;
  // Its keys in a ~bodies entry, the one that names its topic first.
  std::vector<const char*> keys;
  // Its topic in BodyParams: a valid ROS topic name; template copies substitute {i} in it.
  std::string BodyParams::*topic;
  // Reads its keys of the ~bodies entry `entry` (`path` in the errors) into `p`, after the body's
  // own keys (name, frame, geometry) and the kinds listed before it; throws ParamError naming
  // the parameter.
  void (*parse)(const XmlRpc::XmlRpcValue& entry, const std::string& path, BodyParams& p);
  bool (*wanted)(const BodyParams& p);
  std::unique_ptr<Source> (*make)(const BodyParams& p, const Body& b);
  // The kind moves the body's links with its joints: the body needs the URDF's kinematics, and
  // its links' chains start from the body frame.
  bool kinematics_input;
};
// Every kind, in the order a body's sources are made and contribute (the velocity source
// first: the others start from the body frame it gives).
const std::vector<SourceKind>& sourceKinds();

// One body of a body-set source: a collision element of its own that moves with a constant
// twist from `stamp` (zero for a static obstacle), named in the impacts by `name` and `link`.
struct SourcedBody {
  bool alive = false;  // false: a free slot
  // The impacts' body_a/body_b (tracked objects: "<prefix>/<id>"); also the element's id in
  // the world (its errors name it), so unique among the bodies in the world.
  std::string name;
  std::string link;    // the impacts' link_a/link_b (tracked objects: empty)
  vadop::Shape shape;  // unpadded
  // In the fixed frame: the pose at `stamp`, the velocity of the pose's origin and the angular
  // velocity.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  ros::Time stamp;
  // Bumped by the source whenever `shape` changes in a living slot (a sensor's new points): the
  // world keeps an element's shape from its entry, so MonitorCore re-enters the element then.
  uint64_t shape_version = 0;
  // Optional: `shape` grown by `prepared_padding` and prepared for the narrow phase by the
  // source, off the cycle (a sensor's point set: its tree built in the message's callback, not
  // under the node's lock). MonitorCore takes it while the node's padding is still that one;
  // otherwise it pads and prepares `shape` itself.
  std::shared_ptr<const vadop::PreparedShape> prepared;
  double prepared_padding = 0.0;
};

// An input that brings a set of bodies (the kind's topics, their latest messages, the bodies
// they hold). The bodies live in slots (bodies()) that keep their index while their body lives
// and are reused after it left: MonitorCore gives each slot one world element, so a body joining
// or leaving costs one world add or remove, never a rebuild. A slot is freed only through
// expire, drop or clear, which hand it back in `left`: its element leaves the world before the
// slot may hold another body.
// A body-set source does: subscribe to its topics (each message checked and kept under the
// node's lock by its own handler), let bodies leave whose input timed out (expire), drop a body
// the world refused (drop, counted and warned about), forget everything (clear) and fill its
// diagnostics entry (report; its name: kind()). It does not: touch the world, pad shapes,
// apply the pair rules or turn a body's state into a motion (MonitorCore does, the same way
// for every kind).
class BodiesSource {
 public:
  virtual ~BodiesSource() = default;
  // Its top-level parameter and its diagnostics entry ("tracks").
  virtual const char* kind() const = 0;
  // Its parameters name at least one topic (else the node adds no diagnostics entry for it).
  virtual bool configured() const = 0;

  // What the node gives a body-set source to subscribe with: its NodeHandle, the lock every
  // use of the core holds and tf (for a message in another frame).
  struct Wiring {
    ros::NodeHandle& nh;
    std::mutex& lock;
    TransformSource& tf;
  };
  virtual std::vector<ros::Subscriber> subscribe(const Wiring& w) = 0;

  // Bodies whose input timed out at `now` leave; their slots are appended to `left`.
  virtual void expire(const ros::Time& now, std::vector<size_t>& left) = 0;
  // The body in `slot` cannot be predicted (its motion out of range, refused by the world): it
  // leaves, counted as dropped and warned about with `why`.
  virtual void drop(size_t slot, const std::string& why, const ros::Time& now) = 0;
  // Every body leaves and every message is forgotten (time jumped back); their slots are
  // appended to `left`.
  virtual void clear(std::vector<size_t>& left) = 0;
  // Fills its diagnostics entry (named kind()).
  virtual void report(diagnostic_updater::DiagnosticStatusWrapper& stat, const ros::Time& now) const = 0;
  // Inputs the gates must not go without (sensors): true, with `why` naming it, when one that
  // `ignored` (given its name) does not leave out has no fresh message at `now`. The gates
  // then publish zero Twists (reason stale). None by default.
  virtual bool staleInput(const ros::Time& /*now*/, const std::function<bool(const std::string& name)>& /*ignored*/,
                          std::string& /*why*/) const {
    return false;
  }

  // The slots, alive or free (no virtual call per body in MonitorCore's loops).
  const std::vector<SourcedBody>& bodies() const { return bodies_; }

 protected:
  std::vector<SourcedBody> bodies_;
};

// One body-set kind: its top-level parameter, how to read it and how to make its source.
struct BodiesSourceKind {
  // Its top-level parameter (~tracks: "tracks"), a known key of the node.
  const char* name;
  // Reads ~<name> (`value`) into `out` after the bodies and static obstacles; throws
  // ParamError naming the parameter.
  void (*parse)(const XmlRpc::XmlRpcValue& value, MonitorParams& out);
  // Its source from the node's parameters: always made (configured() says whether ~<name>
  // named a topic), so that MonitorCore has one per kind.
  std::unique_ptr<BodiesSource> (*make)(const MonitorParams& p);
};
// Every body-set kind, in the order MonitorCore syncs them into the world (each source's
// elements follow the registry's: MonitorCore::setElement).
const std::vector<BodiesSourceKind>& bodiesSourceKinds();

}  // namespace vadop_ros
