#include "vadop_ros/body_registry.h"

#include "message_checks.h"

#include <vadop/detail/parallel_for.h>
#include <vadop/error.h>
#include <vadop/joint_chain.h>
#include <vadop/timed_path.h>

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

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) { return {v.x, v.y, v.z}; }

// A frame id without its leading slashes (tf2 refuses them), as a view into `s`.
std::string_view withoutSlash(const std::string& s) {
  std::string_view v(s);
  while (!v.empty() && v.front() == '/') v.remove_prefix(1);
  return v;
}
std::string stripSlash(const std::string& s) { return std::string(withoutSlash(s)); }

// Rotation vector (axis * angle) of a rotation matrix, angle in [0, pi].
Eigen::Vector3d rotationVector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

std::string stampText(const ros::Time& t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%u.%09u", t.sec, t.nsec);
  return buf;
}

std::string number(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// The movable joints `names` (a message's field `field`) name, in order; "" or why not (a name
// that is not a movable joint of the URDF, or repeats).
std::string jointIndices(const JointKinematics& kin, const std::vector<std::string>& names, const std::string& field,
                         std::vector<int>& index) {
  index.assign(names.size(), -1);
  std::vector<char> seen(kin.joints().size(), 0);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string item = field + "[" + std::to_string(i) + "] \"" + names[i] + "\"";
    index[i] = kin.jointIndex(names[i]);
    if (index[i] < 0) return item + " is not a movable joint of the body's URDF";
    if (seen[static_cast<size_t>(index[i])]++) return item + " repeats";
  }
  return "";
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

}  // namespace

BodyRegistry::BodyRegistry(const MonitorParams& params, const ParamReader& read_param, const MeshLoader& load_mesh)
    : fixed_frame_(params.fixed_frame), stale_timeout_(params.stale_timeout) {
  // Parsed URDFs by parameter name (a fleet usually shares one description).
  std::map<std::string, std::shared_ptr<UrdfShapes>> parsed;
  std::map<std::string, std::string> parse_error;
  auto getUrdf = [&](const std::string& param, std::string& error) -> std::shared_ptr<UrdfShapes> {
    if (parsed.count(param)) return parsed[param];
    if (parse_error.count(param)) {
      error = parse_error[param];
      return nullptr;
    }
    std::string text;
    if (!read_param || !read_param(param, text)) {
      error = "robot_description parameter \"" + param + "\" does not exist (or is not a string)";
    } else {
      try {
        auto shapes = std::make_shared<UrdfShapes>(urdfToShapes(text, load_mesh));
        parsed[param] = shapes;
        return shapes;
      } catch (const UrdfError& e) {
        error = "robot_description \"" + param + "\": " + e.what();
      }
    }
    parse_error[param] = error;
    return nullptr;
  };

  // The body's elements: its primitive shape, or every collision element of its URDF. False
  // (and the body flagged "no geometry") when the URDF cannot be had.
  auto addGeometry = [&](size_t bi, bool has_shape, const vadop::Shape& shape, const std::string& description,
                         bool links_from_tf, const std::string& tf_prefix) {
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
    const auto urdf = getUrdf(description, error);
    if (!urdf) {
      bodies_[bi].status.geometry_errors.push_back(error);
      bodies_[bi].status.state = BodyState::kNoGeometry;
      return false;
    }
    addUrdfGeometry(bi, description, *urdf, links_from_tf, tf_prefix);
    return true;
  };

  // Kinematics of the joint-states bodies, by description parameter (null: failed).
  std::map<std::string, std::shared_ptr<const JointKinematics>> kinematics;
  std::map<std::string, std::string> kinematics_error;

  bodies_.reserve(params.bodies.size() + params.static_obstacles.size());
  elements_.reserve(params.bodies.size() + params.static_obstacles.size());  // at least one each, usually
  for (const BodyParams& bp : params.bodies) {
    Body b;
    b.name = bp.name;
    b.params = bp;
    bodies_.push_back(std::move(b));
    const size_t bi = bodies_.size() - 1;
    if (!addGeometry(bi, bp.has_shape, bp.shape, bp.robot_description, bp.links_from_tf, bp.tf_prefix)) continue;
    if ((!bp.joint_states_topic.empty() || !bp.joint_trajectory_topic.empty()) && !bodies_[bi].elements.empty()) {
      Body& jb = bodies_[bi];
      auto it = kinematics.find(bp.robot_description);
      if (it == kinematics.end()) {
        std::shared_ptr<const JointKinematics> k;
        std::string text;
        try {
          if (read_param(bp.robot_description, text)) k = std::make_shared<const JointKinematics>(text);
        } catch (const UrdfError& e) {
          kinematics_error[bp.robot_description] = e.what();
        }
        it = kinematics.emplace(bp.robot_description, k).first;
      }
      if (!it->second) {
        jb.status.geometry_errors.push_back("robot_description \"" + bp.robot_description +
                                            "\": no kinematics for the joint inputs: " +
                                            kinematics_error[bp.robot_description]);
        continue;  // its links stay rigid (joints at zero)
      }
      jb.kinematics = it->second;
      const size_t nj = jb.kinematics->joints().size();
      jb.q.assign(nj, 0.0);
      jb.qd.assign(nj, 0.0);
      jb.q_time.assign(nj, ros::Time());
      // Element offsets: the collision origin in its link's frame.
      for (const size_t ei : jb.elements) {
        Element& e = elements_[ei];
        const auto li = jb.link_in_root.find(e.link);
        if (li != jb.link_in_root.end()) e.offset = li->second.inverse() * e.root_offset;
      }
    }
  }

  for (const StaticObstacleParams& op : params.static_obstacles) {
    Body b;
    b.name = op.name;
    b.is_static = true;
    b.has_state = true;
    b.pose = op.pose;
    b.status.state = BodyState::kStatic;
    bodies_.push_back(std::move(b));
    const size_t bi = bodies_.size() - 1;
    if (!addGeometry(bi, op.has_shape, op.shape, op.robot_description, false, "")) continue;
    // Static elements: fixed pose, zero velocity, always active.
    for (const size_t ei : bodies_[bi].elements) {
      Element& e = elements_[ei];
      const Eigen::Isometry3d pose = op.pose * e.offset;
      e.motion = vadop::makeMotion(pose.translation(), Eigen::Quaterniond(pose.linear()), Eigen::Vector3d::Zero(),
                                   Eigen::Vector3d::Zero(), 0.0);
      e.active = true;
    }
  }

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
    return std::string(what) + " " + number(value) + " " + unit + " is beyond " + number(limit) + " " + unit;
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
      return "its position at t = " + number(t) + " s (" + number(reach) + " m from the origin) is beyond " +
             number(kMaxReach) + " m";
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
  return "stamp " + stampText(stamp) + " is " + number(std::fabs(skew)) + " s " + (skew > 0 ? "ahead of" : "behind") +
         " the node's clock (" + stampText(receipt) + ") at its receipt: beyond ~max_stamp_skew = " +
         number(max_skew) + " s";
}

std::string BodyRegistry::stampSkewError(const ros::Time& stamp, const ros::Time& receipt) const {
  return vadop_ros::stampSkewError(stamp, receipt, max_stamp_skew_);
}

InputResult BodyRegistry::acceptStamp(Body& b, ros::Time stamp, const ros::Time& receipt) {
  if (stamp.isZero()) stamp = receipt;
  // Far from the node's clock, ahead or behind: invalid (it would blind the body, or be
  // extrapolated over hours).
  if (const std::string why = stampSkewError(stamp, receipt); !why.empty()) {
    rejectInput(b, why, receipt);
    return InputResult::kInvalid;
  }
  // Out of order / duplicate, but only while the last stamp is not ahead of this receipt by more
  // than the clock may lag the messages (a simulated /clock is published at its own rate, so a
  // message often arrives a few ms before the clock reaches its stamp): a stamp further in the
  // future blocks nothing once the clock has reached it.
  if (b.has_state && stamp <= b.stamp && secondsBetween(b.stamp, receipt) <= kClockLag) {
    ++b.status.dropped_out_of_order;
    ROS_DEBUG_NAMED("vadop_monitor", "body \"%s\": message with stamp %s ignored (not newer than %s)", b.name.c_str(),
                    stampText(stamp).c_str(), stampText(b.stamp).c_str());
    return InputResult::kOutOfOrder;
  }
  b.stamp = stamp;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::onOdometry(size_t bi, const nav_msgs::Odometry& msg, const ros::Time& receipt) {
  Body& b = bodies_.at(bi);
  std::string why;
  const auto& p = msg.pose.pose;
  const auto& t = msg.twist.twist;
  if (!checkPoint(p.position, "pose.pose.position", why) ||
      !checkQuaternion(p.orientation, "pose.pose.orientation", why) ||
      !checkVector(t.linear, vadop::kMaxLinearSpeed, "m/s", "twist.twist.linear", why) ||
      !checkVector(t.angular, vadop::kMaxAngularSpeed, "rad/s", "twist.twist.angular", why)) {
    rejectInput(b, why, receipt);
    return InputResult::kInvalid;
  }
  const InputResult stamp_result = acceptStamp(b, msg.header.stamp, receipt);
  if (stamp_result != InputResult::kAccepted) return stamp_result;
  b.has_state = true;
  // Assigned in place: the body's strings keep their storage from message to message.
  const std::string_view source = withoutSlash(msg.header.frame_id);
  if (source.empty()) {
    b.source_frame = fixed_frame_;
  } else {
    b.source_frame.assign(source);
  }
  b.child_frame.assign(withoutSlash(msg.child_frame_id));
  b.pose = Eigen::Isometry3d::Identity();
  b.pose.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  b.pose.linear() = Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
                        .normalized()
                        .toRotationMatrix();
  b.v = toEigen(t.linear);
  b.w = toEigen(t.angular);
  b.status.last_receipt = receipt;
  ++b.status.accepted;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::onTwist(size_t bi, const geometry_msgs::TwistStamped& msg, const ros::Time& receipt) {
  Body& b = bodies_.at(bi);
  std::string why;
  if (!checkVector(msg.twist.linear, vadop::kMaxLinearSpeed, "m/s", "twist.linear", why) ||
      !checkVector(msg.twist.angular, vadop::kMaxAngularSpeed, "rad/s", "twist.angular", why)) {
    rejectInput(b, why, receipt);
    return InputResult::kInvalid;
  }
  const InputResult stamp_result = acceptStamp(b, msg.header.stamp, receipt);
  if (stamp_result != InputResult::kAccepted) return stamp_result;
  b.has_state = true;
  b.twist_frame.assign(withoutSlash(msg.header.frame_id));
  b.v = toEigen(msg.twist.linear);
  b.w = toEigen(msg.twist.angular);
  b.status.last_receipt = receipt;
  ++b.status.accepted;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::onPath(size_t bi, const nav_msgs::Path& msg, const ros::Time& receipt, TransformSource& tf) {
  Body& b = bodies_.at(bi);
  auto drop = [&](const std::string& why) {
    ++b.status.paths_dropped;
    rejectInput(b, "path: " + why + " (the previous plan is kept)", receipt);
    return InputResult::kInvalid;
  };
  const ros::Time header_stamp = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
  if (const std::string why = stampSkewError(header_stamp, receipt); !why.empty()) return drop("header." + why);
  if (header_stamp < b.plan_stamp && b.plan_stamp <= receipt) {
    ++b.status.dropped_out_of_order;
    return InputResult::kOutOfOrder;
  }
  if (msg.poses.empty()) {
    b.plan.clear();
    b.plan_stamp = header_stamp;
    ++b.status.paths_accepted;
    return InputResult::kAccepted;
  }
  const std::string frame = stripSlash(msg.header.frame_id);
  if (frame.empty()) return drop("header.frame_id is empty (the frame of the poses)");
  std::vector<std::pair<ros::Time, Eigen::Isometry3d>> plan;
  plan.reserve(msg.poses.size());
  for (size_t i = 0; i < msg.poses.size(); ++i) {
    const geometry_msgs::PoseStamped& ps = msg.poses[i];
    const std::string field = "poses[" + std::to_string(i) + "]";
    const std::string pose_frame = stripSlash(ps.header.frame_id);
    if (!pose_frame.empty() && pose_frame != frame) {
      return drop(field + ".header.frame_id \"" + pose_frame + "\" differs from header.frame_id \"" + frame + "\"");
    }
    std::string why;
    if (!checkPoint(ps.pose.position, field + ".pose.position", why) ||
        !checkQuaternion(ps.pose.orientation, field + ".pose.orientation", why)) {
      return drop(why);
    }
    if (ps.header.stamp.isZero()) {
      return drop(field + ".header.stamp is zero (a timed path needs the time the body is at each pose)");
    }
    if (!(std::fabs(secondsBetween(ps.header.stamp, receipt)) <= kRebaseAfterSeconds)) {
      return drop(field + ".header.stamp " + stampText(ps.header.stamp) + " is more than " +
                  number(kRebaseAfterSeconds) + " s from the node's clock");
    }
    if (!plan.empty() && !(ps.header.stamp > plan.back().first)) {
      return drop(field + ".header.stamp " + stampText(ps.header.stamp) + " is not after poses[" +
                  std::to_string(i - 1) + "]'s " + stampText(plan.back().first));
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    const auto& q = ps.pose.orientation;
    pose.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(ps.pose.position.x, ps.pose.position.y, ps.pose.position.z);
    plan.emplace_back(ps.header.stamp, pose);
  }
  if (frame != fixed_frame_) {
    Eigen::Isometry3d fixed_path;
    ros::Time stamp;
    std::string error;
    if (!lookup(tf, fixed_frame_, frame, header_stamp, fixed_path, stamp, error) &&
        !lookup(tf, fixed_frame_, frame, ros::Time(0), fixed_path, stamp, error)) {
      return drop("header.frame_id \"" + frame + "\": " + error);
    }
    for (auto& [t, pose] : plan) {
      pose = fixed_path * pose;
      std::string why;
      if (!(pose.translation().cwiseAbs().maxCoeff() <= vadop::kMaxCoordinate)) {
        return drop("a pose is out of range in the fixed frame (|position| > " + number(vadop::kMaxCoordinate) + " m)");
      }
    }
  }
  b.plan = std::move(plan);
  b.plan_stamp = header_stamp;
  ++b.status.paths_accepted;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::onJointState(size_t bi, const sensor_msgs::JointState& msg, const ros::Time& receipt) {
  Body& b = bodies_.at(bi);
  auto drop = [&](const std::string& why) {
    ++b.status.joint_states_dropped;
    rejectInput(b, "joint_states: " + why, receipt);
    return InputResult::kInvalid;
  };
  if (!b.kinematics) return drop("the body has no kinematics (see its geometry error)");
  const size_t n = msg.name.size();
  if (msg.position.size() != n) {
    return drop("position has " + std::to_string(msg.position.size()) + " values for " + std::to_string(n) + " names");
  }
  if (!msg.velocity.empty() && msg.velocity.size() != n) {
    return drop("velocity has " + std::to_string(msg.velocity.size()) + " values for " + std::to_string(n) +
                " names (give none or one per name)");
  }
  std::vector<int> index;
  if (const std::string why = jointIndices(*b.kinematics, msg.name, "name", index); !why.empty()) return drop(why);
  for (size_t i = 0; i < n; ++i) {
    std::string why;
    if (!checkValue(msg.position[i], vadop::kMaxCoordinate, "rad or m", "position[" + std::to_string(i) + "]", why)) {
      return drop(why);
    }
    if (!msg.velocity.empty() &&
        !checkValue(msg.velocity[i], vadop::kMaxAngularSpeed, "rad/s or m/s", "velocity[" + std::to_string(i) + "]", why)) {
      return drop(why);
    }
  }
  ros::Time stamp = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
  if (const std::string why = stampSkewError(stamp, receipt); !why.empty()) return drop("header." + why);
  if (b.has_joints && stamp <= b.joint_stamp && b.joint_stamp <= receipt) {
    ++b.status.dropped_out_of_order;
    return InputResult::kOutOfOrder;
  }
  for (size_t i = 0; i < n; ++i) {
    const size_t j = static_cast<size_t>(index[i]);
    b.q[j] = msg.position[i];
    b.qd[j] = msg.velocity.empty() ? 0.0 : msg.velocity[i];
    b.q_time[j] = stamp;
  }
  b.has_joints = true;
  b.joint_stamp = stamp;
  b.joint_receipt = receipt;
  ++b.status.joint_states_accepted;
  return InputResult::kAccepted;
}

InputResult BodyRegistry::onJointTrajectory(size_t bi, const trajectory_msgs::JointTrajectory& msg,
                                            const ros::Time& receipt) {
  Body& b = bodies_.at(bi);
  auto drop = [&](const std::string& why) {
    ++b.status.trajectories_dropped;
    rejectInput(b, "joint_trajectory: " + why + " (the previous trajectory is kept)", receipt);
    return InputResult::kInvalid;
  };
  if (!b.kinematics) return drop("the body has no kinematics (see its geometry error)");
  const ros::Time start = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
  if (const std::string why = stampSkewError(start, receipt); !why.empty()) return drop("header." + why);
  if (msg.points.empty()) {
    b.traj_time.clear();
    ++b.status.trajectories_accepted;
    return InputResult::kAccepted;
  }
  const size_t n = msg.joint_names.size();
  std::vector<int> joints;
  if (const std::string why = jointIndices(*b.kinematics, msg.joint_names, "joint_names", joints); !why.empty()) {
    return drop(why);
  }
  bool with_velocities = true;
  for (const auto& p : msg.points) with_velocities = with_velocities && p.velocities.size() == n;
  std::vector<ros::Time> times;
  std::vector<std::vector<double>> qs, qds;
  for (size_t k = 0; k < msg.points.size(); ++k) {
    const auto& p = msg.points[k];
    const std::string field = "points[" + std::to_string(k) + "]";
    if (p.positions.size() != n) {
      return drop(field + ".positions has " + std::to_string(p.positions.size()) + " values for " + std::to_string(n) +
                  " joint_names");
    }
    if (!p.velocities.empty() && p.velocities.size() != n) {
      return drop(field + ".velocities has " + std::to_string(p.velocities.size()) + " values for " +
                  std::to_string(n) + " joint_names (give none or one per joint)");
    }
    std::string why;
    for (size_t i = 0; i < n; ++i) {
      if (!checkValue(p.positions[i], vadop::kMaxCoordinate, "rad or m", field + ".positions[" + std::to_string(i) + "]",
                      why) ||
          (!p.velocities.empty() && !checkValue(p.velocities[i], vadop::kMaxAngularSpeed, "rad/s or m/s",
                                                field + ".velocities[" + std::to_string(i) + "]", why))) {
        return drop(why);
      }
    }
    const double from_start = p.time_from_start.toSec();
    if (!(from_start >= 0.0 && from_start <= kRebaseAfterSeconds)) {
      return drop(field + ".time_from_start = " + number(from_start) + " s is not in [0, " +
                  number(kRebaseAfterSeconds) + "]");
    }
    const ros::Time t = addSeconds(start, from_start);
    if (!times.empty() && !(t > times.back())) {
      return drop(field + ".time_from_start does not increase (" + number(from_start) + " s)");
    }
    times.push_back(t);
    qs.push_back(p.positions);
    if (with_velocities) qds.push_back(p.velocities);
  }
  b.traj_joints = std::move(joints);
  b.traj_time = std::move(times);
  b.traj_q = std::move(qs);
  b.traj_qd = std::move(qds);
  ++b.status.trajectories_accepted;
  return InputResult::kAccepted;
}

void BodyRegistry::updateJointBody(Body& b, const ros::Time& now, double t_now, double t_check_end,
                                   const vadop::Motion& frame, bool stale, const vadop::TimedPath* plan) {
  const JointKinematics& kin = *b.kinematics;
  const size_t nj = kin.joints().size();
  // Joint j at time t (registry seconds): its position carried from its stamp with its velocity
  // (none when the joint states or the body are stale), clamped at its limits.
  const bool joints_stale = !b.has_joints || !receiptFresh(b.joint_receipt, now, stale_timeout_);
  std::vector<double> qt(nj, 0.0), rate(nj, 0.0), since(nj, t_now);
  bool moving = false;
  for (size_t j = 0; j < nj; ++j) {
    if (b.q_time[j].isZero()) continue;  // never reported: at zero
    since[j] = seconds(b.q_time[j]);
    rate[j] = (stale || joints_stale) ? 0.0 : b.qd[j];
    moving = moving || rate[j] != 0.0;
  }
  // A running trajectory (its last point after now) overrides the joints it names.
  const bool on_trajectory = !stale && !b.traj_time.empty() && b.traj_time.back() > now;
  std::vector<double> point_time;
  if (on_trajectory) {
    for (const ros::Time& pt : b.traj_time) point_time.push_back(seconds(pt));
    moving = true;
  }
  // Still joints (none moves, no trajectory): their positions now, clamped at the limits.
  auto jointsNow = [&]() {
    for (size_t j = 0; j < nj; ++j) qt[j] = kin.clamp(j, b.q[j]);
  };
  // Every element's pose relative to the body frame at joint positions qt.
  std::vector<Eigen::Isometry3d> rel(b.elements.size());
  auto relativePoses = [&]() {
    Eigen::Isometry3d ref;
    if (!kin.linkPose(qt, b.reference_link, ref)) ref.setIdentity();
    const Eigen::Isometry3d ref_inv = ref.inverse();
    for (size_t k = 0; k < b.elements.size(); ++k) {
      const Element& e = elements_[b.elements[k]];
      Eigen::Isometry3d link;
      if (!kin.linkPose(qt, e.link, link)) link.setIdentity();
      rel[k] = ref_inv * link * e.offset;
    }
  };
  auto accept = [&](Element& e, const vadop::Motion& m, std::shared_ptr<const vadop::LinkChain> chain) {
    const std::string why = motionRangeError(m, t_now, t_check_end);
    if (!why.empty()) {
      rejectInput(b, "link \"" + e.link + "\": motion out of range: " + why, now, false);
      return;
    }
    e.motion = m;
    e.chain = std::move(chain);
    e.active = true;
  };
  if (!moving && !plan) {
    // Rigid at the current joint positions: the body frame's constant twist, exact.
    jointsNow();
    relativePoses();
    const Eigen::Isometry3d fb = frame.poseAt(frame.t_ref);
    for (size_t k = 0; k < b.elements.size(); ++k) {
      Element& e = elements_[b.elements[k]];
      const Eigen::Isometry3d pe = fb * rel[k];
      accept(e, twistMotion(pe, frame.velocityOfPoint(pe.translation(), frame.t_ref), frame.angular_velocity,
                            frame.t_ref),
             nullptr);
    }
    return;
  }
  // Every joint along a vadop::JointPath: its velocity from its stamp (clamped at its limits),
  // or the running trajectory through its points (the cubic through positions and velocities,
  // straight lines without velocities; positions clamped at the limits).
  std::vector<vadop::JointPath> joint_paths;
  joint_paths.reserve(nj);
  for (size_t j = 0; j < nj; ++j) {
    joint_paths.push_back(vadop::JointPath::constantVelocity(since[j], b.q[j], rate[j], kin.lower(j), kin.upper(j)));
  }
  if (on_trajectory) {
    for (size_t i = 0; i < b.traj_joints.size(); ++i) {
      const size_t j = static_cast<size_t>(b.traj_joints[i]);
      std::vector<double> positions, velocities;
      for (size_t k = 0; k < point_time.size(); ++k) {
        positions.push_back(kin.clamp(j, b.traj_q[k][i]));
        if (!b.traj_qd.empty()) velocities.push_back(b.traj_qd[k][i]);
      }
      joint_paths[j] = vadop::JointPath(point_time, std::move(positions), 0.0, std::move(velocities));
    }
  }
  std::optional<vadop::TimedPath> base_path;  // each link's chain starts from a copy
  for (size_t k = 0; k < b.elements.size(); ++k) {
    Element& e = elements_[b.elements[k]];
    try {
      if (!base_path) plan ? base_path.emplace(*plan) : base_path.emplace(frame);
      std::vector<JointKinematics::Step> steps;
      if (!kin.chain(b.reference_link, e.link, steps)) steps.clear();  // not in the tree: rigid
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
      shape_offset.origin = e.offset;
      joints.push_back(shape_offset);
      auto chain = std::make_shared<const vadop::LinkChain>(*base_path, std::move(joints));
      const vadop::PosedTwist now = chain->stateAt(t_now);
      const vadop::Motion now_motion = twistMotion(now.pose, now.velocity, now.angular_velocity, t_now);
      accept(e, now_motion, std::move(chain));
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, "link \"" + e.link + "\": joint motion out of range: " + ex.what(), now, false);
    }
  }
  b.status.joints_moving = moving;
  b.status.on_trajectory = on_trajectory;
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

std::optional<vadop::TimedPath> BodyRegistry::planPath(Body& b, const ros::Time& now, double t_now,
                                                        double t_check_end, const Eigen::Isometry3d& frame_now) {
  if (b.plan.empty() || !(b.plan.back().first > now)) return std::nullopt;
  // The body frame from its pose now through the poses stamped after now. A pose within 1 ms
  // after now is left out: the current pose stands for it (a piece that short would turn a
  // centimetre of odometry error into metres per second).
  constexpr double kMinPiece = 1e-3;
  std::vector<vadop::Keyframe> frames;
  frames.reserve(b.plan.size() + 1);
  frames.push_back({t_now, frame_now.translation(), Eigen::Quaternion<double>(frame_now.linear())});
  for (const auto& [stamp, pose] : b.plan) {
    const double t = seconds(stamp);
    if (t < t_now + kMinPiece) continue;
    frames.push_back({t, pose.translation(), Eigen::Quaterniond(pose.linear())});
  }
  if (frames.size() < 2) return std::nullopt;
  const vadop::AfterPath after = b.params.path_continue ? vadop::AfterPath::kContinue : vadop::AfterPath::kHold;
  try {
    vadop::TimedPath path(std::move(frames), after);
    checkPathRange(path, t_now, t_check_end);
    return path;
  } catch (const vadop::InvalidArgument& ex) {
    warnPlanNotFollowed(b, now, ex.what());
    return std::nullopt;
  }
}

void BodyRegistry::followPlan(Body& b, const ros::Time& now, const vadop::TimedPath& plan, double t_now,
                              double t_check_end, const Eigen::Isometry3d& frame_now) {
  const vadop::AfterPath after = b.params.path_continue ? vadop::AfterPath::kContinue : vadop::AfterPath::kHold;
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

bool BodyRegistry::bodyMotion(Body& b, const ros::Time& now, TransformSource& tf, Eigen::Isometry3d& pose,
                              Eigen::Vector3d& v, Eigen::Vector3d& w, ros::Time& t_ref, const std::string*& frame) {
  std::string error;
  ros::Time stamp;
  if (b.params.source == VelocitySource::kOdometry) {
    Eigen::Isometry3d fixed_src = Eigen::Isometry3d::Identity();
    if (b.source_frame != fixed_frame_) {
      if (!lookup(tf, fixed_frame_, b.source_frame, b.stamp, fixed_src, stamp, error) &&
          !lookup(tf, fixed_frame_, b.source_frame, ros::Time(0), fixed_src, stamp, error)) {
        warnTf(b, error, now);
        return false;
      }
    }
    // Most odometry is in the fixed frame already: no product with the identity (a cycle computes
    // this for every body).
    const Eigen::Isometry3d fixed_child = b.source_frame == fixed_frame_ ? b.pose : fixed_src * b.pose;
    const Eigen::Matrix3d& r = fixed_child.linear();
    v = r * b.v;
    w = r * b.w;
    pose = fixed_child;
    frame = &b.child_frame;
    if (!b.params.frame.empty() && b.params.frame != b.child_frame && !b.child_frame.empty()) {
      // The body frame is another frame rigid with the child frame.
      Eigen::Isometry3d child_body;
      if (!lookup(tf, b.child_frame, b.params.frame, ros::Time(0), child_body, stamp, error)) {
        warnTf(b, error, now);
        return false;
      }
      pose = fixed_child * child_body;
      v += w.cross(pose.translation() - fixed_child.translation());
      frame = &b.params.frame;
    } else if (!b.params.frame.empty()) {
      frame = &b.params.frame;
    }
    t_ref = b.stamp;
  } else {
    frame = &b.params.frame;
    if (!lookup(tf, fixed_frame_, *frame, ros::Time(0), pose, stamp, error)) {
      warnTf(b, error, now);
      return false;
    }
    Eigen::Matrix3d r = pose.linear();
    if (!b.twist_frame.empty() && b.twist_frame != *frame) {
      Eigen::Isometry3d fixed_twist;
      ros::Time s2;
      if (!lookup(tf, fixed_frame_, b.twist_frame, ros::Time(0), fixed_twist, s2, error)) {
        warnTf(b, error, now);
        return false;
      }
      r = fixed_twist.linear();
    }
    v = r * b.v;
    w = r * b.w;
    t_ref = stamp.isZero() ? now : stamp;
  }
  return true;
}

void BodyRegistry::update(const ros::Time& now, TransformSource& tf) {
  // Seconds since the base stay within kRebaseAfterSeconds of zero: far inside vadop::kMaxTime
  // whatever the clock (epoch seconds, a /clock jump to 4e9 s, a jump back).
  if (!has_base_ || !(std::fabs(seconds(now)) <= kRebaseAfterSeconds)) {
    base_ = now;
    has_base_ = true;
    ++rebases_;
  }
  const double t_now = seconds(now);
  const double t_check_end = t_now + kMotionCheckWindow;
  // A body writes only itself and its elements (its warnings too); the kinematics it may share
  // with others is read only (KDL's recursive solver keeps no state).
  auto updateOne = [&](size_t i) {
    Body& b = bodies_[i];
    if (b.is_static) {
      // Fixed motions (zero velocity, set at start-up): checked like the others, so that one
      // obstacle out of range is left out instead of failing every prediction.
      for (const size_t ei : b.elements) {
        Element& e = elements_[ei];
        const std::string why = motionRangeError(e.motion, t_now, t_check_end);
        e.active = why.empty();
        if (!e.active) rejectInput(b, "element \"" + e.id + "\": " + why, now, false);
      }
      return;
    }
    updateMoving(b, now, t_now, t_check_end, tf);
  };
  // Below a few hundred bodies a thread costs more than it saves.
  constexpr size_t kBodiesPerThread = 256;
  constexpr size_t kChunk = 32;
  vadop::detail::parallelFor(tf.concurrent() ? threads_ : 1, bodies_.size(), kBodiesPerThread, kChunk, updateOne);
}

void BodyRegistry::setThreads(int threads) { threads_ = vadop::detail::threadCount(threads); }

bool BodyRegistry::updateBody(size_t body, const ros::Time& now, TransformSource& tf) {
  if (!has_base_ || body >= bodies_.size() || bodies_[body].is_static) return false;
  const double t_now = seconds(now);
  Body& b = bodies_[body];
  updateMoving(b, now, t_now, t_now + kMotionCheckWindow, tf);
  return b.frame_motion.valid;
}

void BodyRegistry::updateMoving(Body& b, const ros::Time& now, double t_now, double t_check_end, TransformSource& tf) {
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
    return;
  }
  if (!b.has_state) {
    b.status.state = BodyState::kWaiting;
    return;
  }
  Eigen::Isometry3d fb;
  Eigen::Vector3d v, w;
  ros::Time t_ref;
  const std::string* body_frame_name = nullptr;
  if (!bodyMotion(b, now, tf, fb, v, w, t_ref, body_frame_name)) {
    b.status.state = BodyState::kTfMissing;
    return;
  }
  const bool stale = !receiptFresh(b.status.last_receipt, now, stale_timeout_);
  if (stale) {
    v.setZero();
    w.setZero();
  }
  const std::string& body_frame = *body_frame_name;
  resolveReference(b, body_frame);
  // A stale body stands still: its pose holds at any time, so its motion is referred to
  // `now` (its stamp may be hours old, beyond the library's time range).
  const ros::Time motion_ref = stale ? now : t_ref;
  const double tr = seconds(motion_ref);
  // The body frame's own motion, which its elements, its plan and the velocity gate all carry:
  // out of the library's range over the window (a pose from tf stamped far from the clock), the
  // body is left out as a whole, as when its transform is missing.
  vadop::Motion frame;
  std::string frame_error;
  try {
    frame = twistMotion(fb, v, w, tr);
    frame_error = motionRangeError(frame, t_now, t_check_end);
  } catch (const vadop::InvalidArgument& ex) {
    frame_error = ex.what();
  }
  if (!frame_error.empty()) {
    b.status.tf_error = "the body frame's motion is out of range: " + frame_error;
    rejectInput(b, b.status.tf_error, now, false);
    b.status.state = BodyState::kTfMissing;
    return;
  }
  if (b.kinematics) {
    // A mobile manipulator on its plan: its links' chains start from the body frame along it.
    const std::optional<vadop::TimedPath> plan =
        stale || b.plan.empty() ? std::nullopt : planPath(b, now, t_now, t_check_end, frame.poseAt(t_now));
    try {
      updateJointBody(b, now, t_now, t_check_end, frame, stale, plan ? &*plan : nullptr);
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, std::string("invalid motion: ") + ex.what(), now, false);
    }
    b.tf_missing_since = ros::Time();
    b.status.state = stale ? BodyState::kStale : BodyState::kOk;
    b.frame_motion = FrameMotion{true, stale, fb, v, w, tr, frame};
    return;
  }
  const Eigen::Matrix3d& rb = fb.linear();
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
      pe = fb * e.offset;
      ve = v + w.cross(pe.translation() - fb.translation());
      we = w;
    } else {
      Eigen::Isometry3d body_link;
      ros::Time ls;
      std::string error;
      if (body_frame.empty()) {
        error = "the odometry has no child_frame_id and the body no frame parameter: link poses cannot be "
                "looked up";
        warnTf(b, error, now);
        ++b.status.links_skipped;
        continue;
      }
      if (!lookup(tf, body_frame, e.tf_frame, ros::Time(0), body_link, ls, error)) {
        warnTf(b, "link \"" + e.link + "\": " + error, now);
        ++b.status.links_skipped;
        continue;
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
      const Eigen::Isometry3d le = body_link * e.offset;  // element in the body frame
      pe = fb * le;
      const Eigen::Vector3d r_world = rb * le.translation();
      Eigen::Vector3d own_v = Eigen::Vector3d::Zero(), own_w = Eigen::Vector3d::Zero();
      if (!stale) {
        own_v = rb * (e.rel_v + e.rel_w.cross(le.translation() - body_link.translation()));
        own_w = rb * e.rel_w;
      }
      ve = v + w.cross(r_world) + own_v;
      we = w + own_w;
    }
    try {
      const vadop::Motion m = twistMotion(pe, ve, we, tr);
      // The library's range over [now, now + the largest horizon]: one element out of it is
      // left out (and its body marked), never the whole prediction.
      const std::string why = motionRangeError(m, t_now, t_check_end);
      if (!why.empty()) {
        rejectInput(b, (e.link.empty() ? std::string("motion") : "link \"" + e.link + "\": motion") +
                           " out of range after transformation: " + why,
                    now, false);
        continue;
      }
      e.motion = m;
      e.active = true;
    } catch (const vadop::InvalidArgument& ex) {
      rejectInput(b, std::string("invalid motion: ") + ex.what(), now, false);
    }
  }
  if (b.status.links_skipped > 0) {
    b.status.state = BodyState::kTfMissing;
  } else {
    b.tf_missing_since = ros::Time();
    b.status.state = stale ? BodyState::kStale : BodyState::kOk;
    b.frame_motion = FrameMotion{true, stale, fb, v, w, tr, frame};
    if (!stale && !b.plan.empty()) {
      const Eigen::Isometry3d frame_now = frame.poseAt(t_now);
      if (const auto plan = planPath(b, now, t_now, t_check_end, frame_now)) {
        followPlan(b, now, *plan, t_now, t_check_end, frame_now);
      }
    }
  }
}

const char* motionSource(const Body& b) {
  if (b.is_static) return "static";
  if (!b.frame_motion.valid) return "none";
  if (b.frame_motion.stale) return "stale";
  if (b.status.on_path) {
    return b.status.on_trajectory ? "path + joint trajectory" : b.status.joints_moving ? "path + joint states" : "path";
  }
  if (b.status.on_trajectory) return "joint trajectory";
  if (b.status.joints_moving) return b.params.source == VelocitySource::kOdometry ? "odometry + joint states" : "twist + joint states";
  return b.params.source == VelocitySource::kOdometry ? "odometry" : "twist";
}

void BodyRegistry::reset() {
  has_base_ = false;
  for (Body& b : bodies_) {
    if (b.is_static) continue;
    b.has_state = false;
    b.stamp = ros::Time();
    b.plan.clear();
    b.plan_stamp = ros::Time();
    b.status.on_path = false;
    b.has_joints = false;
    b.joint_stamp = ros::Time();
    std::fill(b.q.begin(), b.q.end(), 0.0);
    std::fill(b.qd.begin(), b.qd.end(), 0.0);
    std::fill(b.q_time.begin(), b.q_time.end(), ros::Time());
    b.traj_time.clear();
    b.status.state = b.elements.empty() ? BodyState::kNoGeometry : BodyState::kWaiting;
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
