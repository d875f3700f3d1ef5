#include "vadop_ros/body_registry.h"

#include "message_checks.h"

#include <vadop/error.h>
#include <vadop/joint_chain.h>
#include <vadop/timed_path.h>
#include <vadop/world.h>

#include <ros/console.h>
#include <ros/time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_set>

namespace vadop_ros {
namespace {

// Farthest screw axis (m from the element) modelled as a rotation about it (see update()).
constexpr double kMaxPivot = 1e4;

double wallNow() { return ros::WallTime::now().toSec(); }

}  // namespace

vadop::Motion twistMotion(const Eigen::Isometry3d& pose, const Eigen::Vector3d& v, const Eigen::Vector3d& w,
                          double t_ref) {
  // A constant twist turns the element about its screw axis (a link of a robot turning in
  // place about the robot, a robot on a curve about the curve's centre, a link about its
  // joint): the world gets that pivot, so the element follows its arc instead of drifting off
  // along the tangent. Nearly straight motion (axis farther than kMaxPivot) stays a
  // translation: the two differ by |v| |w| t^2 / 2 < 1e-3 m over a 2 s horizon there.
  const Eigen::Vector3d pivot = vadop::screwPivotOffset(v, w);
  const bool screw = pivot.norm() <= kMaxPivot;
  vadop::Motion m = vadop::makeMotion(pose.translation(), Eigen::Quaterniond(pose.linear()),
                                      screw ? vadop::screwPivotVelocity(v, w) : v, w, t_ref);
  if (screw) m.pivot_offset = pivot;
  return m;
}

namespace {

// Rotation vector (axis * angle) of a rotation matrix, angle in [0, pi].
Eigen::Vector3d rotationVector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

}  // namespace

const char* toString(BodyState s) {
  switch (s) {
    case BodyState::kWaiting: return "waiting for the first message";
    case BodyState::kOk: return "ok";
    case BodyState::kStale: return "stale";
    case BodyState::kTfMissing: return "transform missing";
    case BodyState::kNoGeometry: return "no geometry";
    case BodyState::kStatic: return "static";
  }
  return "unknown";
}

namespace {

// World id of a URDF collision element: "body/link", "body/link#k" for the link's k-th element
// (k > 0), where '%' and '#' in the link name are written "%25" and "%23". Unique by
// construction: body names are unique and have no '/', so the first '/' ends the body name (a
// primitive body's id, its bare name, has none); the escaped link name has no '#', so a '#'
// starts the index; and the escaping is one-to-one. (Unescaped, link "x" element 1 and link
// "x#1" element 0 were both "body/x#1".)
std::string urdfElementId(const std::string& body, const std::string& link, int index) {
  std::string id = body + "/";
  id.reserve(id.size() + link.size() + 8);
  for (const char c : link) {
    if (c == '%') {
      id += "%25";
    } else if (c == '#') {
      id += "%23";
    } else {
      id += c;
    }
  }
  if (index > 0) id += "#" + std::to_string(index);
  return id;
}

// A body going stale, or coming back, is said once each time (WARN, then INFO): a robot whose
// odometry stops would otherwise show only in the diagnostics.
void announceLiveness(Body& b, bool stale, const ros::Time& now, double stale_timeout) {
  if (stale == b.status.announced_stale) return;
  b.status.announced_stale = stale;
  const char* topic = b.sources.empty() ? "" : b.sources.front()->topic().c_str();
  if (stale) {
    ROS_WARN_NAMED("vadop_monitor",
                   "body \"%s\": stale: no message on %s for %.2f s (stale_timeout %.2f s): predicted standing "
                   "still at its last pose, its gate (if any) stops it",
                   b.name.c_str(), topic, secondsBetween(now, b.status.last_receipt), stale_timeout);
  } else {
    ROS_INFO_NAMED("vadop_monitor", "body \"%s\": messages on %s again: predicted from its motion", b.name.c_str(),
                   topic);
  }
}

}  // namespace

// Parsed URDFs and kinematics by parameter name (a fleet usually shares one description), with
// the error of each that failed.
class BodyRegistry::UrdfCache {
 public:
  UrdfCache(const ParamReader& read_param, const MeshLoader& load_mesh) : read_param_(read_param), load_mesh_(load_mesh) {}

  std::shared_ptr<UrdfShapes> shapes(const std::string& param, std::string& error) {
    if (parsed_.count(param)) return parsed_[param];
    if (parse_error_.count(param)) {
      error = parse_error_[param];
      return nullptr;
    }
    std::string text;
    if (!read_param_ || !read_param_(param, text)) {
      error = "robot_description parameter \"" + param + "\" does not exist (or is not a string)";
    } else {
      try {
        auto shapes = std::make_shared<UrdfShapes>(urdfToShapes(text, load_mesh_));
        parsed_[param] = shapes;
        return shapes;
      } catch (const UrdfError& e) {
        error = "robot_description \"" + param + "\": " + e.what();
      }
    }
    parse_error_[param] = error;
    return nullptr;
  }

  // Null (and `error` why) when the description has no kinematics.
  std::shared_ptr<const JointKinematics> kinematics(const std::string& param, std::string& error) {
    auto it = kinematics_.find(param);
    if (it == kinematics_.end()) {
      std::shared_ptr<const JointKinematics> k;
      std::string text;
      try {
        if (read_param_(param, text)) k = std::make_shared<const JointKinematics>(text);
      } catch (const UrdfError& e) {
        kinematics_error_[param] = e.what();
      }
      it = kinematics_.emplace(param, k).first;
    }
    error = kinematics_error_[param];
    return it->second;
  }

 private:
  const ParamReader& read_param_;
  const MeshLoader& load_mesh_;
  std::map<std::string, std::shared_ptr<UrdfShapes>> parsed_;
  std::map<std::string, std::string> parse_error_;
  std::map<std::string, std::shared_ptr<const JointKinematics>> kinematics_;
  std::map<std::string, std::string> kinematics_error_;
};

BodyRegistry::BodyRegistry(const MonitorParams& params, const ParamReader& read_param, const MeshLoader& load_mesh)
    : fixed_frame_(params.fixed_frame), stale_timeout_(params.stale_timeout) {
  UrdfCache urdfs(read_param, load_mesh);
  bodies_.reserve(params.bodies.size() + params.static_obstacles.size());
  elements_.reserve(params.bodies.size() + params.static_obstacles.size());  // at least one each, usually
  for (const BodyParams& bp : params.bodies) addMovingBody(bp, urdfs);
  for (const StaticObstacleParams& op : params.static_obstacles) addStaticObstacle(op, urdfs);
  checkUniqueIds();
}

bool BodyRegistry::addGeometry(size_t bi, bool has_shape, const vadop::Shape& shape, const std::string& description,
                               bool links_from_tf, const std::string& tf_prefix, UrdfCache& urdfs) {
  if (has_shape) {
    Element e;
    e.id = bodies_[bi].name;
    e.body = bi;
    e.shape = shape;
    elements_.push_back(std::move(e));
    bodies_[bi].elements.push_back(elements_.size() - 1);
    return true;
  }
  std::string error;
  const auto urdf = urdfs.shapes(description, error);
  if (!urdf) {
    bodies_[bi].status.geometry_errors.push_back(error);
    bodies_[bi].status.state = BodyState::kNoGeometry;
    return false;
  }
  addUrdfGeometry(bi, description, *urdf, links_from_tf, tf_prefix);
  return true;
}

void BodyRegistry::addMovingBody(const BodyParams& bp, UrdfCache& urdfs) {
  Body body;
  body.name = bp.name;
  body.params = bp;
  bodies_.push_back(std::move(body));
  const size_t bi = bodies_.size() - 1;
  Body& b = bodies_[bi];
  const bool has_geometry =
      addGeometry(bi, bp.has_shape, bp.shape, bp.robot_description, bp.links_from_tf, bp.tf_prefix, urdfs);
  bool moves_joints = false;
  for (const SourceKind& kind : sourceKinds()) moves_joints = moves_joints || (kind.kinematics_input && kind.wanted(bp));
  if (has_geometry && moves_joints && !b.elements.empty()) attachKinematics(b, urdfs);
  // Sources after the kinematics: the joint sources size their state from them.
  for (const SourceKind& kind : sourceKinds()) {
    if (kind.wanted(bp)) b.sources.push_back(kind.make(bp, b));
  }
}

void BodyRegistry::attachKinematics(Body& b, UrdfCache& urdfs) {
  const std::string& description = b.params.robot_description;
  std::string error;
  b.kinematics = urdfs.kinematics(description, error);
  if (!b.kinematics) {
    b.status.geometry_errors.push_back("robot_description \"" + description +
                                       "\": no kinematics for the joint inputs: " + error);
    return;  // its links stay rigid (joints at zero)
  }
  // Element offsets: the collision origin in its link's frame.
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    const auto li = b.link_in_root.find(e.link);
    if (li != b.link_in_root.end()) e.offset = li->second.inverse() * e.root_offset;
  }
}

void BodyRegistry::addStaticObstacle(const StaticObstacleParams& op, UrdfCache& urdfs) {
  Body b;
  b.name = op.name;
  b.is_static = true;
  b.has_state = true;
  b.status.state = BodyState::kStatic;
  bodies_.push_back(std::move(b));
  const size_t bi = bodies_.size() - 1;
  if (!addGeometry(bi, op.has_shape, op.shape, op.robot_description, false, "", urdfs)) return;
  // Static elements: fixed pose, zero velocity, always active.
  for (const size_t ei : bodies_[bi].elements) {
    Element& e = elements_[ei];
    const Eigen::Isometry3d pose = op.pose * e.offset;
    e.motion = vadop::makeMotion(pose.translation(), Eigen::Quaterniond(pose.linear()), Eigen::Vector3d::Zero(),
                                 Eigen::Vector3d::Zero(), 0.0);
    e.active = true;
  }
}

void BodyRegistry::checkUniqueIds() const {
  // Element ids are unique by construction (unique body names without '/', urdfElementId);
  // a duplicate would leave an element out of the world (it keys by id), so it is an internal
  // error, not a warning.
  std::unordered_set<std::string> ids;
  ids.reserve(elements_.size());
  for (const Element& e : elements_) {
    if (!ids.insert(e.id).second) {
      throw std::logic_error("internal error: collision element id \"" + e.id + "\" (body \"" +
                             bodies_[e.body].name + "\") is not unique");
    }
  }
}

void BodyRegistry::addUrdfGeometry(size_t bi, const std::string& description, const UrdfShapes& urdf,
                                   bool links_from_tf, const std::string& tf_prefix) {
  Body& b = bodies_[bi];
  b.adjacent = urdf.adjacent;
  b.link_in_root = urdf.link_in_root;
  b.root_link = urdf.root_link;
  for (const std::string& err : urdf.errors) {
    b.status.geometry_errors.push_back("robot_description \"" + description + "\": " + err);
  }
  for (const LinkGeometry& g : urdf.geometries) {
    Element e;
    e.id = urdfElementId(b.name, g.link, g.index);
    e.body = bi;
    e.link = g.link;
    e.shape = g.shape;
    e.mesh_uri = g.mesh_uri;
    e.mesh_scale = g.mesh_scale;
    if (links_from_tf) {
      e.offset = g.origin;
      e.tf_frame = tf_prefix.empty() ? g.link : tf_prefix + "/" + g.link;
    } else {
      const auto it = urdf.link_in_root.find(g.link);
      e.root_offset = (it != urdf.link_in_root.end() ? it->second : Eigen::Isometry3d::Identity()) * g.origin;
      e.offset = e.root_offset;
    }
    elements_.push_back(std::move(e));
    b.elements.push_back(elements_.size() - 1);
  }
  if (b.elements.empty()) {
    b.status.geometry_errors.push_back("robot_description \"" + description + "\": no usable collision element");
    b.status.state = BodyState::kNoGeometry;
  }
  // Rigid links: offsets relative to the root until the body frame is known.
  b.reference_for.clear();
}

int BodyRegistry::find(const std::string& name) const {
  for (size_t i = 0; i < bodies_.size(); ++i) {
    if (bodies_[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<std::string> BodyRegistry::geometryErrors() const {
  std::vector<std::string> out;
  for (const Body& b : bodies_) {
    for (const std::string& e : b.status.geometry_errors) {
      out.push_back(std::string(b.is_static ? "static obstacle" : "body") + " \"" + b.name + "\": " + e);
    }
  }
  return out;
}

const Source* Body::source(const char* kind) const {
  for (const auto& s : sources) {
    if (std::string_view(s->kind()) == kind) return s.get();
  }
  return nullptr;
}

const VelocityState* Body::velocityState() const {
  return sources.empty() ? nullptr : sources.front()->velocityState();
}

ros::Time addSeconds(const ros::Time& t, double s) {
  if (std::isnan(s)) return t;
  const double ns = static_cast<double>(t.toNSec()) + s * 1e9;
  if (!(ns > 0.0)) return ros::Time();
  // 2^32 s in ns is 4.29e18 (not exact in a double): anything at or beyond is the largest time.
  if (ns >= static_cast<double>(ros::TIME_MAX.toNSec())) return ros::TIME_MAX;
  ros::Time out;
  out.fromNSec(static_cast<uint64_t>(ns));
  return out;
}

bool receiptFresh(const ros::Time& receipt, const ros::Time& now, double timeout) {
  const double age = secondsBetween(now, receipt);
  return age <= timeout && age >= -BodyRegistry::kClockLag;
}

std::string BodyRegistry::motionRangeError(const vadop::Motion& m, double t0, double t1) {
  using vadop::kMaxAngularSpeed;
  using vadop::kMaxCoordinate;
  using vadop::kMaxLinearSpeed;
  using vadop::kMaxReach;
  using vadop::kMaxTime;
  if (!vadop::isValidMotion(m)) {
    try {
      vadop::validateMotion(m, "motion");
    } catch (const vadop::InvalidArgument& e) {
      return e.what();
    }
  }
  // Norms (not components): the strictest reading of the library's limits.
  const auto beyond = [](const char* what, double value, double limit, const char* unit) {
    return std::string(what) + " " + numberText(value) + " " + unit + " is beyond " + numberText(limit) + " " + unit;
  };
  if (!(std::fabs(m.t_ref) <= kMaxTime)) return beyond("|t_ref|", std::fabs(m.t_ref), kMaxTime, "s");
  if (!(m.position.norm() <= kMaxCoordinate)) return beyond("|position|", m.position.norm(), kMaxCoordinate, "m");
  if (!(m.pivot_offset.norm() <= kMaxCoordinate)) {
    return beyond("|pivot offset|", m.pivot_offset.norm(), kMaxCoordinate, "m");
  }
  if (!(m.linear_velocity.norm() <= kMaxLinearSpeed)) {
    return beyond("|linear velocity|", m.linear_velocity.norm(), kMaxLinearSpeed, "m/s");
  }
  if (!(m.angular_velocity.norm() <= kMaxAngularSpeed)) {
    return beyond("|angular velocity|", m.angular_velocity.norm(), kMaxAngularSpeed, "rad/s");
  }
  // The origin stays within |pivot(t)| + |pivot offset| of zero; the pivot moves on a line, so
  // its largest distance over [t0, t1] is at an end.
  const double spin_radius = m.pivotArm();
  for (const double t : {t0, t1}) {
    const double reach = m.centreAt(t).norm() + spin_radius;
    if (!(reach <= kMaxReach)) {
      return "its position at t = " + numberText(t) + " s (" + numberText(reach) + " m from the origin) is beyond " +
             numberText(kMaxReach) + " m";
    }
  }
  return "";
}

void BodyRegistry::rejectInput(Body& b, const std::string& why, const ros::Time& receipt, bool count_message) {
  if (count_message) {
    ++b.status.dropped_invalid;
  } else {
    ++b.status.elements_left_out;
  }
  b.status.last_invalid = why;
  b.status.last_invalid_receipt = receipt;
  const double now = wallNow();
  if (now - b.last_warn_invalid >= kWarnPeriod) {
    b.last_warn_invalid = now;
    if (count_message) {
      ROS_WARN_NAMED("vadop_monitor", "body \"%s\": message dropped: %s (%llu dropped so far; warnings for this body "
                     "throttled to one per %.0f s)",
                     b.name.c_str(), why.c_str(), static_cast<unsigned long long>(b.status.dropped_invalid),
                     kWarnPeriod);
    } else {
      ROS_WARN_NAMED("vadop_monitor", "%s \"%s\": %s: left out of the prediction (warnings for this body throttled "
                     "to one per %.0f s)",
                     b.is_static ? "static obstacle" : "body", b.name.c_str(), why.c_str(), kWarnPeriod);
    }
  }
}

void BodyRegistry::markElementBad(size_t element, const std::string& why, const ros::Time& now) {
  const Element& e = elements_.at(element);
  rejectInput(bodies_.at(e.body), "element \"" + e.id + "\": " + why, now, false);
}

std::string stampSkewError(const ros::Time& stamp, const ros::Time& receipt, double max_skew) {
  const double skew = secondsBetween(stamp, receipt);
  if (std::fabs(skew) <= max_skew) return "";
  return "stamp " + stampText(stamp) + " is " + numberText(std::fabs(skew)) + " s " + (skew > 0 ? "ahead of" : "behind") +
         " the node's clock (" + stampText(receipt) + ") at its receipt: beyond ~max_stamp_skew = " +
         numberText(max_skew) + " s";
}

std::string BodyRegistry::stampSkewError(const ros::Time& stamp, const ros::Time& receipt) const {
  return vadop_ros::stampSkewError(stamp, receipt, max_stamp_skew_);
}

InputResult BodyRegistry::stampDecision(ros::Time& stamp, const ros::Time& receipt, bool has_state,
                                        const ros::Time& last, double max_skew, std::string& why) {
  if (stamp.isZero()) stamp = receipt;
  // Far from the node's clock, ahead or behind: invalid (it would blind the body, or be
  // extrapolated over hours).
  why = vadop_ros::stampSkewError(stamp, receipt, max_skew);
  if (!why.empty()) return InputResult::kInvalid;
  // Out of order / duplicate, but only while the last stamp is not ahead of this receipt by more
  // than the clock may lag the messages (a simulated /clock is published at its own rate, so a
  // message often arrives a few ms before the clock reaches its stamp): a stamp further in the
  // future blocks nothing once the clock has reached it.
  if (has_state && stamp <= last && secondsBetween(last, receipt) <= kClockLag) return InputResult::kOutOfOrder;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::acceptStamp(Body& b, ros::Time stamp, const ros::Time& receipt, ros::Time& last) {
  std::string why;
  const InputResult decision = stampDecision(stamp, receipt, b.has_state, last, max_stamp_skew_, why);
  if (decision == InputResult::kInvalid) {
    rejectInput(b, why, receipt);
  } else if (decision == InputResult::kOutOfOrder) {
    ++b.status.dropped_out_of_order;
    ROS_DEBUG_NAMED("vadop_monitor", "body \"%s\": message with stamp %s ignored (not newer than %s)", b.name.c_str(),
                    stampText(stamp).c_str(), stampText(last).c_str());
  } else {
    last = stamp;
  }
  return decision;
}

void BodyRegistry::acceptMotion(Body& b, Element& e, const vadop::Motion& m,
                                std::shared_ptr<const vadop::LinkChain> chain, const ros::Time& now, double t_now,
                                double t_check_end, const char* out_of_range) {
  // The library's range over [now, now + the largest horizon]: one element out of it is left
  // out (and its body marked), never the whole prediction.
  const std::string why = motionRangeError(m, t_now, t_check_end);
  if (!why.empty()) {
    rejectInput(b, (e.link.empty() ? std::string("motion") : "link \"" + e.link + "\": motion") + out_of_range + why,
                now, false);
    return;
  }
  e.motion = m;
  e.chain = std::move(chain);
  e.active = true;
}

namespace {

// The joints of a body at a cycle: each one's path (its velocity from its stamp, clamped at its
// limits, or the running trajectory), and whether any moves.
struct JointMotion {
  std::vector<vadop::JointPath> paths;
  bool moving = false;
  bool on_trajectory = false;
};

// Joint j at time t (registry seconds): its position carried from its stamp with its velocity
// (none when the joint states or the body are stale), clamped at its limits; a running
// trajectory (its last point after now) overrides the joints it names: the cubic through its
// positions and velocities, straight lines without velocities, positions clamped.
template <class Seconds>
JointMotion jointMotion(const JointKinematics& kin, const JointInput* js, const TrajectoryInput* traj,
                        const ros::Time& now, double t_now, bool stale, bool joints_stale, const Seconds& seconds) {
  const size_t nj = kin.joints().size();
  JointMotion out;
  out.paths.reserve(nj);
  for (size_t j = 0; j < nj; ++j) {
    const bool reported = js && !js->q_time[j].isZero();  // never reported: at zero
    const double since = reported ? seconds(js->q_time[j]) : t_now;
    const double rate = reported && !(stale || joints_stale) ? js->qd[j] : 0.0;
    out.moving = out.moving || rate != 0.0;
    out.paths.push_back(
        vadop::JointPath::constantVelocity(since, js ? js->q[j] : 0.0, rate, kin.lower(j), kin.upper(j)));
  }
  out.on_trajectory = !stale && traj && !traj->time.empty() && traj->time.back() > now;
  if (!out.on_trajectory) return out;
  out.moving = true;
  std::vector<double> point_time;
  for (const ros::Time& pt : traj->time) point_time.push_back(seconds(pt));
  for (size_t i = 0; i < traj->joints.size(); ++i) {
    const size_t j = static_cast<size_t>(traj->joints[i]);
    std::vector<double> positions, velocities;
    for (size_t k = 0; k < point_time.size(); ++k) {
      positions.push_back(kin.clamp(j, traj->q[k][i]));
      if (!traj->qd.empty()) velocities.push_back(traj->qd[k][i]);
    }
    out.paths[j] = vadop::JointPath(point_time, std::move(positions), 0.0, std::move(velocities));
  }
  return out;
}

// The joints between the body's reference link and `link` along their paths, then the
// collision geometry's `offset` in its link (none: rigid, when the link is not in the tree).
std::vector<vadop::ChainJoint> chainJoints(const JointKinematics& kin, const std::string& reference_link,
                                           const std::string& link, const Eigen::Isometry3d& offset,
                                           const std::vector<vadop::JointPath>& joint_paths) {
  std::vector<JointKinematics::Step> steps;
  if (!kin.chain(reference_link, link, steps)) steps.clear();
  std::vector<vadop::ChainJoint> joints;
  joints.reserve(steps.size() + 1);
  for (const JointKinematics::Step& st : steps) {
    vadop::ChainJoint c;
    c.origin = st.origin;
    c.axis = st.axis;
    c.type = st.kind == JointKinematics::Step::Kind::kRevolute    ? vadop::JointType::kRevolute
             : st.kind == JointKinematics::Step::Kind::kPrismatic ? vadop::JointType::kPrismatic
                                                                  : vadop::JointType::kFixed;
    if (st.joint >= 0) {
      const vadop::JointPath& jp = joint_paths[static_cast<size_t>(st.joint)];
      if (st.sign > 0.0) {
        c.path = jp;
      } else {
        std::vector<double> negated = jp.positions(), negated_rates = jp.velocities();
        for (double& q : negated) q = -q;
        for (double& v : negated_rates) v = -v;
        c.path = vadop::JointPath(jp.times(), std::move(negated), -jp.velocityAfter(), std::move(negated_rates));
      }
    }
    joints.push_back(std::move(c));
  }
  vadop::ChainJoint shape_offset;  // the collision geometry in its link
  shape_offset.origin = offset;
  joints.push_back(shape_offset);
  return joints;
}

}  // namespace

void BodyRegistry::holdJoints(Body& b, const BodyInputs& in, const ros::Time& now, double t_now, double t_check_end,
                              const vadop::Motion& frame) {
  const JointKinematics& kin = *b.kinematics;
  const size_t nj = kin.joints().size();
  // The joints' positions now, clamped at the limits.
  std::vector<double> qt(nj, 0.0);
  for (size_t j = 0; j < nj; ++j) qt[j] = kin.clamp(j, in.joints ? in.joints->q[j] : 0.0);
  Eigen::Isometry3d ref;
  if (!kin.linkPose(qt, b.reference_link, ref)) ref.setIdentity();
  const Eigen::Isometry3d ref_inv = ref.inverse();
  const Eigen::Isometry3d fb = frame.poseAt(frame.t_ref);
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    Eigen::Isometry3d link;
    if (!kin.linkPose(qt, e.link, link)) link.setIdentity();
    const Eigen::Isometry3d rel = ref_inv * link * e.offset;  // the element in the body frame
    const Eigen::Isometry3d pe = fb * rel;
    acceptMotion(b, e,
                 twistMotion(pe, frame.velocityOfPoint(pe.translation(), frame.t_ref), frame.angular_velocity,
                             frame.t_ref),
                 nullptr, now, t_now, t_check_end, " out of range: ");
  }
}

void BodyRegistry::updateJointBody(Body& b, const BodyInputs& in, const ros::Time& now, double t_now,
                                   double t_check_end, const vadop::Motion& frame, bool stale,
                                   const vadop::TimedPath* plan) {
  const JointKinematics& kin = *b.kinematics;
  const bool joints_stale = !in.joints || !in.joints->has_joints || !receiptFresh(in.joints->receipt, now, stale_timeout_);
  JointMotion joints = jointMotion(kin, in.joints, in.trajectory, now, t_now, stale, joints_stale,
                                   [this](const ros::Time& t) { return seconds(t); });
  if (!joints.moving && !plan) {
    // Rigid at the current joint positions: the body frame's constant twist, exact.
    holdJoints(b, in, now, t_now, t_check_end, frame);
    return;
  }
  std::optional<vadop::TimedPath> base_path;  // each link's chain starts from a copy
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    try {
      if (!base_path) plan ? base_path.emplace(*plan) : base_path.emplace(frame);
      auto chain = std::make_shared<const vadop::LinkChain>(
          *base_path, chainJoints(kin, b.reference_link, e.link, e.offset, joints.paths));
      const vadop::PosedTwist state = chain->stateAt(t_now);
      acceptMotion(b, e, twistMotion(state.pose, state.velocity, state.angular_velocity, t_now), std::move(chain),
                   now, t_now, t_check_end, " out of range: ");
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, "link \"" + e.link + "\": joint motion out of range: " + ex.what(), now, false);
    }
  }
  b.status.joints_moving = joints.moving;
  b.status.on_trajectory = joints.on_trajectory;
  b.status.on_path = plan != nullptr;
}

namespace {

// Throws vadop::InvalidArgument naming the first piece of `path` out of the library's range over
// the part of [t_now, t_check_end] in which it holds.
void checkPathRange(const vadop::TimedPath& path, double t_now, double t_check_end) {
  for (size_t piece = 0; piece < path.pieces(); ++piece) {
    const double from = std::max(t_now, path.start(piece)), to = std::min(t_check_end, path.start(piece + 1));
    if (!(from <= to)) continue;
    const std::string why = BodyRegistry::motionRangeError(path.motion(piece), from, to);
    if (!why.empty()) throw vadop::InvalidArgument("piece " + std::to_string(piece) + ": " + why);
  }
}

}  // namespace

void BodyRegistry::warnPlanNotFollowed(Body& b, const ros::Time& now, const std::string& why) {
  // The plan cannot be followed (e.g. two poses 1 ms apart and metres away): the twist is.
  b.status.last_invalid = "path: not followed, the body's twist is used instead: " + why;
  b.status.last_invalid_receipt = now;
  const double wall = wallNow();
  if (wall - b.last_warn_invalid >= kWarnPeriod) {
    b.last_warn_invalid = wall;
    ROS_WARN_NAMED("vadop_monitor", "body \"%s\": %s (warnings for this body throttled to one per %.0f s)",
                   b.name.c_str(), b.status.last_invalid.c_str(), kWarnPeriod);
  }
}

std::optional<vadop::TimedPath> BodyRegistry::planPath(Body& b, const BodyInputs& in, const ros::Time& now,
                                                        double t_now, double t_check_end,
                                                        const Eigen::Isometry3d& frame_now) {
  if (!in.plan || in.plan->empty() || !(in.plan->back().first > now)) return std::nullopt;
  const Plan& plan = *in.plan;
  // The body frame from its pose now through the poses stamped after now. A pose within 1 ms
  // after now is left out: the current pose stands for it (a piece that short would turn a
  // centimetre of odometry error into metres per second).
  constexpr double kMinPiece = 1e-3;
  std::vector<vadop::Keyframe> frames;
  frames.reserve(plan.size() + 1);
  frames.push_back({t_now, frame_now.translation(), Eigen::Quaternion<double>(frame_now.linear())});
  for (const auto& [stamp, pose] : plan) {
    const double t = seconds(stamp);
    if (t < t_now + kMinPiece) continue;
    frames.push_back({t, pose.translation(), Eigen::Quaterniond(pose.linear())});
  }
  if (frames.size() < 2) return std::nullopt;
  const vadop::AfterPath after = in.plan_continue ? vadop::AfterPath::kContinue : vadop::AfterPath::kHold;
  try {
    vadop::TimedPath path(std::move(frames), after);
    checkPathRange(path, t_now, t_check_end);
    return path;
  } catch (const vadop::InvalidArgument& ex) {
    warnPlanNotFollowed(b, now, ex.what());
    return std::nullopt;
  }
}

void BodyRegistry::followPlan(Body& b, const BodyInputs& in, const ros::Time& now, const vadop::TimedPath& plan,
                              double t_now, double t_check_end, const Eigen::Isometry3d& frame_now) {
  const vadop::AfterPath after = in.plan_continue ? vadop::AfterPath::kContinue : vadop::AfterPath::kHold;
  std::vector<std::shared_ptr<const vadop::LinkChain>> paths;
  paths.reserve(b.elements.size());
  try {
    for (const size_t ei : b.elements) {
      const Element& e = elements_[ei];
      if (!e.active) {
        paths.push_back(nullptr);
        continue;
      }
      // The element's pose in the body frame now, kept along the plan.
      const Eigen::Isometry3d in_body = frame_now.inverse() * e.motion.poseAt(t_now);
      std::vector<vadop::Keyframe> k = plan.keyframes();
      for (vadop::Keyframe& f : k) {
        Eigen::Isometry3d fp = Eigen::Isometry3d::Identity();
        fp.linear() = f.orientation.toRotationMatrix();
        fp.translation() = f.position;
        const Eigen::Isometry3d pe = fp * in_body;
        f.position = pe.translation();
        f.orientation = Eigen::Quaterniond(pe.linear());
      }
      const vadop::TimedPath path(std::move(k), after);
      checkPathRange(path, t_now, t_check_end);
      paths.push_back(std::make_shared<const vadop::LinkChain>(path));
    }
  } catch (const vadop::InvalidArgument& ex) {
    warnPlanNotFollowed(b, now, ex.what());
    return;
  }
  for (size_t k = 0; k < b.elements.size(); ++k) elements_[b.elements[k]].chain = std::move(paths[k]);
  b.status.on_path = true;
}

bool BodyRegistry::lookup(TransformSource& tf, const std::string& target, const std::string& source,
                          const ros::Time& time, Eigen::Isometry3d& pose, ros::Time& stamp, std::string& error) {
  try {
    if (!tf.lookup(target, source, time, pose, stamp, error)) return false;
  } catch (const std::exception& e) {
    // tf2 formats its extrapolation errors with ros::Duration(requested - latest), which
    // throws std::runtime_error when the two are more than 2^31 s apart.
    error = std::string("transform lookup failed: ") + e.what();
    return false;
  }
  if (!(pose.matrix().allFinite())) {
    error = "transform from \"" + source + "\" to \"" + target + "\" is not finite";
    return false;
  }
  return true;
}

void BodyRegistry::warnTf(Body& b, const std::string& error, const ros::Time& ros_now) {
  b.status.tf_error = error;
  if (b.tf_missing_since.isZero()) b.tf_missing_since = ros_now;
  if (secondsBetween(ros_now, b.tf_missing_since) < kTfWarnAfter) return;
  const double now = wallNow();
  if (now - b.last_warn_tf >= kWarnPeriod) {
    b.last_warn_tf = now;
    ROS_WARN_NAMED("vadop_monitor", "body \"%s\" skipped this cycle: %s (warnings for this body throttled to one "
                   "per %.0f s)",
                   b.name.c_str(), error.c_str(), kWarnPeriod);
  }
}

void BodyRegistry::resolveReference(Body& b, const std::string& body_frame) {
  if (b.reference_for == body_frame || b.params.has_shape || b.params.links_from_tf) return;
  b.reference_for = body_frame;
  // The reference link: the body frame without the tf prefix (or its last path component)
  // when it names a URDF link, else the root link.
  std::string ref = body_frame;
  if (!b.link_in_root.count(ref)) {
    const size_t slash = ref.find_last_of('/');
    if (slash != std::string::npos) ref = ref.substr(slash + 1);
  }
  const auto it = b.link_in_root.find(ref);
  b.reference_link = it != b.link_in_root.end() ? ref : b.root_link;
  if (b.kinematics) return;  // link poses from the joints each cycle
  Eigen::Isometry3d root_in_ref = Eigen::Isometry3d::Identity();
  if (it != b.link_in_root.end()) root_in_ref = it->second.inverse();
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    e.offset = root_in_ref * e.root_offset;
  }
}

void BodyRegistry::update(const ros::Time& now, TransformSource& tf) {
  // Seconds since the base stay within kRebaseAfterSeconds of zero: far inside vadop::kMaxTime
  // whatever the clock (epoch seconds, a /clock jump to 4e9 s, a jump back).
  if (!has_base_ || !(std::fabs(seconds(now)) <= kRebaseAfterSeconds)) {
    base_ = now;
    has_base_ = true;
    ++rebases_;
  }
  if (first_update_.isZero()) first_update_ = now;
  const double t_now = seconds(now);
  const double t_check_end = t_now + kMotionCheckWindow;
  // A body writes only itself, its sources and its elements (its warnings too); the kinematics
  // it may share with others is read only (KDL's recursive solver keeps no state).
  auto updateOne = [&](size_t i) {
    Body& b = bodies_[i];
    if (b.is_static) {
      updateStatic(b, now, t_now, t_check_end);
    } else {
      updateMoving(b, now, t_now, t_check_end, tf);
    }
  };
  // Below a few hundred bodies a thread costs more than it saves.
  constexpr size_t kBodiesPerThread = 256;
  constexpr size_t kChunk = 32;
  vadop::parallelFor(tf.concurrent() ? threads_ : 1, bodies_.size(), kBodiesPerThread, kChunk, updateOne);
}

void BodyRegistry::updateStatic(Body& b, const ros::Time& now, double t_now, double t_check_end) {
  // Fixed motions (zero velocity, set at start-up): checked like the others, so that one
  // obstacle out of range is left out instead of failing every prediction.
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    const std::string why = motionRangeError(e.motion, t_now, t_check_end);
    e.active = why.empty();
    if (!e.active) rejectInput(b, "element \"" + e.id + "\": " + why, now, false);
  }
}

void BodyRegistry::setThreads(int threads) { threads_ = vadop::threadCount(threads); }

bool BodyRegistry::updateBody(size_t body, const ros::Time& now, TransformSource& tf) {
  if (!has_base_ || body >= bodies_.size() || bodies_[body].is_static) return false;
  const double t_now = seconds(now);
  Body& b = bodies_[body];
  updateMoving(b, now, t_now, t_now + kMotionCheckWindow, tf);
  return b.frame_motion.valid;
}

bool BodyRegistry::startCycle(Body& b) {
  for (const size_t ei : b.elements) {
    elements_[ei].active = false;
    elements_[ei].chain.reset();
  }
  b.status.on_path = false;
  b.status.joints_moving = false;
  b.status.on_trajectory = false;
  b.frame_motion.valid = false;
  b.status.tf_error.clear();
  b.status.links_skipped = 0;
  if (b.elements.empty()) {
    b.status.state = BodyState::kNoGeometry;
    return false;
  }
  if (!b.has_state) {
    b.status.state = BodyState::kWaiting;
    return false;
  }
  return true;
}

bool BodyRegistry::frameMotion(Body& b, const ros::Time& now, double t_now, double t_check_end, const BodyInputs& in,
                               double tr, vadop::Motion& frame) {
  // The body frame's own motion, which its elements, its plan and the velocity gate all carry:
  // out of the library's range over the window (a pose from tf stamped far from the clock), the
  // body is left out as a whole, as when its transform is missing.
  std::string frame_error;
  try {
    frame = twistMotion(in.pose, in.v, in.w, tr);
    frame_error = motionRangeError(frame, t_now, t_check_end);
  } catch (const vadop::InvalidArgument& ex) {
    frame_error = ex.what();
  }
  if (frame_error.empty()) return true;
  b.status.tf_error = "the body frame's motion is out of range: " + frame_error;
  rejectInput(b, b.status.tf_error, now, false);
  b.status.state = BodyState::kTfMissing;
  return false;
}

void BodyRegistry::collect(Body& b) {
  for (const auto& source : b.sources) source->collect(b, *this);
}

void BodyRegistry::updateMoving(Body& b, const ros::Time& now, double t_now, double t_check_end, TransformSource& tf) {
  collect(b);  // what the callbacks posted since the last cycle (source.h: Source::collect)
  if (!startCycle(b)) return;
  // Every source adds its latest message (the velocity source first: the body frame's motion).
  BodyInputs in;
  for (const auto& source : b.sources) {
    if (!source->contribute(b, *this, now, tf, in)) {
      b.status.state = BodyState::kTfMissing;
      return;
    }
  }
  const bool stale = !receiptFresh(b.status.last_receipt, now, stale_timeout_);
  announceLiveness(b, stale, now, stale_timeout_);
  if (stale) {
    in.v.setZero();
    in.w.setZero();
  }
  resolveReference(b, *in.frame);
  // A stale body stands still: its pose holds at any time, so its motion is referred to
  // `now` (its stamp may be hours old, beyond the library's time range).
  const double tr = seconds(stale ? now : in.t_ref);
  vadop::Motion frame;
  if (!frameMotion(b, now, t_now, t_check_end, in, tr, frame)) return;
  if (b.kinematics) {
    // A mobile manipulator on its plan: its links' chains start from the body frame along it.
    const std::optional<vadop::TimedPath> plan =
        stale ? std::nullopt : planPath(b, in, now, t_now, t_check_end, frame.poseAt(t_now));
    try {
      updateJointBody(b, in, now, t_now, t_check_end, frame, stale, plan ? &*plan : nullptr);
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, std::string("invalid motion: ") + ex.what(), now, false);
    }
    b.tf_missing_since = ros::Time();
    b.status.state = stale ? BodyState::kStale : BodyState::kOk;
    b.frame_motion = FrameMotion{true, stale, in.pose, in.v, in.w, tr, frame};
    return;
  }
  updateRigidBody(b, now, t_now, t_check_end, tf, in, stale, frame, tr);
  if (b.status.links_skipped > 0) {
    b.status.state = BodyState::kTfMissing;
    return;
  }
  b.tf_missing_since = ros::Time();
  b.status.state = stale ? BodyState::kStale : BodyState::kOk;
  b.frame_motion = FrameMotion{true, stale, in.pose, in.v, in.w, tr, frame};
  if (!stale && in.plan) {
    const Eigen::Isometry3d frame_now = frame.poseAt(t_now);
    if (const auto plan = planPath(b, in, now, t_now, t_check_end, frame_now)) {
      followPlan(b, in, now, *plan, t_now, t_check_end, frame_now);
    }
  }
}

void BodyRegistry::updateRigidBody(Body& b, const ros::Time& now, double t_now, double t_check_end,
                                   TransformSource& tf, const BodyInputs& in, bool stale, const vadop::Motion& frame,
                                   double tr) {
  const ros::Time motion_ref = stale ? now : in.t_ref;
  for (const size_t ei : b.elements) {
    Element& e = elements_[ei];
    Eigen::Isometry3d pe;
    Eigen::Vector3d ve, we;
    if (e.tf_frame.empty()) {
      if (e.offset.matrix() == Eigen::Matrix4d::Identity()) {
        // One shape at the body frame (most bodies): the frame's motion, already checked.
        e.motion = frame;
        e.active = true;
        continue;
      }
      pe = in.pose * e.offset;
      ve = in.v + in.w.cross(pe.translation() - in.pose.translation());
      we = in.w;
    } else if (!tfElementMotion(b, e, now, tf, in, stale, motion_ref, pe, ve, we)) {
      continue;
    }
    try {
      acceptMotion(b, e, twistMotion(pe, ve, we, tr), nullptr, now, t_now, t_check_end,
                   " out of range after transformation: ");
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, std::string("invalid motion: ") + ex.what(), now, false);
    }
  }
}

bool BodyRegistry::tfElementMotion(Body& b, Element& e, const ros::Time& now, TransformSource& tf,
                                   const BodyInputs& in, bool stale, const ros::Time& motion_ref,
                                   Eigen::Isometry3d& pe, Eigen::Vector3d& ve, Eigen::Vector3d& we) {
  const std::string& body_frame = *in.frame;
  Eigen::Isometry3d body_link;
  ros::Time ls;
  std::string error;
  if (body_frame.empty()) {
    warnTf(b,
           "the odometry has no child_frame_id and the body no frame parameter: link poses cannot be looked up",
           now);
    ++b.status.links_skipped;
    return false;
  }
  if (!lookup(tf, body_frame, e.tf_frame, ros::Time(0), body_link, ls, error)) {
    warnTf(b, "link \"" + e.link + "\": " + error, now);
    ++b.status.links_skipped;
    return false;
  }
  // Own motion relative to the body, from the last two distinct tf stamps.
  if (e.has_rel && ls > e.rel_stamp) {
    const double dt = secondsBetween(ls, e.rel_stamp);
    e.rel_v = (body_link.translation() - e.rel_pose.translation()) / dt;
    e.rel_w = rotationVector(body_link.linear() * e.rel_pose.linear().transpose()) / dt;
    if (!e.rel_v.allFinite() || !e.rel_w.allFinite() || dt > 1.0) {
      e.rel_v.setZero();
      e.rel_w.setZero();
    }
  }
  if (!e.has_rel || ls > e.rel_stamp) {
    e.has_rel = true;
    e.rel_stamp = ls;
    e.rel_pose = body_link;
  }
  // The tf pose holds at its own stamp: carried to the body's t_ref with the link's own
  // motion (tf and odometry rarely share stamps).
  const double lag = secondsBetween(motion_ref, ls);
  if (!stale && e.has_rel && std::abs(lag) <= 1.0) {
    body_link.translation() += e.rel_v * lag;
    const Eigen::Vector3d turn = e.rel_w * lag;
    if (turn.squaredNorm() > 0.0) {
      body_link.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * body_link.linear();
    }
  }
  const Eigen::Matrix3d& rb = in.pose.linear();
  const Eigen::Isometry3d le = body_link * e.offset;  // element in the body frame
  pe = in.pose * le;
  const Eigen::Vector3d r_world = rb * le.translation();
  Eigen::Vector3d own_v = Eigen::Vector3d::Zero(), own_w = Eigen::Vector3d::Zero();
  if (!stale) {
    own_v = rb * (e.rel_v + e.rel_w.cross(le.translation() - body_link.translation()));
    own_w = rb * e.rel_w;
  }
  ve = in.v + in.w.cross(r_world) + own_v;
  we = in.w + own_w;
  return true;
}

const char* motionSource(const Body& b) {
  if (b.is_static) return "static";
  if (!b.frame_motion.valid) return "none";
  if (b.frame_motion.stale) return "stale";
  if (b.status.on_path) {
    return b.status.on_trajectory ? "path + joint trajectory" : b.status.joints_moving ? "path + joint states" : "path";
  }
  if (b.status.on_trajectory) return "joint trajectory";
  switch (b.params.source) {
    case VelocitySource::kOdometry: return b.status.joints_moving ? "odometry + joint states" : "odometry";
    case VelocitySource::kTwist: return b.status.joints_moving ? "twist + joint states" : "twist";
    case VelocitySource::kStates: return b.status.joints_moving ? "body states + joint states" : "body states";
  }
  return "none";
}

void BodyRegistry::reset() {
  ++resets_;
  has_base_ = false;
  first_update_ = ros::Time();
  for (Body& b : bodies_) {
    if (b.is_static) continue;
    b.has_state = false;
    for (const auto& source : b.sources) source->reset();
    b.status.on_path = false;
    b.status.state = b.elements.empty() ? BodyState::kNoGeometry : BodyState::kWaiting;
    b.status.announced_stale = false;
    b.status.last_receipt = ros::Time();
    b.status.last_invalid_receipt = ros::Time();
    b.tf_missing_since = ros::Time();
    b.frame_motion.valid = false;
    for (const size_t ei : b.elements) {
      Element& e = elements_[ei];
      e.active = false;
      e.chain.reset();
      if (!e.tf_frame.empty()) {
        e.has_rel = false;
        e.rel_v.setZero();
        e.rel_w.setZero();
      }
    }
  }
}

}  // namespace vadop_ros
