// The path source (path_topic): nav_msgs/Path, the body frame's planned poses with the time it
// is at each. It keeps the last accepted plan in the fixed frame; at a cycle the body follows
// it while it reaches beyond `now` (BodyRegistry::update), then holds or goes on (after_path).
#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <nav_msgs/Path.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace vadop_ros {
namespace {

class PathSource : public Source {
 public:
  explicit PathSource(const BodyParams& p) : topic_(p.path_topic), plan_continue_(p.path_continue) {}
  const char* kind() const override { return "path"; }
  const std::string& topic() const override { return topic_; }

  ros::Subscriber subscribe(const Wiring& w) override {
    return w.nh.subscribe<nav_msgs::Path>(
        topic_, 2,
        [this, &lock = w.lock, &registry = w.registry, body = w.body, &tf = w.tf](const nav_msgs::PathConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          onMessage(registry, registry.body(body), *msg, ros::Time::now(), tf);
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  InputResult onMessage(BodyRegistry& registry, Body& b, const nav_msgs::Path& msg, const ros::Time& receipt,
                        TransformSource& tf) {
    const ros::Time header_stamp = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
    std::string why = registry.stampSkewError(header_stamp, receipt);
    if (!why.empty()) return drop(registry, b, "header." + why, receipt);
    if (header_stamp < plan_stamp_ && plan_stamp_ <= receipt) {
      ++b.status.dropped_out_of_order;
      return InputResult::kOutOfOrder;
    }
    Plan plan;
    if (!msg.poses.empty()) {
      const std::string frame = stripSlash(msg.header.frame_id);
      if (frame.empty()) return drop(registry, b, "header.frame_id is empty (the frame of the poses)", receipt);
      why = readPoses(msg, frame, receipt, plan);
      if (why.empty()) why = toFixedFrame(registry, frame, header_stamp, tf, plan);
      if (!why.empty()) return drop(registry, b, why, receipt);
    }
    plan_ = std::move(plan);  // an empty path clears the plan
    plan_stamp_ = header_stamp;
    ++counts_.accepted;
    return InputResult::kAccepted;
  }

  bool contribute(Body&, BodyRegistry&, const ros::Time&, TransformSource&, BodyInputs& in) override {
    if (!plan_.empty()) {
      in.plan = &plan_;
      in.plan_continue = plan_continue_;
    }
    return true;
  }

  void reset() override {
    plan_.clear();
    plan_stamp_ = ros::Time();
  }

  std::string describe(const Body& b, const ros::Time& now) const override {
    std::string text = std::to_string(counts_.accepted) + " path(s) accepted, " + std::to_string(counts_.dropped) +
                       " dropped";
    if (b.status.on_path && !plan_.empty()) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.2f", secondsBetween(plan_.back().first, now));
      text += std::string(", plan ends in ") + buf + " s";
    }
    return text;
  }

 private:
  InputResult drop(BodyRegistry& registry, Body& b, const std::string& why, const ros::Time& receipt) {
    ++counts_.dropped;
    registry.dropMessage(b, "path: " + why + " (the previous plan is kept)", receipt);
    return InputResult::kInvalid;
  }

  // The poses of `msg` in its frame `frame`, checked; "" or why not.
  static std::string readPoses(const nav_msgs::Path& msg, const std::string& frame, const ros::Time& receipt,
                               Plan& plan) {
    plan.reserve(msg.poses.size());
    for (size_t i = 0; i < msg.poses.size(); ++i) {
      const geometry_msgs::PoseStamped& ps = msg.poses[i];
      const std::string field = "poses[" + std::to_string(i) + "]";
      const std::string pose_frame = stripSlash(ps.header.frame_id);
      if (!pose_frame.empty() && pose_frame != frame) {
        return field + ".header.frame_id \"" + pose_frame + "\" differs from header.frame_id \"" + frame + "\"";
      }
      std::string why;
      if (!checkPoint(ps.pose.position, field + ".pose.position", why) ||
          !checkQuaternion(ps.pose.orientation, field + ".pose.orientation", why)) {
        return why;
      }
      if (ps.header.stamp.isZero()) {
        return field + ".header.stamp is zero (a timed path needs the time the body is at each pose)";
      }
      if (!(std::fabs(secondsBetween(ps.header.stamp, receipt)) <= BodyRegistry::kRebaseAfterSeconds)) {
        return field + ".header.stamp " + stampText(ps.header.stamp) + " is more than " +
               numberText(BodyRegistry::kRebaseAfterSeconds) + " s from the node's clock";
      }
      if (!plan.empty() && !(ps.header.stamp > plan.back().first)) {
        return field + ".header.stamp " + stampText(ps.header.stamp) + " is not after poses[" +
               std::to_string(i - 1) + "]'s " + stampText(plan.back().first);
      }
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      const auto& q = ps.pose.orientation;
      pose.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
      pose.translation() = Eigen::Vector3d(ps.pose.position.x, ps.pose.position.y, ps.pose.position.z);
      plan.emplace_back(ps.header.stamp, pose);
    }
    return "";
  }

  // The plan moved from `frame` into the fixed frame (tf at the header stamp, else the latest
  // transform); "" or why not.
  static std::string toFixedFrame(BodyRegistry& registry, const std::string& frame, const ros::Time& header_stamp,
                                  TransformSource& tf, Plan& plan) {
    const std::string& fixed = registry.fixedFrame();
    if (frame == fixed) return "";
    Eigen::Isometry3d fixed_path;
    ros::Time stamp;
    std::string error;
    if (!BodyRegistry::lookup(tf, fixed, frame, header_stamp, fixed_path, stamp, error) &&
        !BodyRegistry::lookup(tf, fixed, frame, ros::Time(0), fixed_path, stamp, error)) {
      return "header.frame_id \"" + frame + "\": " + error;
    }
    for (auto& [t, pose] : plan) {
      pose = fixed_path * pose;
      if (!(pose.translation().cwiseAbs().maxCoeff() <= vadop::kMaxCoordinate)) {
        return "a pose is out of range in the fixed frame (|position| > " + numberText(vadop::kMaxCoordinate) + " m)";
      }
    }
    return "";
  }

  std::string topic_;
  bool plan_continue_;
  Plan plan_;
  ros::Time plan_stamp_;  // header stamp of the plan (its receipt time when zero)
};

void parsePath(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  using namespace param_reading;
  if (const XmlRpcValue* p = member(e, "path_topic")) {
    b.path_topic = toString(*p, path + ".path_topic");
    if (b.path_topic.empty()) fail(path + ".path_topic", "must not be empty (a nav_msgs/Path topic)");
    if (b.path_topic == b.topic) fail(path + ".path_topic", "must differ from the body's velocity topic");
  }
  if (const XmlRpcValue* a = member(e, "after_path")) {
    const std::string mode = toString(*a, path + ".after_path");
    if (mode != "hold" && mode != "continue") {
      fail(path + ".after_path", "must be \"hold\" or \"continue\", got \"" + mode + "\"");
    }
    if (b.path_topic.empty()) fail(path + ".after_path", "applies only with path_topic");
    b.path_continue = mode == "continue";
  }
}

}  // namespace

SourceKind pathSourceKind() {
  return {"path", {"path_topic", "after_path"}, &BodyParams::path_topic, parsePath,
          [](const BodyParams& p) { return !p.path_topic.empty(); },
          [](const BodyParams& p, const Body&) -> std::unique_ptr<Source> { return std::make_unique<PathSource>(p); },
          false};
}

InputResult BodyRegistry::onPath(size_t bi, const nav_msgs::Path& msg, const ros::Time& receipt, TransformSource& tf) {
  return sourceOf<PathSource>(bi, "path_topic").onMessage(*this, bodies_[bi], msg, receipt, tf);
}

}  // namespace vadop_ros
