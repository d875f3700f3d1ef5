// The body-states source (states_topic): the body's entry, by name, of a fleet's
// vadop/BodyStateArray: its pose in the array's header.frame_id at the array's stamp, its twist
// in the body frame, taken as an odometry message would be (PoseTwistSource: the same checks,
// stamp policy and motion). The bodies of one topic share one subscription: the node subscribes
// once per distinct topic (the first of its bodies' sources does; the others return no
// subscription), and each array is routed to its bodies by name through a hash map
// (BodyStatesRoutes). Entries naming no body of the topic are counted; a bad entry is dropped
// (its body's warning names the entry), the rest of the array kept.
#include "pose_twist_source.h"

#include "../message_checks.h"
#include "../param_reading.h"

#include <map>
#include <unordered_map>

namespace vadop_ros {
namespace {
class BodyStatesSource;
}

// Per states_topic: its bodies by name (a body's sources and strings live as long as the
// registry, so a route keeps pointers), its totals and whether a subscription exists.
class BodyStatesRoutes {
 public:
  struct Target {
    size_t body;
    BodyStatesSource* source;
  };
  struct Route {
    std::unordered_map<std::string, Target> by_name;
    BodyStatesCounts totals;
    bool subscribed = false;
  };
  std::map<std::string, Route> topics;
};

namespace {

class BodyStatesSource : public PoseTwistSource {
 public:
  explicit BodyStatesSource(const BodyParams& p) : topic_(p.topic) {}
  const char* kind() const override { return "body_states"; }
  const std::string& topic() const override { return topic_; }

  // One subscription per topic: made by the first body of the topic that subscribes.
  ros::Subscriber subscribe(const Wiring& w) override {
    {
      std::lock_guard<std::mutex> guard(w.lock);
      BodyStatesRoutes::Route& route = w.registry.bodyStatesRoutes().topics.at(topic_);
      if (route.subscribed) return ros::Subscriber();
      route.subscribed = true;
    }
    return w.nh.subscribe<vadop::BodyStateArray>(
        topic_, 5,
        [&lock = w.lock, &registry = w.registry, topic = topic_](const vadop::BodyStateArrayConstPtr& msg) {
          std::lock_guard<std::mutex> guard(lock);
          registry.onBodyStates(topic, *msg, ros::Time::now());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  // Entry `k` of an array on topic(), in `frame` at `stamp`, naming this source's body `b`:
  // posted into its slot (under the node's lock here) and collected at once.
  InputResult onEntry(BodyRegistry& registry, Body& b, const ros::Time& stamp, std::string_view frame,
                      const vadop::BodyState& e, size_t k, const ros::Time& receipt) {
    static constexpr PoseTwistFields kFields{"pose.position", "pose.orientation", "twist.linear", "twist.angular"};
    std::string why;
    const InputResult result =
        checkPoseTwist(e.pose, e.twist, kFields, why)
            ? post(registry, b.name, stamp, frame, b.params.frame, e.pose, e.twist, receipt)
            : postInvalid("entry \"" + e.name + "\" (states[" + std::to_string(k) + "] of " + topic_ + "): " + why,
                          receipt);
    collect(b, registry);
    return result;
  }

 private:
  std::string topic_;
};

// After odometry's check that the body has one velocity source.
void parseStates(const XmlRpc::XmlRpcValue& e, const std::string& path, BodyParams& b) {
  using namespace param_reading;
  const XmlRpcValue* states = member(e, "states_topic");
  if (!states) return;
  b.source = VelocitySource::kStates;
  b.topic = toString(*states, path + ".states_topic");
  if (b.topic.empty()) fail(path + ".states_topic", "must not be empty");
}

}  // namespace

SourceKind bodyStatesSourceKind() {
  return {"body_states", {"states_topic"}, &BodyParams::topic, parseStates,
          [](const BodyParams& p) { return p.source == VelocitySource::kStates; },
          [](const BodyParams& p, const Body&) -> std::unique_ptr<Source> {
            return std::make_unique<BodyStatesSource>(p);
          },
          false};
}

BodyStatesRoutes& BodyRegistry::bodyStatesRoutes() {
  if (states_routes_) return *states_routes_;
  states_routes_ = std::make_shared<BodyStatesRoutes>();
  for (size_t i = 0; i < bodies_.size(); ++i) {
    for (const std::unique_ptr<Source>& source : bodies_[i].sources) {
      if (auto* s = dynamic_cast<BodyStatesSource*>(source.get())) {
        states_routes_->topics[s->topic()].by_name.emplace(bodies_[i].name, BodyStatesRoutes::Target{i, s});
      }
    }
  }
  return *states_routes_;
}

BodyStatesCounts BodyRegistry::onBodyStates(const std::string& topic, const vadop::BodyStateArray& msg,
                                            const ros::Time& receipt) {
  BodyStatesCounts c;
  c.arrays = 1;
  auto& topics = bodyStatesRoutes().topics;
  const auto route = topics.find(topic);
  if (route == topics.end()) {
    c.unknown = msg.states.size();
    return c;
  }
  const std::string_view frame = withoutSlash(msg.header.frame_id);
  const auto& by_name = route->second.by_name;
  for (size_t k = 0; k < msg.states.size(); ++k) {
    const vadop::BodyState& e = msg.states[k];
    const auto target = by_name.find(e.name);
    if (target == by_name.end()) {
      ++c.unknown;
      continue;
    }
    Body& b = bodies_[target->second.body];
    switch (target->second.source->onEntry(*this, b, msg.header.stamp, frame, e, k, receipt)) {
      case InputResult::kAccepted: ++c.accepted; break;
      case InputResult::kInvalid: ++c.dropped; break;
      case InputResult::kOutOfOrder: ++c.out_of_order; break;
    }
  }
  BodyStatesCounts& t = route->second.totals;
  t.arrays += 1;
  t.accepted += c.accepted;
  t.dropped += c.dropped;
  t.out_of_order += c.out_of_order;
  t.unknown += c.unknown;
  return c;
}

std::vector<std::pair<std::string, BodyStatesCounts>> BodyRegistry::bodyStatesTopics() const {
  std::vector<std::pair<std::string, BodyStatesCounts>> out;
  if (!states_routes_) return out;
  for (const auto& [topic, route] : states_routes_->topics) out.emplace_back(topic, route.totals);
  return out;
}

}  // namespace vadop_ros
