#include "vadop_ros/tracks.h"

#include "../message_checks.h"
#include "../param_reading.h"
#include "source_problem.h"

#include <vadop/error.h>

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/console.h>
#include <ros/node_handle.h>

#include <shape_msgs/SolidPrimitive.h>

#include <cmath>
#include <set>
#include <cstdio>
#include <memory>
#include <unordered_set>
#include <utility>

namespace vadop_ros {
namespace {

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) { return {v.x, v.y, v.z}; }

}  // namespace

Tracks::Tracks(std::vector<TrackParams> params, std::string fixed_frame, double max_stamp_skew)
    : params_(std::move(params)),
      fixed_frame_(std::move(fixed_frame)),
      max_stamp_skew_(max_stamp_skew),
      status_(params_.size()),
      last_stamp_(params_.size()) {}

void Tracks::problem(size_t source, const std::string& why, const ros::Time& receipt) {
  const TrackParams& p = params_[source];
  noteSourceProblem(status_[source], "tracks " + p.topic + " (prefix \"" + p.prefix + "\")", "source", why, receipt);
}

bool Tracks::shapeOf(size_t source, const shape_msgs::SolidPrimitive& p, size_t index, vadop::Shape& out,
                     std::string& why) const {
  using shape_msgs::SolidPrimitive;
  const auto& d = p.dimensions;
  // Named only when something is wrong: the common case builds no string.
  const auto fieldName = [index] { return "objects[" + std::to_string(index) + "].shape"; };
  // The dimensions a primitive needs (SolidPrimitive's index constants), each finite, > 0, in range.
  auto dims = [&](size_t n, const char* names) {
    if (d.size() != n) {
      why = fieldName() + ".dimensions has " + std::to_string(d.size()) + " values, a " + names;
      return false;
    }
    for (size_t i = 0; i < n; ++i) {
      if (d[i] > 0.0 && d[i] <= vadop::kMaxSize) continue;  // false for NaN
      const std::string f = fieldName() + ".dimensions[" + std::to_string(i) + "]";
      if (checkValue(d[i], vadop::kMaxSize, "m", f, why)) why = f + " = " + std::to_string(d[i]) + " is not > 0";
      return false;
    }
    return true;
  };
  try {
    switch (p.type) {
      case 0:
        if (!params_[source].has_default_shape) {
          why = fieldName() + ".type is 0 (the source's default) and the source has no default_shape";
          return false;
        }
        out = params_[source].default_shape;
        return true;
      case SolidPrimitive::BOX:
        if (!dims(3, "BOX needs 3 (x, y, z)")) return false;
        out = vadop::makeBox(Eigen::Vector3d(d[SolidPrimitive::BOX_X], d[SolidPrimitive::BOX_Y], d[SolidPrimitive::BOX_Z]));
        return true;
      case SolidPrimitive::SPHERE:
        if (!dims(1, "SPHERE needs 1 (radius)")) return false;
        out = vadop::makeSphere(d[SolidPrimitive::SPHERE_RADIUS]);
        return true;
      case SolidPrimitive::CYLINDER:
        if (!dims(2, "CYLINDER needs 2 (height, radius)")) return false;
        out = vadop::makeCylinder(d[SolidPrimitive::CYLINDER_RADIUS], d[SolidPrimitive::CYLINDER_HEIGHT]);
        return true;
      default:
        why = fieldName() + ".type = " + std::to_string(p.type) + " is not supported (BOX, SPHERE, CYLINDER, or 0)";
        return false;
    }
  } catch (const vadop::InvalidArgument& e) {
    why = fieldName() + ": " + e.what();
    return false;
  }
}

InputResult Tracks::checkArray(size_t source, const vadop::TrackedObjectArray& msg, const ros::Time& receipt,
                               TransformSource& tf, ros::Time& stamp, Eigen::Isometry3d& to_fixed) {
  TrackSourceStatus& st = status_.at(source);
  auto dropArray = [&](const std::string& why) {
    ++st.arrays_dropped;
    problem(source, "array dropped: " + why, receipt);
    return InputResult::kInvalid;
  };
  stamp = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
  if (const std::string why = stampSkewError(stamp, receipt, max_stamp_skew_); !why.empty()) return dropArray(why);
  // Older than the last accepted one (while that one is not ahead of the clock): out of order.
  if (!last_stamp_[source].isZero() && stamp < last_stamp_[source] && last_stamp_[source] <= receipt) {
    ++st.arrays_out_of_order;
    return InputResult::kOutOfOrder;
  }
  std::string frame = msg.header.frame_id;
  while (!frame.empty() && frame.front() == '/') frame.erase(0, 1);
  if (frame.empty()) return dropArray("header.frame_id is empty");
  to_fixed = Eigen::Isometry3d::Identity();
  if (frame != fixed_frame_) {
    ros::Time tf_stamp;
    std::string error;
    bool found = false;
    try {
      found = tf.lookup(fixed_frame_, frame, stamp, to_fixed, tf_stamp, error);
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (!found) return dropArray("header.frame_id \"" + frame + "\": no transform to \"" + fixed_frame_ + "\" at its stamp: " + error);
  }
  last_stamp_[source] = stamp;
  ++st.arrays_accepted;
  return InputResult::kAccepted;
}

bool Tracks::objectPose(const vadop::TrackedObject& o, size_t index, const Eigen::Isometry3d& to_fixed,
                        Eigen::Isometry3d& pose, std::string& why) const {
  const auto field = [index] { return "objects[" + std::to_string(index) + "]"; };
  // Every value finite and in range, the quaternion not degenerate: the common case, checked
  // without building field names; otherwise the checks that name the field.
  const geometry_msgs::Point& pp = o.pose.position;
  const geometry_msgs::Quaternion& pq = o.pose.orientation;
  const geometry_msgs::Vector3 &tl = o.twist.linear, &ta = o.twist.angular;
  const auto within = [](double v, double limit) { return std::fabs(v) <= limit; };  // false for NaN
  const bool plausible =
      within(pp.x, vadop::kMaxCoordinate) && within(pp.y, vadop::kMaxCoordinate) &&
      within(pp.z, vadop::kMaxCoordinate) && within(tl.x, vadop::kMaxLinearSpeed) &&
      within(tl.y, vadop::kMaxLinearSpeed) && within(tl.z, vadop::kMaxLinearSpeed) &&
      within(ta.x, vadop::kMaxAngularSpeed) && within(ta.y, vadop::kMaxAngularSpeed) &&
      within(ta.z, vadop::kMaxAngularSpeed) && within(pq.x, 1e150) && within(pq.y, 1e150) &&
      within(pq.z, 1e150) && within(pq.w, 1e150) && pq.x * pq.x + pq.y * pq.y + pq.z * pq.z + pq.w * pq.w > 1e-18;
  if (!plausible && (!checkPoint(pp, field() + ".pose.position", why) ||
                     !checkQuaternion(pq, field() + ".pose.orientation", why) ||
                     !checkVector(tl, vadop::kMaxLinearSpeed, "m/s", field() + ".twist.linear", why) ||
                     !checkVector(ta, vadop::kMaxAngularSpeed, "rad/s", field() + ".twist.angular", why))) {
    return false;
  }
  Eigen::Quaterniond quat(pq.w, pq.x, pq.y, pq.z);
  const double scale = std::max({std::fabs(pq.x), std::fabs(pq.y), std::fabs(pq.z), std::fabs(pq.w)});
  quat.coeffs() /= scale;  // finite and non-zero (checked): normalising cannot overflow
  pose = Eigen::Isometry3d::Identity();
  pose.linear() = quat.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(pp.x, pp.y, pp.z);
  pose = to_fixed * pose;
  if (!(pose.translation().cwiseAbs().maxCoeff() <= vadop::kMaxCoordinate)) {
    why = field() + ".pose.position is out of range in \"" + fixed_frame_ + "\"";
    return false;
  }
  return true;
}

size_t Tracks::slotFor(size_t source, const std::string& name) {
  const auto it = by_name_.find(name);
  if (it != by_name_.end()) return it->second;
  size_t slot;
  if (!free_.empty()) {
    slot = free_.back();
    free_.pop_back();
  } else {
    slot = bodies_.size();
    bodies_.emplace_back();
    slot_source_.push_back(0);
    last_seen_.emplace_back();
  }
  by_name_.emplace(name, slot);
  ++status_[source].objects;
  return slot;
}

InputResult Tracks::onArray(size_t source, const vadop::TrackedObjectArray& msg, const ros::Time& receipt,
                            TransformSource& tf) {
  ros::Time stamp;
  Eigen::Isometry3d to_fixed;
  if (const InputResult r = checkArray(source, msg, receipt, tf, stamp, to_fixed); r != InputResult::kAccepted) {
    return r;
  }
  TrackSourceStatus& st = status_[source];
  // The last occurrence of each id is the one kept.
  std::unordered_map<std::string, size_t> last_of;
  for (size_t i = 0; i < msg.objects.size(); ++i) last_of[msg.objects[i].id] = i;
  for (size_t i = 0; i < msg.objects.size(); ++i) {
    const vadop::TrackedObject& o = msg.objects[i];
    auto dropObject = [&](const std::string& why) {
      ++st.objects_dropped;
      problem(source, "object objects[" + std::to_string(i) + "] (id \"" + o.id + "\") dropped: " + why, receipt);
    };
    if (o.id.empty()) {
      dropObject("empty id");
      continue;
    }
    if (last_of[o.id] != i) {
      dropObject("id repeated later in the array (objects[" + std::to_string(last_of[o.id]) + "] is kept)");
      continue;
    }
    std::string why;
    vadop::Shape shape;
    Eigen::Isometry3d pose;
    if (!shapeOf(source, o.shape, i, shape, why) || !objectPose(o, i, to_fixed, pose, why)) {
      dropObject(why);
      continue;
    }
    const std::string name = params_[source].prefix + "/" + o.id;
    const size_t slot = slotFor(source, name);
    TrackedObject& t = bodies_[slot];
    t.alive = true;
    t.name = name;
    slot_source_[slot] = source;
    t.shape = std::move(shape);
    t.pose = pose;
    t.v = to_fixed.linear() * toEigen(o.twist.linear);
    t.w = to_fixed.linear() * toEigen(o.twist.angular);
    t.stamp = stamp;
    last_seen_[slot] = receipt;
  }
  return InputResult::kAccepted;
}

void Tracks::release(size_t slot) {
  TrackedObject& t = bodies_[slot];
  by_name_.erase(t.name);
  --status_[slot_source_[slot]].objects;
  t = TrackedObject();
  slot_source_[slot] = 0;
  last_seen_[slot] = ros::Time();
  free_.push_back(slot);
}

void Tracks::expire(const ros::Time& now, std::vector<size_t>& left) {
  for (size_t s = 0; s < bodies_.size(); ++s) {
    if (!bodies_[s].alive || !(secondsBetween(now, last_seen_[s]) > params_[slot_source_[s]].timeout)) continue;
    ++status_[slot_source_[s]].objects_expired;
    release(s);
    left.push_back(s);
  }
}

void Tracks::drop(size_t slot, const std::string& why, const ros::Time& now) {
  if (slot >= bodies_.size() || !bodies_[slot].alive) return;
  const size_t source = slot_source_[slot];
  ++status_[source].objects_dropped;
  problem(source, "\"" + bodies_[slot].name + "\" left out: " + why, now);
  release(slot);
}

void Tracks::clear(std::vector<size_t>& left) {
  for (size_t s = 0; s < bodies_.size(); ++s) {
    if (!bodies_[s].alive) continue;
    release(s);
    left.push_back(s);
  }
  for (ros::Time& t : last_stamp_) t = ros::Time();
}

std::vector<ros::Subscriber> Tracks::subscribe(const Wiring& w) {
  std::vector<ros::Subscriber> subs;
  for (size_t s = 0; s < params_.size(); ++s) {
    std::mutex* lock = &w.lock;
    TransformSource* tf = &w.tf;
    subs.push_back(w.nh.subscribe<vadop::TrackedObjectArray>(
        params_[s].topic, 5,
        [this, s, lock, tf](const vadop::TrackedObjectArrayConstPtr& msg) {
          std::lock_guard<std::mutex> guard(*lock);
          onArray(s, *msg, ros::Time::now(), *tf);
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
  }
  return subs;
}

void Tracks::report(diagnostic_updater::DiagnosticStatusWrapper& stat, const ros::Time& now) const {
  using diagnostic_msgs::DiagnosticStatus;
  unsigned char level = DiagnosticStatus::OK;
  for (size_t i = 0; i < sources(); ++i) {
    const TrackParams& p = params_[i];
    const TrackSourceStatus& st = status_[i];
    const std::string k = p.prefix + ": ";
    stat.add(k + "topic", p.topic);
    stat.add(k + "objects", st.objects);
    stat.add(k + "arrays accepted", st.arrays_accepted);
    stat.add(k + "arrays dropped", st.arrays_dropped);
    stat.add(k + "arrays out of order", st.arrays_out_of_order);
    stat.add(k + "objects dropped", st.objects_dropped);
    stat.add(k + "objects expired", st.objects_expired);
    stat.add(k + "last problem", st.last_problem.empty() ? std::string("none") : st.last_problem);
    if (!st.last_problem_receipt.isZero() &&
        secondsBetween(now, st.last_problem_receipt) < BodyRegistry::kInvalidMarkSeconds) {
      level = DiagnosticStatus::WARN;
    }
  }
  char buf[128];
  std::snprintf(buf, sizeof buf, "%zu tracked objects from %zu source(s)", alive(), sources());
  stat.summary(level, std::string(buf) + (level == DiagnosticStatus::OK ? "" : "; bad input recently (see last problem)"));
}

namespace {

// The prefix a source's objects are named with: ~tracks[i].prefix, else the topic's last name.
std::string parsePrefix(const XmlRpc::XmlRpcValue& e, const std::string& path, const std::string& topic,
                        std::set<std::string>& prefixes) {
  using namespace param_reading;
  std::string prefix;
  if (const XmlRpcValue* p = member(e, "prefix")) {
    prefix = toString(*p, path + ".prefix");
  } else {
    std::string name = topic;
    while (!name.empty() && name.back() == '/') name.pop_back();
    prefix = name.substr(name.find_last_of('/') + 1);
  }
  if (prefix.empty()) fail(path + ".prefix", "must not be empty");
  if (prefix.find_first_of(" \t\n") != std::string::npos) {
    fail(path + ".prefix", "must not contain spaces, got \"" + prefix + "\"");
  }
  if (!prefixes.insert(prefix).second) {
    fail(path + ".prefix", "\"" + prefix + "\" is the prefix of another source (objects would share names)");
  }
  return prefix;
}

// ~tracks: a list of sources {topic, prefix, default_shape, timeout}.
void parseTracks(const XmlRpc::XmlRpcValue& list, MonitorParams& out) {
  using namespace param_reading;
  requireArray(list, "~tracks");
  std::set<std::string> prefixes;
  for (int i = 0; i < list.size(); ++i) {
    const XmlRpcValue& e = list[i];
    const std::string path = "~tracks[" + std::to_string(i) + "]";
    requireStruct(e, path);
    rejectUnknown(e, {"topic", "prefix", "default_shape", "timeout"}, path);
    TrackParams t;
    const XmlRpcValue* topic = member(e, "topic");
    if (!topic) fail(path + ".topic", "is required (a vadop/TrackedObjectArray topic)");
    t.topic = toString(*topic, path + ".topic");
    checkRosName(t.topic, path + ".topic", "topic");
    t.prefix = parsePrefix(e, path, t.topic, prefixes);
    if (const XmlRpcValue* d = member(e, "default_shape")) {
      t.has_default_shape = true;
      t.default_shape = parseShape(*d, path + ".default_shape");
    }
    t.timeout = ranged(member(e, "timeout"), t.timeout, 0.0, 3600.0, true, path + ".timeout");
    out.tracks.push_back(std::move(t));
  }
}

}  // namespace

BodiesSourceKind trackedObjectsSourceKind() {
  return {"tracks", parseTracks, [](const MonitorParams& p) -> std::unique_ptr<BodiesSource> {
            return std::make_unique<Tracks>(p.tracks, p.fixed_frame, p.max_stamp_skew);
          }};
}

}  // namespace vadop_ros
