// One prediction cycle of vadop_monitor, without ROS transport: the body registry and the
// body-set sources (source.h's BodiesSource: tracked objects, ~tracks) feed the
// vadop::World (through Predictor, kept incrementally: elements are added when they first have
// a motion, setMotion'ed when their motion changes, removed while they are skipped; never
// rebuilt), the World predicts with the VADOP broad phase and the continuous narrow phase, and
// the impacts are filtered (static-static, self-collisions, ~ignore_pairs) and converted to
// the message.
// The node and the nodelet (monitor_node.cpp), the tests and the benchmark drive this class.
#pragma once

#include "vadop_ros/body_registry.h"
#include "vadop_ros/markers.h"
#include "vadop_ros/pair_filter.h"
#include "vadop_ros/params.h"
#include "vadop_ros/predictor.h"
#include "vadop_ros/sensor_filter.h"
#include "vadop_ros/source.h"
#include "vadop_ros/tracks.h"

// The message; this header must not pull in vadop/world.h (see predictor.h).
#include <vadop/ImpactArray.h>

#include <vadop/timed_path.h>
#include <vadop/world.h>

#include <ros/time.h>

#include <chrono>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace vadop_ros {

class SensorsSource;

struct CycleStats {
  ros::Time stamp;
  double cycle_seconds = 0.0;    // wall time of the whole cycle (registry + world + message)
  double registry_seconds = 0.0; // of which the registry's update and its copy into the world
  double predict_seconds = 0.0;  // of which World::predict (the rest: the ImpactArray)
  size_t elements_in_world = 0;
  size_t moving_elements = 0;    // of the bodies (registry)
  size_t tracked_objects = 0;    // of the body-set sources (~tracks), in the world
  size_t candidates = 0;         // candidate pairs after the filters (World::lastCandidateCount)
  size_t reused = 0;             // of which answered by certificates (~coherence_clearance)
  size_t slice_culled = 0;       // broad-phase pairs dropped before them (World::lastSliceCulledCount)
  size_t raw_impacts = 0;        // before filtering
  // Narrow-phase calls on pairs the filters (pairIgnored) then rejected: the raw impacts and
  // undecided pairs they reject. 0 by construction: the filters run before the narrow phase
  // (Predictor::setIgnored); diagnostics 'cycle' "ignored pairs tested".
  size_t ignored_tested = 0;
  size_t impacts = 0;            // published
  // Pairs (after filtering) the narrow phase could not decide within its budget: neither
  // published as impacts nor known to be clear after `undecided_first`'s time; a warning.
  size_t undecided = 0;
  std::string undecided_first;   // "a/link <-> b/link after 0.42 s" of the earliest one
  // World::predict threw and the cycle recovered by leaving out the elements named here (the
  // rest was predicted and published).
  std::string recovered;
  std::string error;             // predict failed this cycle, also after the retry (an empty array)
};

// The values dynamic_reconfigure may change at run time, with their ranges (the start-up
// ranges of params.cpp and those of cfg/Monitor.cfg).
struct RuntimeSettings {
  double horizon = 2.0;  // s, [0, kMaxHorizon]
  double rate = 30.0;    // Hz, [kMinRate, kMaxRate] (params.h)
  double padding = 0.0;  // m, [0, kMaxPadding]
};
constexpr double kMaxHorizon = 60.0;
constexpr double kMaxPadding = 10.0;

// A velocity gate's question (MonitorCore::checkCommand), twists in the body frame (REP 105's
// cmd_vel): the body goes on with the last forwarded command for reaction_time, then follows
// the command scaled by s for `hold`, then, with its decelerations given, brakes to standstill
// along the same arc; a scale is clear when that touches nothing until the body stands (with
// braking) or until the hold's end (without).
struct CommandQuestion {
  Eigen::Vector3d v = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();  // the command
  Eigen::Vector3d last_v = Eigen::Vector3d::Zero(), last_w = Eigen::Vector3d::Zero();  // the last forwarded
  double reaction_time = 0.0;  // s: from the check until the body executes the command
  double hold = 1.0;           // s: cmd_timeout with braking, time_before_collision without
  double linear_decel = 0.0, angular_decel = 0.0;  // m/s^2, rad/s^2: both > 0 for the braking model
  bool others_may_stop = false;  // also the future in which every other body brakes to standstill
  double state_timeout = 0.5;    // s
  bool braking() const { return linear_decel > 0.0 && angular_decel > 0.0; }
};

// What a moving body would touch if it followed a velocity command (MonitorCore::checkCommand):
// the scale of the command that a velocity gate may forward.
struct CommandCheck {
  enum class Status {
    kChecked,     // scale is set
    kNoState,     // no state yet, or the body has no geometry
    kStale,       // no message within the gate's state timeout
    kTfMissing,   // the body's pose or a link's transform is missing
    kNotInWorld,  // an element is not in the world yet (before the first cycle) or was refused
  };
  Status status = Status::kNoState;
  std::string why;  // for every status but kChecked
  vadop::GateScale scale;
  // The contact that limits the scale (not clear at scale 1): the element of the body and the
  // other element, and its time from `now` (s): at the scale just above `scale` when clear,
  // else at `scale` itself.
  bool limited = false;
  size_t element = 0, other = 0;
  double time_to_contact = std::numeric_limits<double>::infinity();
  bool undecided = false;  // that contact is a pair the narrow phase could not decide
  bool braking = false;          // the rule: braking to standstill (else the command held)
  bool others_stopping = false;  // that contact is in the future where the others brake
  double stop_duration = 0.0;    // s: the body's braking from the chosen command (0 without the model)
  // With a reaction time or braking: each element's manoeuvre at the chosen scale, to
  // standstill (markers); `window` then ends when the body stands. Empty: `motions` over it.
  std::vector<vadop::TimedPath> paths;
  // kChecked: the body's elements and their motions at the chosen scale over
  // [t0, t0 + window] (the registry's seconds), for the markers of the commanded sweep.
  std::vector<size_t> elements;
  std::vector<vadop::Motion> motions;
  double t0 = 0.0, window = 0.0;
};

class MonitorCore {
 public:
  // Throws ParamError naming the parameter when a predictor setting is out of range
  // (checkPredictorParams) or ~axes / ~phi_deg are rejected by the library.
  MonitorCore(const MonitorParams& params, const ParamReader& read_param,
              const MeshLoader& load_mesh = makeDefaultMeshLoader());

  BodyRegistry& registry() { return registry_; }
  const BodyRegistry& registry() const { return registry_; }
  // The body-set sources, one per kind of bodiesSourceKinds() (configured or not): the node
  // subscribes them and adds their diagnostics.
  const std::vector<std::unique_ptr<BodiesSource>>& bodiesSources() const { return body_sources_; }
  // The tracked objects (~tracks), the body-set source of kind "tracks": tests, the bench and
  // the fuzz target feed its arrays (Tracks::onArray).
  Tracks& tracks() { return *tracks_; }
  const Tracks& tracks() const { return *tracks_; }
  // Elements: the registry's (0 .. registry().elements().size() - 1), then the body-set
  // sources' slots interleaved: slot s of source j is element setElement(j, s). What one is, as
  // the filters and the impacts name it: a source body's name and link (a tracked object: the
  // body "<prefix>/<id>" without a link).
  ElementKey elementKey(size_t element) const;
  // The same, written into the given strings (the ImpactArray's, whose storage is kept).
  void elementNames(size_t element, std::string& body, std::string& link) const;
  const MonitorParams& params() const { return params_; }

  // Runs one cycle at `now` and returns the impacts (header stamped `now`, in the fixed frame):
  // the phases below, one after the other, on one thread.
  const vadop::ImpactArray& cycle(const ros::Time& now, TransformSource& tf);

  // The same cycle in phases, for a caller that shares the core between threads under a lock
  // of its own (the node: its callbacks and the gates' thread), so that nothing waits for a
  // prediction: the gates answer from their own copy of the world (checkCommand), synced at
  // the end of every cycle, and may do so while the cycle's world predicts. Every call into
  // the core holds the caller's lock, but for predictCycle():
  //   lock;   startCycle(now, tf);
  //   do { unlock; predictCycle(); lock; } while (retryCycle(now));
  //   const ImpactArray& impacts = finishCycle(now);  // still locked
  // startCycle reads the inputs (registry, tracks) into the cycle's world; predictCycle touches
  // the cycle's world and this cycle's result only, nothing a callback or a gate uses;
  // retryCycle, after a failed prediction, leaves out the elements the world refused and says
  // whether to predict once more; finishCycle writes the impacts and syncs the gates' world.
  // Between startCycle and finishCycle the other calls may come, with these effects: the gates
  // answer from their world of the last cycle's end (checkCommand does not read the predicting
  // world), a new padding (reconfigure) takes effect at the next cycle's start, and the
  // impacts are clamped to the horizon the world predicted over. Not reset() (the caller's
  // cycle thread calls it between cycles).
  void startCycle(const ros::Time& now, TransformSource& tf);
  void predictCycle();
  bool retryCycle(const ros::Time& now);
  const vadop::ImpactArray& finishCycle(const ros::Time& now);
  const vadop::ImpactArray& lastImpacts() const { return impacts_; }
  const CycleStats& lastStats() const { return stats_; }

  // Soonest time to impact of each body (index into registry().bodies()) in the last cycle;
  // +inf when none (body-set sources' bodies: not here).
  const std::vector<double>& soonest() const { return soonest_; }

  // Markers of the last cycle (swept volumes, impacts); see markers.h.
  visualization_msgs::MarkerArray markers() const;
  // A gate forwarded the checked command: until the body's next cycle its elements move in the
  // world as commanded (check.motions), so that the other gates' checks count with what this
  // body was just told to do, not with its last reported state (two gated robots starting
  // towards each other between two odometry messages would otherwise each see the other
  // standing). Nothing for a check that is not kChecked.
  void adoptCommand(const CommandCheck& check);
  // Markers of a gate's last checked command (CommandCheck::kChecked): the body's swept volume
  // under the gated command over the gate's window, in namespace `ns`, coloured by the limiting
  // contact's time (markers.h's rule); no DELETEALL (appended to markers()'s array).
  // A gate's decision (markers.h's gateDecisionMarker) in namespace `ns`, above the top of
  // `body` (index into registry().bodies()) as it stands in the last cycle's world; nothing
  // when none of its elements is in that world (not monitored yet).
  void appendGateDecision(const vadop::GateState& state, size_t body, const std::string& ns,
                          visualization_msgs::MarkerArray& out) const;
  void appendCommandMarkers(const CommandCheck& check, const std::string& ns,
                            visualization_msgs::MarkerArray& out) const;

  // dynamic_reconfigure: the one place its values are checked (the node's callback and the
  // fuzz target call it). Each value NaN/Inf or outside its range is refused: the current
  // value is kept and a line naming the parameter is appended to `errors`. Returns the values
  // in effect afterwards (the node writes them back into the config it publishes). A new
  // padding re-adds every element with its new shape at the next cycle. The rate is only
  // stored (params().rate): the node sets its timer from the returned value.
  RuntimeSettings reconfigure(const RuntimeSettings& requested, std::vector<std::string>* errors = nullptr);
  RuntimeSettings settings() const;
  // Single values through the same checks; false (value kept) when refused.
  bool setHorizon(double horizon);
  bool setPadding(double padding);
  double horizon() const { return params_.horizon; }
  double padding() const { return params_.padding; }

  // A velocity gate's question: body `body` (index into registry().bodies(), a moving body)
  // driven from `now` by the twist (v, w) (its body frame: REP 105's cmd_vel) held constant in
  // its frame, from its latest state carried to now, scaled by s in [0, 1] (both parts, so the
  // arc keeps its curvature), against every other element's predicted motion over
  // [now, now + window], with the node's padding and pair rules; `skip` (may be empty) leaves
  // out more elements. Returns the largest clear s on vadop::searchGateScale's 0.02 grid, or
  // the s of the latest first contact when none is clear. Refreshes the body's element motions
  // from its latest state (BodyRegistry::updateBody) and leaves the world as it was. The state
  // is stale when no message arrived within `state_timeout` (s). Never throws on bad state:
  // a status says why it could not check.
  CommandCheck checkCommand(size_t body, const Eigen::Vector3d& v, const Eigen::Vector3d& w, const ros::Time& now,
                            TransformSource& tf, double window, double state_timeout,
                            const std::function<bool(size_t element)>& skip = {});
  // The question with a reaction time, the last forwarded command, a braking model and the
  // others' braking (CommandQuestion): the same contract. With no reaction time, no braking and
  // others as predicted it is the call above with window = question.hold.
  CommandCheck checkCommand(size_t body, const CommandQuestion& question, const ros::Time& now, TransformSource& tf,
                            const std::function<bool(size_t element)>& skip = {});

  // Time jumped backwards: forget every state (and the world's moving elements).
  void reset();

  Predictor& predictorForTesting() { return predictor_; }

  // One line per impact: "robot_1 <-> robot_2/mast in 0.83 s at (x, y, z), closing 1.2 m/s".
  static std::string describe(const vadop::Impact& impact);

 private:
  // The one definition of the pairs never reported (static-static, links of one body rigid
  // with each other, self-collision rules, adjacent links, ~ignore_pairs). Both worlds call it
  // before the narrow phase, with the elements' indices (Predictor::setIgnored): the cycle's
  // predict and the gates' queries (a gate's own ignore list is its query's skip, matched by
  // the same matchingGlobs as ~ignore_pairs); static elements also get a group of their
  // own that does not collide with itself (kStaticGroup), which leaves static-static pairs out
  // before even this call. Asked only while it can ignore a pair the groups do not
  // (pair_rules_needed_: ~ignore_pairs set, or some body with two elements in the world).
  bool pairIgnored(size_t ea, size_t eb) const;
  bool pair_rules_needed_ = true;
  std::vector<uint8_t> elements_in_world_of_body_;  // syncWorld's count (saturated at 2)
  static constexpr uint32_t kMovingGroup = 1u;
  static constexpr uint32_t kStaticGroup = 2u;
  void syncWorld(const ros::Time& now);
  // Each body's place against ~region at now (kInside everywhere without a region): outside the
  // region grown by its margin a body is left out of the world (not a static obstacle, not a
  // gated body); only pairs with a body inside are reported.
  enum Place : uint8_t { kInside, kMargin, kOutside };
  void placeInRegion(const ros::Time& now);
  std::vector<uint8_t> body_place_;
  // One entry of the ImpactArray from the world's impact (thread-safe: reads only).
  void writeImpact(const vadop::Contact& hit, const ros::Time& now, vadop::Impact& msg) const;
  // World::predict threw `error`: leaves out of the world every element whose motion is out of
  // range over the window or that the message names; false when none could be found.
  bool leaveOutOffenders(const std::string& error, const ros::Time& now);
  // The body-set sources' bodies into the world: those whose input timed out leave, the others
  // enter or move with their motion.
  void syncSourcedBodies(const ros::Time& now);
  // Source j's bodies, one after the other (syncSourcedBodies); the number in the world.
  size_t syncSourcedBodies(size_t j, double t_now, const ros::Time& now);
  // The one mapping between a body-set source's slot and its world element: the sources'
  // slots interleaved after the registry's elements (one source: base + slot), so that each
  // source's slots grow without moving another's elements. k = element - setBase() indexes the
  // per-element vectors below.
  size_t setBase() const { return registry_.elements().size(); }
  bool isSourced(size_t element) const { return element >= setBase(); }
  size_t setElement(size_t source, size_t slot) const { return setBase() + slot * body_sources_.size() + source; }
  const SourcedBody& sourcedBody(size_t element) const {
    const size_t k = element - setBase(), n = body_sources_.size();
    return body_sources_[k % n]->bodies().at(k / n);
  }
  // A source body's element leaves both worlds.
  void unsetSourced(size_t element);

  MonitorParams params_;
  BodyRegistry registry_;
  PairFilter filter_;
  std::vector<PairFilter::Matches> element_matches_;  // ~ignore_pairs per element (elements())
  std::vector<std::unique_ptr<BodiesSource>> body_sources_;
  Tracks* tracks_ = nullptr;  // the one of kind "tracks" in body_sources_
  SensorsSource* sensors_ = nullptr;  // the one of kind "sensors" (told the padding)
  // Per source body's element (k = element - setBase()): its body's name in the worlds (""
  // when out), its ~ignore_pairs matches, its soonest time to impact in the last cycle.
  std::vector<std::string> sourced_in_world_;
  std::vector<PairFilter::Matches> sourced_matches_;
  std::vector<double> sourced_soonest_;
  // The shape_version each source body's element entered the world with: a newer one re-enters.
  std::vector<uint64_t> sourced_shape_version_;
  Predictor predictor_;
  // The gates' world: every element of predictor_ with the same shape and motion as at the
  // end of the last cycle (syncGateWorld), and the gated commands adopted since.
  Predictor gate_predictor_;
  void syncGateWorld();
  // How long the element's body takes to brake to standstill from its state (its decelerations;
  // 0, at once, without them and for tracked objects): the gates' others_may_stop future.
  double stopDuration(size_t element) const;
  // Synced at the end of every cycle once a body has a gate configured or a command was
  // checked; before that, by the first checkCommand after a cycle (on the caller's thread:
  // a checking thread needs a configured gate, as the node's has).
  bool gate_world_wanted_ = false;
  bool gate_world_current_ = false;  // gate_predictor_ reflects the last cycle's end
  // The cycle's phases (startCycle .. finishCycle): between them the world predicts
  // (predicting_), over cycle_horizon_ from t0_; raw_impacts_ is its answer.
  std::chrono::steady_clock::time_point cycle_start_, predict_start_;
  double cycle_horizon_ = 0.0;
  int predict_attempts_ = 0;
  bool predicting_ = false;
  bool worlds_stale_ = false;  // a new padding came while predicting: clear both worlds at the next start
  std::vector<vadop::Contact> raw_impacts_;
  // The body can be checked: a moving body with a fresh state and its elements in the gates'
  // world; false, with out's status and why, when not.
  bool commandCheckable(size_t body, const ros::Time& now, double state_timeout, CommandCheck& out) const;
  // A check's start: the gates' world synced, the body checkable and its state carried to now;
  // false, with out's status and why, when not.
  bool prepareCheck(size_t body, const ros::Time& now, TransformSource& tf, double state_timeout, CommandCheck& out);
  // The limiting contact (none: null) into out.
  static void noteLimit(const vadop::World::MoverContact* limit, double t_now, CommandCheck& out);
  void logPredictionOutcome();  // the recovered / failed lines (throttled)
  // What the sensors' points are filtered against (sensor_filter.h), made at most once a cycle
  // when a sensor asks (under the node's lock); cycles_ counts the cycles started.
  std::shared_ptr<const FilterSnapshot> filterSnapshot();
  std::shared_ptr<const FilterSnapshot> filter_snapshot_;
  FilterCache filter_cache_;
  uint64_t cycles_ = 0, filter_snapshot_cycle_ = 0;
  // The kept impacts (pair rules) into impacts_, and each body's soonest time to impact.
  void writeImpacts(const ros::Time& now);
  // Counts the undecided pairs the rules keep and names the first (stats_), with its warning.
  void noteUndecided();
  vadop::ImpactArray impacts_;
  CycleStats stats_;
  std::vector<double> soonest_;
  std::vector<uint32_t> kept_impacts_;  // cycle's scratch: the world's impacts the pair rules keep
  double t0_ = 0.0;  // registry seconds of the last cycle
  // Elements the world refused at predict, kept out while their motion stays the same.
  std::vector<char> refused_;
  std::vector<vadop::Motion> refused_motion_;
  double last_error_log_ = -1e300;  // wall seconds
  double last_undecided_log_ = -1e300;  // wall seconds
};

}  // namespace vadop_ros
