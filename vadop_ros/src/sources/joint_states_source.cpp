// The joint states source (joint_states_topic): sensor_msgs/JointState, the positions and
// velocities of the URDF's movable joints, matched by name. It keeps each joint's latest
// position, velocity and stamp; at a cycle the links move with their joints
// (BodyRegistry::update). Joints a message does not name keep their last state.
#include "vadop_ros/body_registry.h"
#include "vadop_ros/source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <sensor_msgs/JointState.h>

#include <algorithm>
#include <stdexcept>

namespace vadop_ros {
namespace {

class JointStatesSource : public Source {
 public:
  JointStatesSource(const BodyParams& p, const Body& b) : topic_(p.joint_states_topic) {
    const size_t nj = b.kinematics ? b.kinematics->joints().size() : 0;
    joints_.q.assign(nj, 0.0);
    joints_.qd.assign(nj, 0.0);
    joints_.q_time.assign(nj, ros::Time());
  }
  const char* kind() const override { return "joint_states"; }
  const std::string& topic() const override { return topic_; }

  ros::Subscriber subscribe(const Wiring& w) override {
    return w.nh.subscribe<sensor_msgs::JointState>(
        topic_, 20,
        [this, &lock = w.lock, &registry = w.registry, body = w.body](const sensor_msgs::JointStateConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          onMessage(registry, registry.body(body), *msg, ros::Time::now());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  InputResult onMessage(BodyRegistry& registry, Body& b, const sensor_msgs::JointState& msg, const ros::Time& receipt) {
    if (!b.kinematics) return drop(registry, b, "the body has no kinematics (see its geometry error)", receipt);
    std::vector<int> index;
    if (const std::string why = check(*b.kinematics, msg, index); !why.empty()) return drop(registry, b, why, receipt);
    const ros::Time stamp = msg.header.stamp.isZero() ? receipt : msg.header.stamp;
    if (const std::string why = registry.stampSkewError(stamp, receipt); !why.empty()) {
      return drop(registry, b, "header." + why, receipt);
    }
    if (joints_.has_joints && stamp <= joints_.stamp && joints_.stamp <= receipt) {
      ++b.status.dropped_out_of_order;
      return InputResult::kOutOfOrder;
    }
    for (size_t i = 0; i < msg.name.size(); ++i) {
      const size_t j = static_cast<size_t>(index[i]);
      joints_.q[j] = msg.position[i];
      joints_.qd[j] = msg.velocity.empty() ? 0.0 : msg.velocity[i];
      joints_.q_time[j] = stamp;
    }
    joints_.has_joints = true;
    joints_.stamp = stamp;
    joints_.receipt = receipt;
    ++counts_.accepted;
    return InputResult::kAccepted;
  }

  bool contribute(Body&, BodyRegistry&, const ros::Time&, TransformSource&, BodyInputs& in) override {
    in.joints = &joints_;
    return true;
  }

  void reset() override {
    joints_.has_joints = false;
    joints_.stamp = ros::Time();
    std::fill(joints_.q.begin(), joints_.q.end(), 0.0);
    std::fill(joints_.qd.begin(), joints_.qd.end(), 0.0);
    std::fill(joints_.q_time.begin(), joints_.q_time.end(), ros::Time());
  }

  std::string describe(const Body&, const ros::Time&) const override {
    return std::to_string(counts_.accepted) + " joint state(s) accepted, " + std::to_string(counts_.dropped) +
           " dropped";
  }

 private:
  InputResult drop(BodyRegistry& registry, Body& b, const std::string& why, const ros::Time& receipt) {
    ++counts_.dropped;
    registry.dropMessage(b, "joint_states: " + why, receipt);
    return InputResult::kInvalid;
  }

  // "" when the message's arrays agree, name movable joints once each and hold values in the
  // library's range (`index`: each name's joint), else why not.
  static std::string check(const JointKinematics& kin, const sensor_msgs::JointState& msg, std::vector<int>& index) {
    const size_t n = msg.name.size();
    if (msg.position.size() != n) {
      return "position has " + std::to_string(msg.position.size()) + " values for " + std::to_string(n) + " names";
    }
    if (!msg.velocity.empty() && msg.velocity.size() != n) {
      return "velocity has " + std::to_string(msg.velocity.size()) + " values for " + std::to_string(n) +
             " names (give none or one per name)";
    }
    if (std::string why = jointIndices(kin, msg.name, "name", index); !why.empty()) return why;
    for (size_t i = 0; i < n; ++i) {
      std::string why;
      if (!checkValue(msg.position[i], vadop::kMaxCoordinate, "rad or m", "position[" + std::to_string(i) + "]", why)) {
        return why;
      }
      if (!msg.velocity.empty() && !checkValue(msg.velocity[i], vadop::kMaxAngularSpeed, "rad/s or m/s",
                                               "velocity[" + std::to_string(i) + "]", why)) {
        return why;
      }
    }
    return "";
  }

  std::string topic_;
  JointInput joints_;
};

// A topic whose joints move a robot_description body's links (not with tf_prefix).
void parseJointStates(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  param_reading::readJointTopic(e, path, "joint_states_topic", &BodyParams::joint_states_topic, b);
}

}  // namespace

SourceKind jointStatesSourceKind() {
  return {"joint_states", {"joint_states_topic"}, &BodyParams::joint_states_topic, parseJointStates,
          [](const BodyParams& p) { return !p.joint_states_topic.empty(); },
          [](const BodyParams& p, const Body& b) -> std::unique_ptr<Source> {
            return std::make_unique<JointStatesSource>(p, b);
          },
          true};
}

InputResult BodyRegistry::onJointState(size_t bi, const sensor_msgs::JointState& msg, const ros::Time& receipt) {
  return sourceOf<JointStatesSource>(bi, "joint_states_topic").onMessage(*this, bodies_[bi], msg, receipt);
}

}  // namespace vadop_ros
