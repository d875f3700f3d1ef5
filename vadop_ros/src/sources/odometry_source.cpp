// The odometry source (odom_topic): nav_msgs/Odometry, the body's pose in header.frame_id and
// its twist in child_frame_id (REP 105). Its velocity state is the body frame's motion: the
// pose transformed into the fixed frame (tf at the message stamp, else the latest transform),
// the twist rotated with it; a `frame` other than child_frame_id is a frame rigid with it.
#include "pose_twist_source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <nav_msgs/Odometry.h>

#include <stdexcept>

namespace vadop_ros {
namespace {

class OdometrySource : public PoseTwistSource {
 public:
  explicit OdometrySource(const BodyParams& p) : topic_(p.topic) {}
  const char* kind() const override { return "odometry"; }
  const std::string& topic() const override { return topic_; }

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
    static constexpr PoseTwistFields kFields{"pose.pose.position", "pose.pose.orientation", "twist.twist.linear",
                                             "twist.twist.angular"};
    std::string why;
    if (!checkPoseTwist(msg.pose.pose, msg.twist.twist, kFields, why)) return dropInvalid(registry, b, why, receipt);
    return accept(registry, b, msg.header.stamp, withoutSlash(msg.header.frame_id), withoutSlash(msg.child_frame_id),
                  msg.pose.pose, msg.twist.twist, receipt);
  }

 private:
  std::string topic_;
};

// The velocity source is one of odom_topic, twist_topic and states_topic: this kind, listed
// first, checks it.
void parseOdometry(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  using namespace param_reading;
  const XmlRpcValue* odom = member(e, "odom_topic");
  std::string given;
  for (const char* key : {"odom_topic", "twist_topic", "states_topic"}) {
    if (!member(e, key)) continue;
    if (!given.empty()) {
      fail(path, "give one velocity source: odom_topic, twist_topic or states_topic, not " + given + " and " + key);
    }
    given = key;
  }
  if (given.empty()) {
    fail(path + ".odom_topic", "is required (or twist_topic or states_topic): the body's velocity source");
  }
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
