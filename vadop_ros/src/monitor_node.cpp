// The monitor on ROS (monitor_node.h): the node vadop_monitor and the nodelet
// vadop/MonitorNodelet run this, from their own node handles. It predicts collisions between
// the configured bodies over a time horizon and publishes them (~impacts), with rviz markers
// (~markers) and /diagnostics; bodies with a gate get each velocity command checked and
// forwarded scaled (cmd_vel_in -> cmd_vel_out, ~gate_states).
// Parameters: config/monitor.yaml; behaviour: docs/monitor.md.
#include "vadop_ros/monitor_core.h"
#include "vadop_ros/monitor_diagnostics.h"
#include "vadop_ros/monitor_node.h"
#include "vadop_ros/params.h"
#include "vadop_ros/velocity_gate.h"

#include "receiving_thread_queue.h"

#include <vadop/GateStateArray.h>
#include <vadop/ImpactArray.h>
#include <vadop/MonitorConfig.h>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/Twist.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <exception>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace vadop_ros {
namespace {

// tf2 as the registry's TransformSource.
class Tf2Source : public TransformSource {
 public:
  explicit Tf2Source(tf2_ros::Buffer& buffer) : buffer_(buffer) {}
  bool lookup(const std::string& target, const std::string& source, const ros::Time& time, Eigen::Isometry3d& pose,
              ros::Time& stamp, std::string& error) override {
    try {
      const geometry_msgs::TransformStamped t = buffer_.lookupTransform(target, source, time);
      pose = tf2::transformToEigen(t);
      stamp = t.header.stamp;
      return true;
    } catch (const tf2::TransformException& e) {
      error = e.what();
      return false;
    }
  }
  bool concurrent() const override { return true; }  // tf2::BufferCore locks its own state
  bool parent(const std::string& frame, const ros::Time& time, std::string& parent) override {
    return buffer_._getParent(frame, time, parent);
  }

 private:
  tf2_ros::Buffer& buffer_;
};

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Start-up progress of large configurations: a line every kProgressEvery bodies or
// kProgressSeconds, whichever comes first.
constexpr size_t kProgressEvery = 10000;
constexpr double kProgressSeconds = 5.0;

class MonitorNode : public Monitor {
 public:
  MonitorNode(ros::NodeHandle nh, ros::NodeHandle pnh, const MonitorParams& params)
      : nh_(nh),
        pnh_(pnh),
        tf_nh_(withQueue(nh, &tf_queue_)),
        tf_buffer_(ros::Duration(30.0)),
        tf_listener_(tf_buffer_, tf_nh_, /*spin_thread=*/false),
        tf_spinner_(1, &tf_queue_),
        tf_source_(tf_buffer_),
        sets_nh_(withQueue(nh, &sets_queue_)) {
    tf_spinner_.start();
    const auto start = std::chrono::steady_clock::now();
    core_ = std::make_unique<MonitorCore>(params, [this](const std::string& name, std::string& value) {
      return nh_.getParam(name, value);
    });
    if (params.bodies.size() + params.static_obstacles.size() >= kProgressEvery) {
      ROS_INFO("vadop_monitor: geometry of %zu bodies and obstacles built in %.1f s",
               params.bodies.size() + params.static_obstacles.size(), secondsSince(start));
    }
    refuseBodiesWithoutGeometry(params);
    for (const std::string& e : core_->registry().geometryErrors()) {
      ROS_ERROR("vadop_monitor: %s (the rest is monitored)", e.c_str());
    }

    impacts_pub_ = pnh_.advertise<vadop::ImpactArray>("impacts", 10);
    markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("markers", 2);

    setUpIngest(params.ingest_threads);
    const auto subscribe_start = std::chrono::steady_clock::now();
    const size_t moving = subscribeInputs();
    setUpGates();
    setUpDiagnostics();
    setUpReconfigure(params);

    timer_ = nh_.createTimer(ros::Duration(1.0 / rate_), [this](const ros::TimerEvent&) { onTimer(); });
    reconnect_start_ = std::chrono::steady_clock::now();
    // The start-up checks below call the master (a few milliseconds a call): on the body-set
    // sources' thread, not the cycle's.
    reconnect_timer_ = sets_nh_.createWallTimer(ros::WallDuration(kReconnectSeconds),
                                                [this](const ros::WallTimerEvent&) { reconnectSilentTopics(); });
    silent_topics_timer_ = sets_nh_.createWallTimer(
        ros::WallDuration(kFirstMessageWarnSeconds), [this](const ros::WallTimerEvent&) { warnSilentTopics(); },
        /*oneshot=*/true);
    if (!gates_.empty()) {
      gate_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &gate_queue_);
      gate_spinner_->start();
    }
    if (moving >= kProgressEvery) {
      ROS_INFO("vadop_monitor: subscribed to %zu topics in %.1f s; start-up took %.1f s", moving,
               secondsSince(subscribe_start), secondsSince(start));
    }
    ROS_INFO("vadop_monitor: %zu moving bodies, %zu static obstacles, %zu collision elements, %zu tracked-object "
             "source(s); fixed frame \"%s\", %.1f Hz, horizon %.2f s, padding %.3f m",
             moving, core_->registry().bodies().size() - moving, core_->registry().elements().size(),
             params.tracks.size(), params.fixed_frame.c_str(), rate_, params.horizon, params.padding);
    if (params.bodies.empty() && params.static_obstacles.empty() && params.tracks.empty() && params.sensors.empty()) {
      ROS_WARN("vadop_monitor: nothing configured (no bodies, static_obstacles, tracks or sensors): nothing to "
               "predict. Give the node a parameter file (roslaunch vadop monitor.launch config:=/path/to/your.yaml; "
               "config/monitor.yaml is the reference)");
    }
  }

 private:
  // Every input of every moving body (each source subscribes itself, source.h) and of every
  // body-set source (tracked objects); returns the number of moving bodies.
  size_t subscribeInputs() {
    const auto& bodies = core_->registry().bodies();
    // One subscription per moving body: a call to the master each, and both roscpp
    // (TopicManager::addSubCallback) and rosmaster (NodeRef.add) compare a new subscription
    // with every earlier one of the node. This is nearly all of a large start-up (20,000
    // bodies: parameters 0.2 s, geometry 0.3 s, subscriptions 40 s; see kMaxBodies), so its
    // progress is logged.
    size_t moving = 0;
    for (const Body& b : bodies) moving += b.is_static ? 0 : 1;
    const auto subscribe_start = std::chrono::steady_clock::now();
    auto last_progress = subscribe_start;
    subs_.reserve(moving);
    for (size_t i = 0; i < bodies.size(); ++i) {
      const Body& b = bodies[i];
      if (b.is_static) continue;
      if (!subs_.empty() && (subs_.size() % kProgressEvery == 0 || secondsSince(last_progress) >= kProgressSeconds)) {
        last_progress = std::chrono::steady_clock::now();
        ROS_INFO("vadop_monitor: set up %zu of %zu bodies (subscribing, %.0f s)", subs_.size(), moving,
                 secondsSince(subscribe_start));
      }
      for (const auto& source : b.sources) {
        subs_.push_back(source->subscribe(wiring(i)));
        if (std::string(source->kind()) == "odometry") {
          odometry_subs_.push_back({subs_.size() - 1, i, 0, std::chrono::steady_clock::now()});
        }
        // Bodies sharing a topic (a fleet array) share its one subscription: the first's.
        if (subs_.back()) sub_of_topic_.emplace(source->topic(), subs_.size() - 1);
      }
    }
    // Body-set sources (tracked objects, sensors): each subscribes its own topics, on a queue
    // and thread of their own: a cloud's handling (milliseconds: its points placed, filtered and
    // put in a tree, outside the node's lock) never holds back a cycle on the node's queue.
    for (const auto& source : core_->bodiesSources()) {
      for (ros::Subscriber& sub : source->subscribe({sets_nh_, core_mutex_, tf_source_})) {
        subs_.push_back(std::move(sub));
      }
    }
    sets_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &sets_queue_);
    sets_spinner_->start();
    return moving;
  }

  // The odometry callbacks' queue (~ingest_threads): 0, none (roscpp's receiving thread runs
  // them as the messages arrive); n, a queue of their own served by n threads. Either way not
  // the node's queue, where the cycle runs.
  void setUpIngest(int threads) {
    if (threads == 0) {
      ingest_queue_ = std::make_unique<ReceivingThreadQueue>();
      return;
    }
    auto queue = std::make_unique<ros::CallbackQueue>();
    ingest_spinner_ = std::make_unique<ros::AsyncSpinner>(threads, queue.get());
    ingest_queue_ = std::move(queue);
    ingest_spinner_->start();
  }

  Source::Wiring wiring(size_t body) {
    return {nh_, core_mutex_, core_->registry(), body, tf_source_, ingest_queue_.get(), core_->params().ingest_udp};
  }

  // Odometry subscriptions that did not connect within kReconnectAfter. With thousands of topics,
  // roscpp's negotiations (two XML-RPC connections each) and the master's publisher updates land on
  // XML-RPC servers that listen with a backlog of 5; a connection the kernel dropped waits for
  // TCP's SYN retransmission (1, 3, 7, 15, 31 s), and a publisher update the master could not
  // deliver is not sent again. Every kReconnectSeconds, a body that has had no message
  // kReconnectAfter after its subscription and whose subscription has no publisher, while the
  // master lists one for its topic, is subscribed again (a fresh negotiation; one under way is
  // left alone: restarting those delays them), at most kReconnectBatch a time (each costs two
  // calls to the master, which the publishers' start-up shares) and kMaxReconnects times a topic
  // (a publisher of another type never connects). The timer stops when no body that could be
  // subscribed again is waiting (not when none is due at a tick: the last subscribed are due
  // later), or kReconnectWindow seconds after start-up (a publisher that starts later is
  // announced by the master on its own, not in a burst, and a topic nobody publishes would
  // otherwise cost a call to the master a second).
  void reconnectSilentTopics() {
    if (secondsSince(reconnect_start_) > kReconnectWindow) {
      reconnect_timer_.stop();
      return;
    }
    std::vector<OdometrySub*> silent;
    bool waiting = false;  // some body may yet be subscribed again (now or at a later tick)
    {
      std::lock_guard<std::mutex> lock(core_mutex_);
      const auto& bodies = core_->registry().bodies();
      for (OdometrySub& o : odometry_subs_) {
        if (o.reconnects >= kMaxReconnects || bodies[o.body].status.state != BodyState::kWaiting) continue;
        waiting = true;
        if (secondsSince(o.since) >= kReconnectAfter && subs_[o.sub].getNumPublishers() == 0) silent.push_back(&o);
      }
    }
    if (!waiting) {
      reconnect_timer_.stop();
      return;
    }
    if (silent.empty()) return;
    ros::master::V_TopicInfo published;
    if (!ros::master::getTopics(published)) return;
    std::unordered_set<std::string> names;
    for (const ros::master::TopicInfo& t : published) names.insert(t.name);
    size_t again = 0;
    for (OdometrySub* o : silent) {
      if (again == kReconnectBatch) break;
      if (names.count(subs_[o->sub].getTopic()) == 0) continue;  // nobody publishes it: nothing to connect to
      subs_[o->sub].shutdown();
      subs_[o->sub] = core_->registry().body(o->body).sources.front()->subscribe(wiring(o->body));
      ++o->reconnects;
      o->since = std::chrono::steady_clock::now();
      ++again;
    }
    if (again > 0) {
      ROS_INFO("vadop_monitor: subscribed again to %zu odometry topic(s) whose publisher had not connected", again);
    }
  }

  // A body or obstacle with nothing to monitor (its robot_description missing, unparsable, or
  // without a usable collision element) is a configuration mistake nothing could hit: refused,
  // naming the parameter.
  void refuseBodiesWithoutGeometry(const MonitorParams& params) const {
    for (const Body& b : core_->registry().bodies()) {
      if (!b.elements.empty()) continue;
      const std::string why = b.status.geometry_errors.empty() ? "no collision element" : b.status.geometry_errors.front();
      const char* list = b.is_static ? "static_obstacles" : "bodies";
      size_t index = 0;
      if (b.is_static) {
        while (index < params.static_obstacles.size() && params.static_obstacles[index].name != b.name) ++index;
      } else {
        while (index < params.bodies.size() && params.bodies[index].name != b.name) ++index;
      }
      throw ParamError("~" + std::string(list) + "[" + std::to_string(index) + "] (\"" + b.name +
                       "\").robot_description: nothing to monitor: " + why);
    }
  }

  // kFirstMessageWarnSeconds after start-up: a WARN for each moving body still waiting whose
  // topic no node publishes (a wrong odom_topic is otherwise silent; diagnostics warn too): one
  // warning a body for the first kSilentNamed of them, then one line for the rest (a fleet whose
  // driver still advertises its 3,000 topics would otherwise print thousands).
  static constexpr size_t kSilentNamed = 10;
  void warnSilentTopics() {
    std::lock_guard<std::mutex> lock(core_mutex_);
    size_t silent = 0;
    std::string first_unnamed;
    for (const Body& b : core_->registry().bodies()) {
      if (b.is_static || b.status.state != BodyState::kWaiting || b.sources.empty()) continue;
      const auto sub = sub_of_topic_.find(b.sources.front()->topic());  // the velocity source: its state
      if (sub == sub_of_topic_.end() || subs_[sub->second].getNumPublishers() > 0) continue;
      if (++silent > kSilentNamed) {
        if (first_unnamed.empty()) first_unnamed = "\"" + b.name + "\" (" + subs_[sub->second].getTopic() + ")";
        continue;
      }
      ROS_WARN("vadop_monitor: body \"%s\": no node publishes %s %.0f s after start-up (waiting for its first "
               "message; is the topic right?)",
               b.name.c_str(), subs_[sub->second].getTopic().c_str(), kFirstMessageWarnSeconds);
    }
    if (silent > kSilentNamed) {
      ROS_WARN("vadop_monitor: %zu more bodies, from %s on: no node publishes their topics %.0f s after start-up "
               "(waiting for their first messages; diagnostics \"bodies\" lists those waiting)",
               silent - kSilentNamed, first_unnamed.c_str(), kFirstMessageWarnSeconds);
    }
  }

  // Velocity gates: each command is checked as it arrives (not at the cycle rate), on the gates'
  // own queue and thread, so that a command is checked while a cycle predicts.
  void setUpGates() {
    const auto& bodies = core_->registry().bodies();
    for (size_t i = 0; i < bodies.size(); ++i) {
      if (bodies[i].is_static || !bodies[i].params.has_gate) continue;
      const size_t g = gates_.size();
      gates_.emplace_back(i, core_->registry());
      const GateParams& gp = bodies[i].params.gate;
      gate_pubs_.push_back(nh_.advertise<geometry_msgs::Twist>(gp.cmd_vel_out, 10));
      ros::SubscribeOptions options;
      options.init<geometry_msgs::Twist>(
          gp.cmd_vel_in, 10,
          boost::function<void(const ros::MessageEvent<geometry_msgs::Twist const>&)>(
              [this, g](const ros::MessageEvent<geometry_msgs::Twist const>& event) {
                onCommand(g, *event.getConstMessage(), event.getReceiptTime());
              }));
      options.transport_hints = ros::TransportHints().tcpNoDelay();
      options.callback_queue = &gate_queue_;
      subs_.push_back(nh_.subscribe(options));
      updater_.add("gate " + bodies[i].name, [this, g](diagnostic_updater::DiagnosticStatusWrapper& s) {
        reportGate(s, gates_[g]);
        s.add("latency median (ms)", gate_latency_[g].percentile(0.5));
        s.add("latency p99 (ms)", gate_latency_[g].percentile(0.99));
      });
    }
    gate_latency_.resize(gates_.size());
    if (!gates_.empty()) gate_states_pub_ = pnh_.advertise<vadop::GateStateArray>("gate_states", 10);
  }

  void setUpDiagnostics() {
    updater_.setHardwareID("vadop_monitor");
    updater_.add("cycle", [this](diagnostic_updater::DiagnosticStatusWrapper& s) {
      window_.report(s, core_->params().rate);
    });
    updater_.add("bodies", [this](diagnostic_updater::DiagnosticStatusWrapper& s) {
      reportBodies(s, core_->registry(), ros::Time::now());
    });
    for (const auto& source : core_->bodiesSources()) {
      if (!source->configured()) continue;
      const BodiesSource* kept = source.get();
      updater_.add(kept->kind(), [kept](diagnostic_updater::DiagnosticStatusWrapper& s) {
        kept->report(s, ros::Time::now());
      });
    }
  }

  // ~horizon, ~rate and ~padding through dynamic_reconfigure, starting from the parameters.
  void setUpReconfigure(const MonitorParams& params) {
    rate_ = params.rate;
    window_.setRate(rate_);
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<vadop::MonitorConfig>>(reconfigure_mutex_, pnh_);
    vadop::MonitorConfig initial;
    initial.horizon = params.horizon;
    initial.rate = params.rate;
    initial.padding = params.padding;
    reconfigure_->updateConfig(initial);
    reconfigure_->setCallback(
        [this](vadop::MonitorConfig& c, uint32_t) { onReconfigure(c); });
  }

  // Every use of core_ holds core_mutex_ (the gates' thread checks commands), but for the
  // cycle's prediction, which onTimer runs outside it (MonitorCore::predictCycle).
  // A command on a gate's cmd_vel_in: checked and forwarded at once. Whatever goes wrong, the
  // gate publishes a zero command rather than nothing or the unchecked one.
  void onCommand(size_t g, const geometry_msgs::Twist& msg, const ros::Time& receipt) {
    std::lock_guard<std::mutex> lock(core_mutex_);
    const ros::Time now = ros::Time::now();
    geometry_msgs::Twist out;  // zero
    try {
      if (!now.isZero()) out = gates_[g].onCommand(*core_, msg, now, tf_source_);
    } catch (const std::exception& e) {
      out = geometry_msgs::Twist();
      ROS_ERROR_THROTTLE(5.0, "vadop_monitor: gate of \"%s\" failed (zero command published): %s",
                         gates_[g].state().body.c_str(), e.what());
    }
    gate_pubs_[g].publish(out);
    // From the message's arrival at the node (transport thread) to the gated command's
    // publication: the check and any wait behind a cycle running on the callback thread. Wall
    // clock (ros::Time may be simulated).
    gate_latency_[g].add((ros::WallTime::now().toSec() - receiptWall(receipt)) * 1e3);
    publishGateStates(now);
  }

  // ros::MessageEvent's receipt time is ros::Time::now() at arrival: with use_sim_time it is
  // simulated time, and latency is then not measured (NaN).
  double receiptWall(const ros::Time& receipt) const {
    return ros::Time::isSimTime() ? std::numeric_limits<double>::quiet_NaN() : receipt.toSec();
  }

  void publishGateStates(const ros::Time& now) {
    if (gates_.empty()) return;
    vadop::GateStateArray msg;
    msg.header.stamp = now;
    msg.header.frame_id = core_->params().fixed_frame;
    msg.gates.reserve(gates_.size());
    for (const VelocityGate& g : gates_) msg.gates.push_back(g.state());
    gate_states_pub_.publish(msg);
  }

  static void reportGate(diagnostic_updater::DiagnosticStatusWrapper& s, const VelocityGate& g) {
    const vadop::GateState& st = g.state();
    using diagnostic_msgs::DiagnosticStatus;
    const bool unchecked = st.reason == vadop::GateState::REASON_STALE ||
                           st.reason == vadop::GateState::REASON_BAD_COMMAND;
    std::string summary = st.reason + ", scale " + std::to_string(st.scale);
    if (!st.rule.empty()) summary += ", rule " + st.rule;
    if (!st.limiting_body.empty()) {
      summary += ", limited by " + st.limiting_body + (st.limiting_link.empty() ? "" : "/" + st.limiting_link) +
                 " in " + std::to_string(st.time_to_contact) + " s (" + st.future + ")";
    }
    if (!st.detail.empty()) summary += ": " + st.detail;
    s.summary(unchecked ? DiagnosticStatus::WARN : DiagnosticStatus::OK, summary);
    const VelocityGate::Counts& c = g.counts();
    s.add("cmd_vel_in", g.params().cmd_vel_in);
    s.add("cmd_vel_out", g.params().cmd_vel_out);
    s.add("rule", st.rule);
    s.add("reaction_time", g.params().reaction_time);
    s.add("others_may_stop", g.params().others_may_stop ? "true" : "false");
    s.add("limiting future", st.future);
    s.add("commands", c.commands);
    s.add("clear", c.clear);
    s.add("slowed", c.slowed);
    s.add("stopped", c.stopped);
    s.add("not checked (zero sent)", c.unchecked);
    s.add("bad commands (zero sent)", c.bad);
    s.add("timeouts (zero sent)", c.timeouts);
  }

  // The last commands' latencies (ms) of one gate: median and 99th percentile.
  struct LatencyWindow {
    std::vector<double> ms;
    size_t next = 0;
    static constexpr size_t kSize = 1000;
    void add(double v) {
      if (!std::isfinite(v)) return;
      if (ms.size() < kSize) {
        ms.push_back(v);
      } else {
        ms[next] = v;
        next = (next + 1) % kSize;
      }
    }
    double percentile(double p) const {
      if (ms.empty()) return std::numeric_limits<double>::quiet_NaN();
      std::vector<double> v = ms;
      const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
      std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
      return v[k];
    }
  };

  // dynamic_reconfigure clamps to the ranges of cfg/Monitor.cfg, but NaN passes its min/max:
  // MonitorCore::reconfigure checks every value (the one place), keeps the previous value of a
  // refused one, and the kept values are written back into `c`, which the server stores and
  // publishes, so dynparam shows what is in effect.
  void onReconfigure(vadop::MonitorConfig& c) {
    std::lock_guard<std::mutex> lock(core_mutex_);
    RuntimeSettings requested;
    requested.horizon = c.horizon;
    requested.rate = c.rate;
    requested.padding = c.padding;
    std::vector<std::string> errors;
    const RuntimeSettings s = core_->reconfigure(requested, &errors);
    for (const std::string& e : errors) ROS_ERROR("vadop_monitor: dynamic_reconfigure: %s", e.c_str());
    c.horizon = s.horizon;
    c.rate = s.rate;
    c.padding = s.padding;
    if (s.rate != rate_) {
      rate_ = s.rate;
      window_.setRate(rate_);
      if (timer_.isValid()) timer_.setPeriod(ros::Duration(1.0 / rate_));
    }
    ROS_INFO("vadop_monitor: horizon %.2f s, rate %.1f Hz, padding %.3f m", s.horizon, s.rate, s.padding);
  }

  void onTimer() {
    std::unique_lock<std::mutex> lock(core_mutex_);  // released while the world predicts (below)
    const ros::Time now = ros::Time::now();
    if (now.isZero()) return;  // use_sim_time and no /clock yet
    if (!last_now_.isZero() && now < last_now_) {
      // int64 nanoseconds: a ros::Duration of two arbitrary times may be out of its range.
      ROS_WARN("vadop_monitor: time jumped back by %.3f s (bag restarted?): forgetting every state",
               secondsBetween(last_now_, now));
      core_->reset();
      tf_buffer_.clear();
    }
    last_now_ = now;
    // The cycle does not throw on any input; should it still, this cycle is lost, not the node.
    try {
      core_->startCycle(now, tf_source_);
      do {
        lock.unlock();  // callbacks and gates meanwhile: the prediction uses the cycle's own world
        core_->predictCycle();
        lock.lock();
      } while (core_->retryCycle(now));
      const vadop::ImpactArray& impacts = core_->finishCycle(now);
      window_.add(core_->lastStats());
      impacts_pub_.publish(impacts);
      if (core_->params().publish_markers && markers_pub_.getNumSubscribers() > 0) {
        visualization_msgs::MarkerArray markers = core_->markers();
        // Each gate's last checked command (its swept volume) and its decision, namespace "gate/<body>".
        for (const VelocityGate& g : gates_) {
          core_->appendCommandMarkers(g.lastCheck(), "gate/" + g.state().body, markers);
          core_->appendGateDecision(g.state(), g.body(), "gate/" + g.state().body, markers);
        }
        markers_pub_.publish(markers);
      }
      if (core_->params().log_impacts && !impacts.impacts.empty()) {
        std::string text;
        for (const vadop::Impact& i : impacts.impacts) text += "\n  " + MonitorCore::describe(i);
        ROS_INFO_THROTTLE(1.0, "vadop_monitor: %zu predicted impact(s):%s", impacts.impacts.size(), text.c_str());
      }
    } catch (const std::exception& e) {
      if (!lock.owns_lock()) lock.lock();  // thrown while the world predicted
      ROS_ERROR_THROTTLE(5.0, "vadop_monitor: cycle failed: %s", e.what());
    }
    // Gates whose commands stopped: one zero command each.
    for (size_t g = 0; g < gates_.size(); ++g) {
      geometry_msgs::Twist zero;
      if (gates_[g].onCycle(now, zero)) gate_pubs_[g].publish(zero);
    }
    publishGateStates(now);
    try {
      updater_.update();
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5.0, "vadop_monitor: diagnostics failed: %s", e.what());
    }
  }

  static ros::NodeHandle withQueue(ros::NodeHandle nh, ros::CallbackQueue* queue) {
    nh.setCallbackQueue(queue);
    return nh;
  }

  ros::NodeHandle nh_, pnh_;
  // tf's messages on a queue of their own and one spinner thread, which sleeps until a message
  // comes (or 0.1 s): tf2_ros's own listener thread wakes every 10 ms whether tf publishes or not,
  // 2% of the node's CPU samples at 1,000 robots in one array.
  ros::CallbackQueue tf_queue_;
  ros::NodeHandle tf_nh_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::AsyncSpinner tf_spinner_;  // after the listener: stopped before it goes
  Tf2Source tf_source_;
  std::unique_ptr<MonitorCore> core_;
  ros::Publisher impacts_pub_, markers_pub_;
  // Before subs_ and after core_: destroyed after the subscriptions, the spinner first.
  std::unique_ptr<ros::CallbackQueueInterface> ingest_queue_;
  std::unique_ptr<ros::AsyncSpinner> ingest_spinner_;
  ros::CallbackQueue sets_queue_;  // the body-set sources' (subscribeInputs)
  ros::NodeHandle sets_nh_;
  std::vector<ros::Subscriber> subs_;
  std::unique_ptr<ros::AsyncSpinner> sets_spinner_;  // after subs_: stopped before they go
  std::unordered_map<std::string, size_t> sub_of_topic_;  // a moving body's topic: its subscription in subs_
  ros::WallTimer silent_topics_timer_;
  ros::WallTimer reconnect_timer_;
  struct OdometrySub {
    size_t sub;   // index in subs_
    size_t body;
    int reconnects;
    std::chrono::steady_clock::time_point since;  // subscribed
  };
  std::vector<OdometrySub> odometry_subs_;
  static constexpr double kReconnectSeconds = 1.0;
  static constexpr size_t kReconnectBatch = 100;
  static constexpr int kMaxReconnects = 3;
  static constexpr double kReconnectAfter = 2.0;  // s without a publisher connected
  static constexpr double kReconnectWindow = 60.0;
  std::chrono::steady_clock::time_point reconnect_start_;
  std::vector<VelocityGate> gates_;
  std::vector<ros::Publisher> gate_pubs_;  // by gate: cmd_vel_out
  std::vector<LatencyWindow> gate_latency_;  // by gate
  std::mutex core_mutex_;
  ros::CallbackQueue gate_queue_;
  std::unique_ptr<ros::AsyncSpinner> gate_spinner_;
  ros::Publisher gate_states_pub_;
  diagnostic_updater::Updater updater_;
  CycleTimeWindow window_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<vadop::MonitorConfig>> reconfigure_;
  ros::Timer timer_;
  double rate_ = 30.0;
  ros::Time last_now_;
};

}  // namespace

std::unique_ptr<Monitor> startMonitor(ros::NodeHandle nh, ros::NodeHandle pnh) {
  const auto start = std::chrono::steady_clock::now();
  XmlRpc::XmlRpcValue root;
  if (!pnh.getParam(pnh.getNamespace(), root)) root = XmlRpc::XmlRpcValue();
  const MonitorParams params = parseParams(root);
  for (const std::string& warning : paramWarnings(params)) ROS_WARN("vadop_monitor: %s", warning.c_str());
  if (params.bodies.size() + params.static_obstacles.size() >= kProgressEvery) {
    ROS_INFO("vadop_monitor: parameters of %zu bodies and obstacles read in %.1f s; setting up",
             params.bodies.size() + params.static_obstacles.size(), secondsSince(start));
  }
  return std::make_unique<MonitorNode>(nh, pnh, params);
}

}  // namespace vadop_ros
