// The odometry source (odom_topic): nav_msgs/Odometry, the body's pose in header.frame_id and
// its twist in child_frame_id (REP 105). Its velocity state is the body frame's motion: the
// pose transformed into the fixed frame (tf at the message stamp, else the latest transform),
// the twist rotated with it; a `frame` other than child_frame_id is a frame rigid with it.
#include "pose_twist_source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <nav_msgs/Odometry.h>

#include <stdexcept>
#include <utility>

namespace vadop_ros {
namespace {

class OdometrySource : public PoseTwistSource {
 public:
  explicit OdometrySource(const BodyParams& p) : topic_(p.topic) {}
  const char* kind() const override { return "odometry"; }
  const std::string& topic() const override { return topic_; }

  // The callback takes no lock but its slot's (pose_twist_source.h): it runs on the node's
  // ingest queue, which may be the transport's own thread.
  ros::Subscriber subscribe(const Wiring& w) override {
    ros::SubscribeOptions options;
    options.init<nav_msgs::Odometry>(
        topic_, 20,
        [this, &registry = w.registry, name = &w.registry.bodies().at(w.body).name](
            const nav_msgs::OdometryConstPtr& msg) { onMessage(registry, *name, *msg, ros::Time::now()); });
    // UDPROS when asked for (~ingest_udp) and the publisher offers it, else TCPROS.
    options.transport_hints =
        w.ingest_udp ? ros::TransportHints().udp().tcpNoDelay() : ros::TransportHints().tcpNoDelay();
    options.callback_queue = w.ingest_queue;
    return w.nh.subscribe(options);
  }

  // Posts the message into the body's slot (any thread); the cycle collects it.
  InputResult onMessage(const BodyRegistry& registry, const std::string& body, const nav_msgs::Odometry& msg,
                        const ros::Time& receipt) {
    static constexpr PoseTwistFields kFields{"pose.pose.position", "pose.pose.orientation", "twist.twist.linear",
                                             "twist.twist.angular"};
    std::string why;
    if (!checkPoseTwist(msg.pose.pose, msg.twist.twist, kFields, why)) return postInvalid(std::move(why), receipt);
    return post(registry, body, msg.header.stamp, withoutSlash(msg.header.frame_id), withoutSlash(msg.child_frame_id),
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
  const InputResult result = postOdometry(bi, msg, receipt);
  collect(bi);
  return result;
}

InputResult BodyRegistry::postOdometry(size_t bi, const nav_msgs::Odometry& msg, const ros::Time& receipt) {
  return sourceOf<OdometrySource>(bi, "odom_topic").onMessage(*this, bodies_[bi].name, msg, receipt);
}

}  // namespace vadop_ros
