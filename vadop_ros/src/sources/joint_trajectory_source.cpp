// The joint trajectory source (joint_trajectory_topic): trajectory_msgs/JointTrajectory as
// MoveIt executes it, point times header.stamp (its receipt when zero) + time_from_start. It
// keeps the last accepted trajectory; while it runs (until its last point) the joints it names
// follow it (BodyRegistry::update). No points: the running trajectory is cancelled.
#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <trajectory_msgs/JointTrajectory.h>

#include <stdexcept>

namespace vadop_ros {
namespace {

class JointTrajectorySource : public Source {
 public:
  explicit JointTrajectorySource(const BodyParams& p) : topic_(p.joint_trajectory_topic) {}
  const char* kind() const override { return "joint_trajectory"; }
  const std::string& topic() const override { return topic_; }

  ros::Subscriber subscribe(const Wiring& w) override {
    return w.nh.subscribe<trajectory_msgs::JointTrajectory>(
        topic_, 5,
        [this, &lock = w.lock, &registry = w.registry,
         body = w.body](const trajectory_msgs::JointTrajectoryConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          onMessage(registry, registry.body(body), *msg, ros::Time::now());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  InputResult onMessage(BodyRegistry& registry, Body& b, const trajectory_msgs::JointTrajectory& msg,
                        const ros::Time& receipt) {
    if (!b.kinematics) return drop(registry, b, "the body has no kinematics (see its geometry error)", receipt);
    const ros::Time start = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
    if (const std::string why = registry.stampSkewError(start, receipt); !why.empty()) {
      return drop(registry, b, "header." + why, receipt);
    }
    if (msg.points.empty()) {
      trajectory_.time.clear();
      ++counts_.accepted;
      return InputResult::kAccepted;
    }
    TrajectoryInput t;
    if (const std::string why = jointIndices(*b.kinematics, msg.joint_names, "joint_names", t.joints); !why.empty()) {
      return drop(registry, b, why, receipt);
    }
    if (const std::string why = readPoints(msg, start, t); !why.empty()) return drop(registry, b, why, receipt);
    trajectory_ = std::move(t);
    ++counts_.accepted;
    return InputResult::kAccepted;
  }

  bool contribute(Body&, BodyRegistry&, const ros::Time&, TransformSource&, BodyInputs& in) override {
    in.trajectory = &trajectory_;
    return true;
  }

  void reset() override { trajectory_.time.clear(); }

  std::string describe(const Body& b, const ros::Time&) const override {
    // A body without joint states lists their zero counts first all the same (the line's form
    // does not depend on which joint inputs a body has).
    return std::string(b.source("joint_states") ? "" : "0 joint state(s) accepted, 0 dropped; ") +
           std::to_string(counts_.accepted) + " trajectory(ies) accepted, " + std::to_string(counts_.dropped) +
           " dropped";
  }

 private:
  InputResult drop(BodyRegistry& registry, Body& b, const std::string& why, const ros::Time& receipt) {
    ++counts_.dropped;
    registry.dropMessage(b, "joint_trajectory: " + why + " (the previous trajectory is kept)", receipt);
    return InputResult::kInvalid;
  }

  // The points of `msg` from `start`, checked, into `t`; "" or why not.
  static std::string readPoints(const trajectory_msgs::JointTrajectory& msg, const ros::Time& start,
                                TrajectoryInput& t) {
    const size_t n = msg.joint_names.size();
    bool with_velocities = true;
    for (const auto& p : msg.points) with_velocities = with_velocities && p.velocities.size() == n;
    for (size_t k = 0; k < msg.points.size(); ++k) {
      const auto& p = msg.points[k];
      const std::string field = "points[" + std::to_string(k) + "]";
      if (std::string why = checkPoint(p, n, field); !why.empty()) return why;
      const double from_start = p.time_from_start.toSec();
      if (!(from_start >= 0.0 && from_start <= BodyRegistry::kRebaseAfterSeconds)) {
        return field + ".time_from_start = " + numberText(from_start) + " s is not in [0, " +
               numberText(BodyRegistry::kRebaseAfterSeconds) + "]";
      }
      const ros::Time time = addSeconds(start, from_start);
      if (!t.time.empty() && !(time > t.time.back())) {
        return field + ".time_from_start does not increase (" + numberText(from_start) + " s)";
      }
      t.time.push_back(time);
      t.q.push_back(p.positions);
      if (with_velocities) t.qd.push_back(p.velocities);
    }
    return "";
  }

  // "" when the point has one position (and none or one velocity) per joint, in range.
  static std::string checkPoint(const trajectory_msgs::JointTrajectoryPoint& p, size_t n, const std::string& field) {
    if (p.positions.size() != n) {
      return field + ".positions has " + std::to_string(p.positions.size()) + " values for " + std::to_string(n) +
             " joint_names";
    }
    if (!p.velocities.empty() && p.velocities.size() != n) {
      return field + ".velocities has " + std::to_string(p.velocities.size()) + " values for " + std::to_string(n) +
             " joint_names (give none or one per joint)";
    }
    std::string why;
    for (size_t i = 0; i < n; ++i) {
      if (!checkValue(p.positions[i], vadop::kMaxCoordinate, "rad or m", field + ".positions[" + std::to_string(i) + "]",
                      why) ||
          (!p.velocities.empty() && !checkValue(p.velocities[i], vadop::kMaxAngularSpeed, "rad/s or m/s",
                                                field + ".velocities[" + std::to_string(i) + "]", why))) {
        return why;
      }
    }
    return "";
  }

  std::string topic_;
  TrajectoryInput trajectory_;
};

// A topic whose joints move a robot_description body's links (not with tf_prefix).
void parseJointTrajectory(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  param_reading::readJointTopic(e, path, "joint_trajectory_topic", &BodyParams::joint_trajectory_topic, b);
}

}  // namespace

SourceKind jointTrajectorySourceKind() {
  return {"joint_trajectory", {"joint_trajectory_topic"}, &BodyParams::joint_trajectory_topic, parseJointTrajectory,
          [](const BodyParams& p) { return !p.joint_trajectory_topic.empty(); },
          [](const BodyParams& p, const Body&) -> std::unique_ptr<Source> {
            return std::make_unique<JointTrajectorySource>(p);
          },
          true};
}

InputResult BodyRegistry::onJointTrajectory(size_t bi, const trajectory_msgs::JointTrajectory& msg,
                                            const ros::Time& receipt) {
  return sourceOf<JointTrajectorySource>(bi, "joint_trajectory_topic").onMessage(*this, bodies_[bi], msg, receipt);
}

}  // namespace vadop_ros
