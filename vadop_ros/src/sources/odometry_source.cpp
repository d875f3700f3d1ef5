// The odometry source (odom_topic): nav_msgs/Odometry, the body's pose in header.frame_id and
// its twist in child_frame_id (REP 105). Its velocity state is the body frame's motion: the
// pose transformed into the fixed frame (tf at the message stamp, else the latest transform),
// the twist rotated with it; a `frame` other than child_frame_id is a frame rigid with it.
#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <nav_msgs/Odometry.h>

#include <stdexcept>

namespace vadop_ros {
namespace {

class OdometrySource : public Source {
 public:
  explicit OdometrySource(const BodyParams& p) : topic_(p.topic) {}
  const char* kind() const override { return "odometry"; }
  const std::string& topic() const override { return topic_; }
  const VelocityState* velocityState() const override { return &state_; }

  ros::Subscriber subscribe(const Wiring& w) override {
    return w.nh.subscribe<nav_msgs::Odometry>(
        topic_, 20,
        [this, &lock = w.lock, &registry = w.registry, body = w.body](const nav_msgs::OdometryConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          onMessage(registry, registry.body(body), *msg, ros::Time::now());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  InputResult onMessage(BodyRegistry& registry, Body& b, const nav_msgs::Odometry& msg, const ros::Time& receipt) {
    std::string why;
    const auto& p = msg.pose.pose;
    const auto& t = msg.twist.twist;
    if (!checkPoint(p.position, "pose.pose.position", why) ||
        !checkQuaternion(p.orientation, "pose.pose.orientation", why) ||
        !checkVector(t.linear, vadop::kMaxLinearSpeed, "m/s", "twist.twist.linear", why) ||
        !checkVector(t.angular, vadop::kMaxAngularSpeed, "rad/s", "twist.twist.angular", why)) {
      registry.dropMessage(b, why, receipt);
      ++counts_.dropped;
      return InputResult::kInvalid;
    }
    const InputResult stamp_result = registry.acceptStamp(b, msg.header.stamp, receipt, state_.stamp);
    if (stamp_result != InputResult::kAccepted) {
      counts_.dropped += stamp_result == InputResult::kInvalid ? 1 : 0;
      return stamp_result;
    }
    b.has_state = true;
    // Assigned in place: the body's strings keep their storage from message to message.
    const std::string_view source = withoutSlash(msg.header.frame_id);
    if (source.empty()) {
      state_.source_frame = registry.fixedFrame();
    } else {
      state_.source_frame.assign(source);
    }
    state_.child_frame.assign(withoutSlash(msg.child_frame_id));
    state_.pose = Eigen::Isometry3d::Identity();
    state_.pose.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
    state_.pose.linear() = Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
                               .normalized()
                               .toRotationMatrix();
    state_.v = Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z);
    state_.w = Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z);
    b.status.last_receipt = receipt;
    ++b.status.accepted;
    ++counts_.accepted;
    return InputResult::kAccepted;
  }

  bool contribute(Body& b, BodyRegistry& registry, const ros::Time& now, TransformSource& tf,
                  BodyInputs& in) override {
    const std::string& fixed = registry.fixedFrame();
    std::string error;
    ros::Time stamp;
    Eigen::Isometry3d fixed_src = Eigen::Isometry3d::Identity();
    if (state_.source_frame != fixed) {
      if (!BodyRegistry::lookup(tf, fixed, state_.source_frame, state_.stamp, fixed_src, stamp, error) &&
          !BodyRegistry::lookup(tf, fixed, state_.source_frame, ros::Time(0), fixed_src, stamp, error)) {
        registry.warnTf(b, error, now);
        return false;
      }
    }
    // Most odometry is in the fixed frame already: no product with the identity (a cycle computes
    // this for every body).
    const Eigen::Isometry3d fixed_child = state_.source_frame == fixed ? state_.pose : fixed_src * state_.pose;
    const Eigen::Matrix3d& r = fixed_child.linear();
    in.v = r * state_.v;
    in.w = r * state_.w;
    in.pose = fixed_child;
    in.frame = &state_.child_frame;
    in.t_ref = state_.stamp;
    const std::string& body_frame = b.params.frame;
    if (!body_frame.empty() && body_frame != state_.child_frame && !state_.child_frame.empty()) {
      // The body frame is another frame rigid with the child frame.
      Eigen::Isometry3d child_body;
      if (!BodyRegistry::lookup(tf, state_.child_frame, body_frame, ros::Time(0), child_body, stamp, error)) {
        registry.warnTf(b, error, now);
        return false;
      }
      in.pose = fixed_child * child_body;
      in.v += in.w.cross(in.pose.translation() - fixed_child.translation());
      in.frame = &body_frame;
    } else if (!body_frame.empty()) {
      in.frame = &body_frame;
    }
    return true;
  }

  void reset() override { state_.stamp = ros::Time(); }

  std::string describe(const Body&, const ros::Time&) const override { return ""; }

 private:
  std::string topic_;
  VelocityState state_;
};

// The velocity source is one of odom_topic and twist_topic: this kind, listed first, checks it.
void parseOdometry(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  using namespace param_reading;
  const XmlRpcValue* odom = member(e, "odom_topic");
  const XmlRpcValue* twist = member(e, "twist_topic");
  if (odom && twist) fail(path, "give one velocity source: odom_topic or twist_topic, not both");
  if (!odom && !twist) fail(path + ".odom_topic", "is required (or twist_topic): the body's velocity source");
  if (!odom) return;
  b.source = VelocitySource::kOdometry;
  b.topic = toString(*odom, path + ".odom_topic");
  if (b.topic.empty()) fail(path + ".odom_topic", "must not be empty");
}

}  // namespace

SourceKind odometrySourceKind() {
  return {"odometry", {"odom_topic"}, &BodyParams::topic, parseOdometry,
          [](const BodyParams& p) { return p.source == VelocitySource::kOdometry; },
          [](const BodyParams& p, const Body&) -> std::unique_ptr<Source> { return std::make_unique<OdometrySource>(p); },
          false};
}

InputResult BodyRegistry::onOdometry(size_t bi, const nav_msgs::Odometry& msg, const ros::Time& receipt) {
  return sourceOf<OdometrySource>(bi, "odom_topic").onMessage(*this, bodies_[bi], msg, receipt);
}

}  // namespace vadop_ros
