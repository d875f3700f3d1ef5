// The twist source (twist_topic): geometry_msgs/TwistStamped, the body's velocity in
// header.frame_id (empty: the body frame); the pose comes from tf of the body's `frame`, the
// latest transform.
#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <geometry_msgs/TwistStamped.h>

#include <stdexcept>

namespace vadop_ros {
namespace {

class TwistSource : public Source {
 public:
  explicit TwistSource(const BodyParams& p) : topic_(p.topic) {}
  const char* kind() const override { return "twist"; }
  const std::string& topic() const override { return topic_; }
  const VelocityState* velocityState() const override { return &state_; }

  ros::Subscriber subscribe(const Wiring& w) override {
    return w.nh.subscribe<geometry_msgs::TwistStamped>(
        topic_, 20,
        [this, &lock = w.lock, &registry = w.registry, body = w.body](const geometry_msgs::TwistStampedConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          onMessage(registry, registry.body(body), *msg, ros::Time::now());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  InputResult onMessage(BodyRegistry& registry, Body& b, const geometry_msgs::TwistStamped& msg,
                        const ros::Time& receipt) {
    std::string why;
    if (!checkVector(msg.twist.linear, vadop::kMaxLinearSpeed, "m/s", "twist.linear", why) ||
        !checkVector(msg.twist.angular, vadop::kMaxAngularSpeed, "rad/s", "twist.angular", why)) {
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
    state_.twist_frame.assign(withoutSlash(msg.header.frame_id));
    state_.v = Eigen::Vector3d(msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z);
    state_.w = Eigen::Vector3d(msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z);
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
    in.frame = &b.params.frame;
    if (!BodyRegistry::lookup(tf, fixed, *in.frame, ros::Time(0), in.pose, stamp, error)) {
      registry.warnTf(b, error, now);
      return false;
    }
    Eigen::Matrix3d r = in.pose.linear();
    if (!state_.twist_frame.empty() && state_.twist_frame != *in.frame) {
      Eigen::Isometry3d fixed_twist;
      ros::Time s2;
      if (!BodyRegistry::lookup(tf, fixed, state_.twist_frame, ros::Time(0), fixed_twist, s2, error)) {
        registry.warnTf(b, error, now);
        return false;
      }
      r = fixed_twist.linear();
    }
    in.v = r * state_.v;
    in.w = r * state_.w;
    in.t_ref = stamp.isZero() ? now : stamp;
    return true;
  }

  void reset() override { state_.stamp = ros::Time(); }

  std::string describe(const Body&, const ros::Time&) const override { return ""; }

 private:
  std::string topic_;
  VelocityState state_;
};

// After odometry's check that the body has one velocity source.
void parseTwist(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  using namespace param_reading;
  const XmlRpcValue* twist = member(e, "twist_topic");
  if (!twist) return;
  b.source = VelocitySource::kTwist;
  b.topic = toString(*twist, path + ".twist_topic");
  if (b.topic.empty()) fail(path + ".twist_topic", "must not be empty");
  if (b.frame.empty()) fail(path + ".frame", "is required with twist_topic (the tf frame that gives the body's pose)");
}

}  // namespace

SourceKind twistSourceKind() {
  return {"twist", {"twist_topic"}, &BodyParams::topic, parseTwist,
          [](const BodyParams& p) { return p.source == VelocitySource::kTwist; },
          [](const BodyParams& p, const Body&) -> std::unique_ptr<Source> { return std::make_unique<TwistSource>(p); },
          false};
}

InputResult BodyRegistry::onTwist(size_t bi, const geometry_msgs::TwistStamped& msg, const ros::Time& receipt) {
  return sourceOf<TwistSource>(bi, "twist_topic").onMessage(*this, bodies_[bi], msg, receipt);
}

}  // namespace vadop_ros
