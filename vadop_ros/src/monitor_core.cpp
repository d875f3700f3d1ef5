#include "vadop_ros/monitor_core.h"

#include "vadop_ros/sensors_source.h"

#include "gate_manoeuvre.h"
#include "scale_contacts.h"

#include <vadop/error.h>
#include <vadop/world.h>

#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace vadop_ros {
namespace {

PredictorConfig predictorConfig(const MonitorParams& p) {
  PredictorConfig c;
  c.axes = p.axes;
  c.phi_deg = p.phi_deg;
  c.threads = p.threads;
  c.broad_phase = p.broad_phase;
  c.time_slices = p.time_slices;
  c.coherence_clearance = p.coherence_clearance;
  c.coherence_lookahead = p.coherence_lookahead;
  return c;
}

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

Predictor makePredictor(const MonitorParams& p, bool queries_only = false) {
  checkPredictorParams(p);  // params built in code name the parameter as parsed ones do
  try {
    PredictorConfig c = predictorConfig(p);
    c.queries_only = queries_only;
    if (queries_only) {
      c.threads = 1;  // the gates' world answers queries, never predicts
      c.coherence_clearance = 0.0;
    }
    return Predictor(c);
  } catch (const vadop::InvalidArgument& e) {
    throw ParamError(std::string("~axes / ~phi_deg: rejected by the VADOP broad phase: ") + e.what());
  }
}

// Throttle of the cycle's own error lines (wall clock: ROS_*_THROTTLE needs ros::Time::now(),
// which tests and the fuzz target do not initialise).
bool throttleOk(double& last) {
  const double now = ros::WallTime::now().toSec();
  if (now - last < 5.0) return false;
  last = now;
  return true;
}

// "" when v is finite and in [lo, hi], else the error line for parameter `name`.
std::string rangeCheck(const char* name, double v, double lo, double hi, double kept, const char* unit) {
  if (std::isfinite(v) && v >= lo && v <= hi) return "";
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s = %g refused (must be finite and in [%g, %g] %s); keeping %g %s", name, v, lo, hi,
                unit, kept, unit);
  return buf;
}

// "" when a padding keeps every gated body's padding above the sensors' self_margin (the
// start-up rule, checkSelfMargins), else the error line: lowered at run time it would let a
// gate take a wall for its own body.
std::string selfMarginCheck(const MonitorParams& params, double padding) {
  MonitorParams p = params;
  p.padding = padding;
  try {
    checkSelfMargins(p);
  } catch (const ParamError& e) {
    return "padding = " + std::to_string(padding) + " refused (" + e.what() + "); keeping " +
           std::to_string(params.padding) + " m";
  }
  return "";
}

}  // namespace

MonitorCore::MonitorCore(const MonitorParams& params, const ParamReader& read_param, const MeshLoader& load_mesh)
    : params_(params),
      registry_(params, read_param, load_mesh),
      filter_(params.ignore_pairs),
      predictor_(makePredictor(params)),
      gate_predictor_(makePredictor(params, true)) {
  soonest_.assign(registry_.bodies().size(), std::numeric_limits<double>::infinity());
  for (const BodiesSourceKind& kind : bodiesSourceKinds()) {
    body_sources_.push_back(kind.make(params));
    if (auto* tracks = dynamic_cast<Tracks*>(body_sources_.back().get())) tracks_ = tracks;
    if (auto* sensors = dynamic_cast<SensorsSource*>(body_sources_.back().get())) {
      sensors->setFilterProvider([this] { return filterSnapshot(); });
      sensors->setPadding(params.padding);
      sensors_ = sensors;
    }
  }
  for (const BodyParams& b : params.bodies) gate_world_wanted_ = gate_world_wanted_ || b.has_gate;
  impacts_.header.frame_id = params_.fixed_frame;
  registry_.setMaxStampSkew(params.max_stamp_skew);
  registry_.setThreads(params.threads);
  refused_.assign(registry_.elements().size(), 0);
  refused_motion_.resize(registry_.elements().size());
  // ~ignore_pairs matched once per element (the elements are fixed), not per candidate pair.
  if (!filter_.empty()) {
    for (const Element& e : registry_.elements()) {
      element_matches_.push_back(filter_.matches({registry_.bodies()[e.body].name, e.link}));
    }
  }
  // `this` in the world: MonitorCore is neither copyable nor movable (Predictor is neither).
  predictor_.setIgnored([this](size_t a, size_t b) { return pairIgnored(a, b); });
  gate_predictor_.setIgnored([this](size_t a, size_t b) { return pairIgnored(a, b); });
}

ElementKey MonitorCore::elementKey(size_t element) const {
  ElementKey key;
  elementNames(element, key.body, key.link);
  return key;
}

void MonitorCore::elementNames(size_t element, std::string& body, std::string& link) const {
  if (isSourced(element)) {
    const SourcedBody& sb = sourcedBody(element);
    body = sb.name;
    link = sb.link;
    return;
  }
  const Element& e = registry_.elements().at(element);
  body = registry_.bodies()[e.body].name;
  link = e.link;
}

void MonitorCore::writeImpact(const vadop::Contact& hit, const ros::Time& now, vadop::Impact& msg) const {
  elementNames(hit.a_user, msg.body_a, msg.link_a);
  elementNames(hit.b_user, msg.body_b, msg.link_b);
  // In [0, horizon] (the one the world predicted over): t0 + horizon - t0 may differ from the
  // horizon by a rounding.
  msg.time_to_impact = std::min(cycle_horizon_, std::max(0.0, hit.impact.time - t0_));
  msg.time_of_impact = addSeconds(now, msg.time_to_impact);  // saturates: now may be near 2^32 s
  msg.point.x = hit.impact.point.x();
  msg.point.y = hit.impact.point.y();
  msg.point.z = hit.impact.point.z();
  msg.normal.x = hit.impact.normal.x();
  msg.normal.y = hit.impact.normal.y();
  msg.normal.z = hit.impact.normal.z();
  msg.closing_speed = hit.closing_speed;
  msg.in_contact = hit.impact.initially_touching;
}

void MonitorCore::syncGateWorld() {
  const auto& elements = registry_.elements();
  std::string error;
  const size_t total = setBase() + sourced_in_world_.size();
  for (size_t i = 0; i < total; ++i) {
    if (!predictor_.contains(i)) {
      gate_predictor_.unset(i);
      continue;
    }
    const bool is_static = !isSourced(i) && registry_.bodies()[elements[i].body].is_static;
    const std::string& id = isSourced(i) ? sourced_in_world_[i - setBase()] : elements[i].id;
    // The shape as the cycle's world prepared it (padded; a point set's tree shared, not built
    // again): read only when the element enters.
    const uint32_t group = is_static ? kStaticGroup : kMovingGroup, mask = is_static ? ~kStaticGroup : ~0u;
    const bool ok = gate_predictor_.contains(i)
                        ? gate_predictor_.set(i, id, predictor_.shape(i), predictor_.motion(i), error, group, mask,
                                              predictor_.chain(i))
                        : gate_predictor_.set(i, id, predictor_.prepared(i), predictor_.motion(i), error, group, mask,
                                              predictor_.chain(i));
    if (!ok) {
      gate_predictor_.unset(i);  // the cycle's world took it: cannot happen but for memory
      continue;
    }
    gate_predictor_.setStopDuration(i, stopDuration(i));
  }
  gate_predictor_.enableIgnored(pair_rules_needed_);
  gate_world_current_ = true;
}

double MonitorCore::stopDuration(size_t element) const {
  if (isSourced(element)) return 0.0;  // tracked objects: at once
  const Body& b = registry_.bodies()[registry_.elements()[element].body];
  if (b.is_static || !b.params.hasBraking()) return 0.0;
  const FrameMotion& fm = b.frame_motion;
  return std::max(fm.v.norm() / b.params.max_linear_decel, fm.w.norm() / b.params.max_angular_decel);
}

RuntimeSettings MonitorCore::settings() const {
  RuntimeSettings s;
  s.horizon = params_.horizon;
  s.rate = params_.rate;
  s.padding = params_.padding;
  return s;
}

RuntimeSettings MonitorCore::reconfigure(const RuntimeSettings& requested, std::vector<std::string>* errors) {
  const auto refuse = [&](const std::string& e) {
    if (e.empty()) return false;
    if (errors) errors->push_back(e);
    return true;
  };
  if (!refuse(rangeCheck("horizon", requested.horizon, 0.0, kMaxHorizon, params_.horizon, "s"))) {
    params_.horizon = requested.horizon;
  }
  if (!refuse(rangeCheck("rate", requested.rate, kMinRate, kMaxRate, params_.rate, "Hz"))) {
    params_.rate = requested.rate;
  }
  if (!refuse(rangeCheck("padding", requested.padding, 0.0, kMaxPadding, params_.padding, "m")) &&
      !refuse(selfMarginCheck(params_, requested.padding)) && requested.padding != params_.padding) {
    params_.padding = requested.padding;
    if (sensors_) sensors_->setPadding(params_.padding);
    // Shapes change: every element leaves the world and comes back, padded anew, at the next
    // cycle (World has no setShape). Not under a predicting world's feet: then at the next
    // cycle's start.
    if (predicting_) {
      worlds_stale_ = true;
    } else {
      predictor_.clear();
      gate_predictor_.clear();
    }
  }
  return settings();
}

bool MonitorCore::setHorizon(double horizon) {
  RuntimeSettings s = settings();
  s.horizon = horizon;
  std::vector<std::string> errors;
  reconfigure(s, &errors);
  return errors.empty();
}

bool MonitorCore::setPadding(double padding) {
  RuntimeSettings s = settings();
  s.padding = padding;
  std::vector<std::string> errors;
  reconfigure(s, &errors);
  return errors.empty();
}

namespace {

// One element of a gated body at the check's start: where it is, what it does on its own and
// what the command adds.
struct CommandedElement {
  size_t element = 0;
  Eigen::Isometry3d pose;
  Eigen::Vector3d own_v, own_w;  // relative to the body frame (links moving on tf), fixed frame
  Eigen::Vector3d cmd_v, cmd_w;  // the element origin's velocity and its turn under the command
};

// The gated body's elements under the command scaled by s (CommandCheck's question): their
// motions at a scale, their first contact in the gates' world, and the contacts each scale
// met, to name what limits the chosen scale afterwards.
class CommandedSweep {
 public:
  CommandedSweep(Predictor& world, double t_now, double window, const std::function<bool(size_t element)>& skip)
      : world_(world), t_now_(t_now), window_(window), skip_(skip) {}

  void add(const CommandedElement& part) {
    movers_.push_back(part.element);
    parts_.push_back(part);
  }

  // Every element's motion at scale s (both parts of the twist, so an arc keeps its curvature).
  const std::vector<vadop::Motion>& motionsAt(double s) {
    motions_.resize(movers_.size());
    for (size_t k = 0; k < parts_.size(); ++k) {
      motions_[k] = twistMotion(parts_[k].pose, parts_[k].own_v + s * parts_[k].cmd_v,
                                parts_[k].own_w + s * parts_[k].cmd_w, t_now_);
    }
    return motions_;
  }

  // The time of the first contact at scale s (+inf when clear over the window).
  double firstContactAt(double s) {
    motionsAt(s);
    return seen_.note(s, world_.firstContact(movers_, motions_, t_now_, window_, skip_));
  }

  // The largest clear scale on searchGateScale's grid. One candidate query for all the scales
  // (beginReach): under a constant twist an origin keeps its speed, |own_v + s cmd_v|, largest
  // at s = 0 or 1. Throws vadop::InvalidArgument on a motion out of the library's range.
  vadop::GateScale search() {
    std::vector<Eigen::Vector3d> origins;
    std::vector<double> reach;
    for (const CommandedElement& m : parts_) {
      origins.push_back(m.pose.translation());
      reach.push_back(window_ * std::max(m.own_v.norm(), (m.own_v + m.cmd_v).norm()));
    }
    const Predictor::ReachScope reach_scope(world_, movers_, origins, reach, t_now_, window_);
    return vadop::searchGateScale([this](double s) { return firstContactAt(s); });
  }

  // The contact that limits `scale` (ScaleContacts::limit).
  const vadop::World::MoverContact* limit(const vadop::GateScale& scale) const { return seen_.limit(scale); }

  const std::vector<size_t>& movers() const { return movers_; }

 private:
  Predictor& world_;
  const double t_now_, window_;
  const std::function<bool(size_t element)>& skip_;
  std::vector<size_t> movers_;
  std::vector<CommandedElement> parts_;
  std::vector<vadop::Motion> motions_;
  ScaleContacts seen_;
};

// The gated body's elements at t_now under the body-frame command (v, w) (the command's
// share zero when not wanted), and the body frame's pose; false (out says why) when one is not
// in the gates' world.
bool commandedElements(const BodyRegistry& registry, const Predictor& gate_world, const Body& b,
                       const Eigen::Vector3d& v, const Eigen::Vector3d& w, double t_now,
                       std::vector<CommandedElement>& parts, Eigen::Isometry3d& pose, CommandCheck& out) {
  const FrameMotion& fm = b.frame_motion;
  const vadop::Motion& frame = fm.motion;
  pose = frame.poseAt(t_now);
  const Eigen::Vector3d frame_v = frame.velocityOfPoint(pose.translation(), t_now);
  // The command in the fixed frame.
  const Eigen::Vector3d cv = pose.linear() * v, cw = pose.linear() * w;
  for (size_t ei : b.elements) {
    const Element& e = registry.elements()[ei];
    if (!e.active || !gate_world.contains(ei)) {
      out.status = CommandCheck::Status::kNotInWorld;
      out.why = "element \"" + e.id + "\" is not in the world";
      return false;
    }
    CommandedElement m;
    m.element = ei;
    m.pose = e.motion.poseAt(t_now);
    const Eigen::Vector3d r = m.pose.translation() - pose.translation();
    // The element's own velocity, less the body frame's rigid share, is what tf says its joints
    // do: it keeps that under any command.
    m.own_v = e.motion.velocityOfPoint(m.pose.translation(), t_now) - (frame_v + fm.w.cross(r));
    m.own_w = e.motion.angular_velocity - fm.w;
    m.cmd_v = cv + cw.cross(r);
    m.cmd_w = cw;
    parts.push_back(m);
  }
  return true;
}

}  // namespace

bool MonitorCore::commandCheckable(size_t body, const ros::Time& now, double state_timeout, CommandCheck& out) const {
  using Status = CommandCheck::Status;
  const auto& bodies = registry_.bodies();
  if (body >= bodies.size() || bodies[body].is_static) {
    out.why = "not a moving body";
    return false;
  }
  const Body& b = bodies[body];
  if (!b.has_state || b.elements.empty()) {
    out.why = b.elements.empty() ? "no geometry" : "no state received yet";
    return false;
  }
  if (!receiptFresh(b.status.last_receipt, now, state_timeout)) {
    const double age = secondsBetween(now, b.status.last_receipt);
    out.status = Status::kStale;
    out.why = age >= 0.0 ? "no state for " + std::to_string(age) + " s"
                         : "the last state was received " + std::to_string(-age) + " s after the node's clock (it went back)";
    return false;
  }
  for (size_t ei : b.elements) {
    if (!gate_predictor_.contains(ei)) {
      out.status = Status::kNotInWorld;
      out.why = "element \"" + registry_.elements()[ei].id + "\" is not in the world (no cycle since it had a state)";
      return false;
    }
  }
  return true;
}

bool MonitorCore::prepareCheck(size_t body, const ros::Time& now, TransformSource& tf, double state_timeout,
                               CommandCheck& out) {
  using Status = CommandCheck::Status;
  gate_world_wanted_ = true;
  // Mid-prediction the cycle's world is not to be read: the gates keep the world they have.
  if (!gate_world_current_ && !predicting_) syncGateWorld();
  // The body's latest state, also when it came after the last cycle (its callback posts it
  // without the node's lock: Source::collect).
  if (body < registry_.bodies().size()) registry_.collect(body);
  if (!commandCheckable(body, now, state_timeout, out)) return false;
  const Body& b = registry_.bodies()[body];
  if (!registry_.updateBody(body, now, tf)) {
    out.status = b.status.state == BodyState::kTfMissing ? Status::kTfMissing : Status::kNoState;
    out.why = b.status.tf_error.empty() ? toString(b.status.state) : b.status.tf_error;
    return false;
  }
  return true;
}

CommandCheck MonitorCore::checkCommand(size_t body, const Eigen::Vector3d& v, const Eigen::Vector3d& w,
                                       const ros::Time& now, TransformSource& tf, double window, double state_timeout,
                                       const std::function<bool(size_t element)>& skip) {
  CommandCheck out;
  if (!prepareCheck(body, now, tf, state_timeout, out)) return out;
  const double t_now = registry_.seconds(now);
  CommandedSweep sweep(gate_predictor_, t_now, window, skip);
  std::vector<CommandedElement> parts;
  Eigen::Isometry3d pose;
  if (!commandedElements(registry_, gate_predictor_, registry_.bodies()[body], v, w, t_now, parts, pose, out)) return out;
  for (const CommandedElement& part : parts) sweep.add(part);
  try {
    out.scale = sweep.search();
  } catch (const vadop::InvalidArgument& e) {
    // A commanded motion out of the library's range (a twist far beyond any robot's).
    out.status = CommandCheck::Status::kNotInWorld;
    out.why = std::string("the commanded motion was refused: ") + e.what();
    return out;
  }
  out.status = CommandCheck::Status::kChecked;
  out.motions = sweep.motionsAt(out.scale.scale);  // the motions at the chosen scale, for the markers
  out.elements = sweep.movers();
  out.t0 = t_now;
  out.window = window;
  noteLimit(sweep.limit(out.scale), t_now, out);
  return out;
}

CommandCheck MonitorCore::checkCommand(size_t body, const CommandQuestion& question, const ros::Time& now,
                                       TransformSource& tf, const std::function<bool(size_t element)>& skip) {
  if (question.reaction_time == 0.0 && !question.braking() && !question.others_may_stop) {
    return checkCommand(body, question.v, question.w, now, tf, question.hold, question.state_timeout, skip);
  }
  CommandCheck out;
  if (!prepareCheck(body, now, tf, question.state_timeout, out)) return out;
  const double t_now = registry_.seconds(now);
  std::vector<CommandedElement> parts;
  Eigen::Isometry3d pose;
  // The command's share is the manoeuvre's own (it changes along the stages).
  if (!commandedElements(registry_, gate_predictor_, registry_.bodies()[body], Eigen::Vector3d::Zero(),
                         Eigen::Vector3d::Zero(), t_now, parts, pose, out)) {
    return out;
  }
  GateManoeuvre manoeuvre(gate_predictor_, pose, question, t_now, skip);
  for (const CommandedElement& part : parts) {
    manoeuvre.add(part.element, part.pose, part.own_v, part.own_w, gate_predictor_.shape(part.element).bounding_radius);
  }
  try {
    out.scale = manoeuvre.search();
    out.paths = manoeuvre.pathsAt(out.scale.scale);
    out.motions = manoeuvre.motionsAt(out.scale.scale);
  } catch (const vadop::InvalidArgument& e) {
    out.status = CommandCheck::Status::kNotInWorld;
    out.why = std::string("the commanded motion was refused: ") + e.what();
    return out;
  }
  out.status = CommandCheck::Status::kChecked;
  out.elements = manoeuvre.movers();
  out.t0 = t_now;
  out.window = manoeuvre.endAt(out.scale.scale) - t_now;
  out.braking = question.braking();
  out.stop_duration = manoeuvre.brakingDuration(out.scale.scale);
  noteLimit(manoeuvre.limit(out.scale), t_now, out);
  return out;
}

void MonitorCore::noteLimit(const vadop::World::MoverContact* limit, double t_now, CommandCheck& out) {
  if (!limit) return;
  out.limited = true;
  out.element = out.elements[limit->mover];  // the query's movers are out.elements
  out.other = limit->other_user;
  out.time_to_contact = limit->impact.time - t_now;
  out.undecided = limit->undecided;
  out.others_stopping = limit->others_stopping;
}

void MonitorCore::reset() {
  registry_.reset();
  ++cycles_;
  const auto& elements = registry_.elements();
  for (size_t i = 0; i < elements.size(); ++i) {
    if (!registry_.bodies()[elements[i].body].is_static) {
      predictor_.unset(i);
      gate_predictor_.unset(i);
      refused_[i] = 0;
    }
  }
  std::vector<size_t> left;
  for (size_t j = 0; j < body_sources_.size(); ++j) {
    left.clear();
    body_sources_[j]->clear(left);
    for (const size_t slot : left) unsetSourced(setElement(j, slot));
  }
  std::fill(soonest_.begin(), soonest_.end(), std::numeric_limits<double>::infinity());
  std::fill(sourced_soonest_.begin(), sourced_soonest_.end(), std::numeric_limits<double>::infinity());
}

void MonitorCore::unsetSourced(size_t element) {
  predictor_.unset(element);
  gate_predictor_.unset(element);
  const size_t k = element - setBase();
  if (k < sourced_in_world_.size()) sourced_in_world_[k].clear();
}

void MonitorCore::syncSourcedBodies(const ros::Time& now) {
  const double t_now = registry_.seconds(now);
  size_t in_world = 0;
  for (size_t j = 0; j < body_sources_.size(); ++j) in_world += syncSourcedBodies(j, t_now, now);
  stats_.tracked_objects = in_world;
}

size_t MonitorCore::syncSourcedBodies(size_t j, double t_now, const ros::Time& now) {
  BodiesSource& source = *body_sources_[j];
  std::vector<size_t> left;
  source.expire(now, left);
  for (const size_t slot : left) unsetSourced(setElement(j, slot));
  const auto& slots = source.bodies();
  // The per-element vectors reach this source's last slot.
  const size_t needed = slots.empty() ? 0 : setElement(j, slots.size() - 1) - setBase() + 1;
  if (sourced_in_world_.size() < needed) {
    sourced_in_world_.resize(needed);
    sourced_matches_.resize(needed);
    sourced_soonest_.resize(needed, std::numeric_limits<double>::infinity());
    sourced_shape_version_.resize(needed, 0);
  }
  std::string error;
  size_t in_world = 0;
  for (size_t s = 0; s < slots.size(); ++s) {
    const SourcedBody& t = slots[s];
    if (!t.alive) continue;
    const size_t element = setElement(j, s), k = element - setBase();
    // A slot's new body: the old one (if any) leaves first.
    if (!sourced_in_world_[k].empty() && sourced_in_world_[k] != t.name) unsetSourced(element);
    // A new shape (a sensor's new points): the world keeps an element's shape from its entry, so
    // it re-enters (both worlds; the gates' at the cycle's end).
    if (predictor_.contains(element) && sourced_shape_version_[k] != t.shape_version) unsetSourced(element);
    std::string why;
    vadop::Motion m;
    try {
      m = twistMotion(t.pose, t.v, t.w, registry_.seconds(t.stamp));
      why = BodyRegistry::motionRangeError(m, t_now, t_now + BodyRegistry::kMotionCheckWindow);
    } catch (const vadop::InvalidArgument& e) {
      why = e.what();
    }
    if (why.empty()) {
      const bool fresh = !predictor_.contains(element);
      bool ok = false;
      if (fresh && t.prepared && t.prepared_padding == params_.padding) {  // prepared by its source
        ok = predictor_.set(element, t.name, t.prepared, m, error, kMovingGroup, ~0u);
      } else {
        // Not copied while in the world (set uses the shape on entry only): a sensor's is large.
        const vadop::Shape padded =
            fresh && params_.padding > 0.0 ? vadop::inflate(t.shape, params_.padding) : vadop::Shape();
        ok = predictor_.set(element, t.name, fresh && params_.padding > 0.0 ? padded : t.shape, m, error,
                            kMovingGroup, ~0u);
      }
      if (!ok) why = "refused by the world: " + error;
      sourced_shape_version_[k] = t.shape_version;
    }
    if (!why.empty()) {
      source.drop(s, "motion out of range: " + why, now);
      unsetSourced(element);
      continue;
    }
    if (sourced_in_world_[k] != t.name) {
      sourced_in_world_[k] = t.name;
      if (!filter_.empty()) sourced_matches_[k] = filter_.matches({t.name, t.link});
    }
    ++in_world;
  }
  return in_world;
}

void MonitorCore::placeInRegion(const ros::Time& now) {
  const auto& bodies = registry_.bodies();
  body_place_.assign(bodies.size(), kInside);
  if (!params_.region.bounded) return;
  const double t_now = registry_.seconds(now);
  for (size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    // Static obstacles stay (they cost no prediction); a gated body stays wherever it drives,
    // so that its gate, which lives in this monitor, always has it.
    if (body.is_static) {
      body_place_[b] = kMargin;
      continue;
    }
    if (!body.frame_motion.valid) continue;  // not in the world this cycle anyway
    const Eigen::Vector3d p = body.frame_motion.motion.positionAt(t_now);
    body_place_[b] = params_.region.contains(p, 0.0)                    ? kInside
                     : params_.region.contains(p, params_.region_margin) ? kMargin
                     : body.params.has_gate                              ? kMargin
                                                                         : kOutside;
  }
}

void MonitorCore::syncWorld(const ros::Time& now) {
  const auto& elements = registry_.elements();
  size_t moving = 0;
  std::string error;
  elements_in_world_of_body_.assign(registry_.bodies().size(), 0);
  placeInRegion(now);
  for (size_t i = 0; i < elements.size(); ++i) {
    const Element& e = elements[i];
    if (refused_[i] && !(e.active && sameMotion(e.motion, refused_motion_[i]))) refused_[i] = 0;
    if (!e.active || refused_[i] || body_place_[e.body] == kOutside) {
      if (refused_[i]) registry_.markElementBad(i, "left out since the prediction failed on it", now);
      predictor_.unset(i);
      continue;
    }
    if (!registry_.bodies()[e.body].is_static) ++moving;
    // Static elements: a group that does not collide with itself (pairIgnored's first rule).
    const bool is_static = registry_.bodies()[e.body].is_static;
    const uint32_t group = is_static ? kStaticGroup : kMovingGroup;
    const uint32_t mask = is_static ? ~kStaticGroup : ~0u;
    const bool ok = (!predictor_.contains(i) && params_.padding > 0.0)
                        ? predictor_.set(i, e.id, vadop::inflate(e.shape, params_.padding), e.motion, error, group,
                                         mask, e.chain)
                        : predictor_.set(i, e.id, e.shape, e.motion, error, group, mask, e.chain);
    if (!ok) {
      predictor_.unset(i);
      registry_.markElementBad(i, "refused by the world: " + error, now);  // throttled per body
    } else if (elements_in_world_of_body_[e.body] < 2) {
      ++elements_in_world_of_body_[e.body];
    }
  }
  stats_.moving_elements = moving;
  syncSourcedBodies(now);
  stats_.elements_in_world = predictor_.size();
  // pairIgnored can ignore a pair the groups let through only by ~ignore_pairs or between two
  // elements of one body.
  pair_rules_needed_ = !filter_.empty() || std::any_of(elements_in_world_of_body_.begin(),
                                                       elements_in_world_of_body_.end(),
                                                       [](uint8_t n) { return n >= 2; });
  predictor_.enableIgnored(pair_rules_needed_);
}

bool MonitorCore::pairIgnored(size_t ea, size_t eb) const {
  if (isSourced(ea) || isSourced(eb)) {
    // A source's body is a body of its own, never static: only ~ignore_pairs applies.
    if (filter_.empty()) return false;
    const auto& ma = isSourced(ea) ? sourced_matches_[ea - setBase()] : element_matches_[ea];
    const auto& mb = isSourced(eb) ? sourced_matches_[eb - setBase()] : element_matches_[eb];
    return PairFilter::ignored(ma, mb);
  }
  const auto& elements = registry_.elements();
  const auto& bodies = registry_.bodies();
  const Element& a = elements[ea];
  const Element& b = elements[eb];
  const Body& ba = bodies[a.body];
  const Body& bb = bodies[b.body];
  if (ba.is_static && bb.is_static) return true;
  if (a.body == b.body) {
    // Links rigid with each other never move relative to each other; links joined by a
    // joint touch by construction.
    if (!params_.self_collision || a.tf_frame.empty() || b.tf_frame.empty()) return true;
    if (a.link == b.link) return true;
    for (const auto& pc : ba.adjacent) {
      if ((pc.first == a.link && pc.second == b.link) || (pc.first == b.link && pc.second == a.link)) return true;
    }
  }
  if (!filter_.empty() && PairFilter::ignored(element_matches_[ea], element_matches_[eb])) return true;
  return false;
}

bool MonitorCore::leaveOutOffenders(const std::string& error, const ros::Time& now) {
  const auto& elements = registry_.elements();
  std::string names;
  for (size_t i = 0; i < elements.size(); ++i) {
    if (!predictor_.contains(i)) continue;
    const Element& e = elements[i];
    std::string why = BodyRegistry::motionRangeError(predictor_.motion(i), t0_, t0_ + cycle_horizon_);
    if (why.empty() && error.find("\"" + e.id + "\"") == std::string::npos) continue;
    if (why.empty()) why = "the prediction failed on it: " + error;
    predictor_.unset(i);
    refused_[i] = 1;
    refused_motion_[i] = e.motion;
    registry_.markElementBad(i, why, now);
    names += (names.empty() ? "" : ", ") + e.id;
  }
  const size_t n = body_sources_.size();
  for (size_t k = 0; k < sourced_in_world_.size(); ++k) {
    const size_t i = setBase() + k;
    if (!predictor_.contains(i)) continue;
    const std::string name = sourced_in_world_[k];
    std::string why = BodyRegistry::motionRangeError(predictor_.motion(i), t0_, t0_ + cycle_horizon_);
    if (why.empty() && error.find("\"" + name + "\"") == std::string::npos) continue;
    if (why.empty()) why = "the prediction failed on it: " + error;
    body_sources_[k % n]->drop(k / n, why, now);
    unsetSourced(i);
    names += (names.empty() ? "" : ", ") + name;
  }
  if (names.empty()) return false;
  stats_.recovered = "left out " + names + " after: " + error;
  return true;
}

const vadop::ImpactArray& MonitorCore::cycle(const ros::Time& now, TransformSource& tf) {
  startCycle(now, tf);
  do {
    predictCycle();
  } while (retryCycle(now));
  return finishCycle(now);
}

std::shared_ptr<const FilterSnapshot> MonitorCore::filterSnapshot() {
  if (!filter_snapshot_ || filter_snapshot_cycle_ != cycles_) {
    static const std::vector<SourcedBody> kNone;
    filter_snapshot_ = makeFilterSnapshot(registry_, tracks_ ? tracks_->bodies() : kNone, filter_cache_);
    filter_snapshot_cycle_ = cycles_;
  }
  return filter_snapshot_;
}

void MonitorCore::startCycle(const ros::Time& now, TransformSource& tf) {
  ++cycles_;  // the sensors' filter snapshot follows the new motions
  cycle_start_ = std::chrono::steady_clock::now();
  predicting_ = false;  // should the last cycle have thrown before its end
  stats_ = CycleStats();
  stats_.stamp = now;
  if (worlds_stale_) {
    // A new padding arrived while the world predicted (reconfigure): every element comes back
    // padded anew now.
    predictor_.clear();
    gate_predictor_.clear();
    worlds_stale_ = false;
  }
  registry_.update(now, tf);
  syncWorld(now);
  stats_.registry_seconds = secondsSince(cycle_start_);

  impacts_.header.stamp = now;
  impacts_.header.frame_id = params_.fixed_frame;
  std::fill(soonest_.begin(), soonest_.end(), std::numeric_limits<double>::infinity());
  std::fill(sourced_soonest_.begin(), sourced_soonest_.end(), std::numeric_limits<double>::infinity());
  t0_ = registry_.seconds(now);
  cycle_horizon_ = params_.horizon;
  predict_attempts_ = 0;
  predicting_ = true;
  predict_start_ = std::chrono::steady_clock::now();
}

void MonitorCore::predictCycle() {
  ++predict_attempts_;
  try {
    raw_impacts_ = predictor_.predict(t0_, cycle_horizon_);
    stats_.error.clear();
  } catch (const std::exception& e) {  // vadop::InvalidArgument; anything else is treated alike
    raw_impacts_.clear();
    stats_.error = e.what();
  }
}

bool MonitorCore::retryCycle(const ros::Time& now) {
  // One element the world refuses must not cost everybody the cycle: find it (out of range
  // over the window, or named by the error), leave it out while its motion stays the same,
  // and predict once more.
  return !stats_.error.empty() && predict_attempts_ == 1 && leaveOutOffenders(stats_.error, now);
}

const vadop::ImpactArray& MonitorCore::finishCycle(const ros::Time& now) {
  predicting_ = false;
  logPredictionOutcome();
  stats_.elements_in_world = predictor_.size();
  stats_.predict_seconds = secondsSince(predict_start_);
  stats_.candidates = predictor_.lastCandidateCount();
  stats_.reused = predictor_.lastReusedCount();
  stats_.slice_culled = predictor_.lastSliceCulledCount();
  stats_.raw_impacts = raw_impacts_.size();
  writeImpacts(now);
  // The world sorts by time; the clamp to 0 keeps that order.
  stats_.impacts = impacts_.impacts.size();
  noteUndecided();
  // The gates' world follows this cycle's now, or at the first question if nobody asks one
  // every cycle (no gate configured: its copy of every element is about a tenth of a cycle).
  gate_world_current_ = false;
  if (gate_world_wanted_) syncGateWorld();
  stats_.cycle_seconds = secondsSince(cycle_start_);
  return impacts_;
}

void MonitorCore::logPredictionOutcome() {
  if (!stats_.recovered.empty() && stats_.error.empty() && throttleOk(last_error_log_)) {
    ROS_WARN_NAMED("vadop_monitor", "prediction recovered this cycle: %s (throttled to one line per 5 s)",
                   stats_.recovered.c_str());
  }
  if (!stats_.error.empty() && throttleOk(last_error_log_)) {
    ROS_ERROR_NAMED("vadop_monitor", "prediction failed this cycle: %s (throttled to one line per 5 s)",
                    stats_.error.c_str());
  }
}

void MonitorCore::writeImpacts(const ros::Time& now) {
  const std::vector<vadop::Contact>& raw = raw_impacts_;
  // The impacts the pair rules keep (the world applies the same rules: syncWorld's groups and,
  // when pair_rules_needed_, this predicate; without those rules it reports no ignored pair).
  std::vector<uint32_t>& kept = kept_impacts_;
  kept.clear();
  const auto& elements = registry_.elements();
  // With a region: a pair with both bodies outside it is another monitor's to report.
  const auto inside = [&](size_t element) {
    return isSourced(element) || body_place_[elements[element].body] == kInside;
  };
  for (size_t k = 0; k < raw.size(); ++k) {
    if (pair_rules_needed_ && pairIgnored(raw[k].a_user, raw[k].b_user)) {
      ++stats_.ignored_tested;
      continue;
    }
    if (params_.region.bounded && !inside(raw[k].a_user) && !inside(raw[k].b_user)) continue;
    kept.push_back(static_cast<uint32_t>(k));
  }
  // The array's entries are overwritten in place (their strings keep their storage from cycle
  // to cycle), each by one thread: thousands a cycle in a large fleet, on the cycle's thread
  // otherwise (mostly cache misses on the bodies' names).
  std::vector<vadop::Impact>& out = impacts_.impacts;
  out.resize(kept.size());
  constexpr size_t kImpactsPerThread = 128, kImpactChunk = 32;
  vadop::parallelFor(vadop::threadCount(params_.threads), kept.size(), kImpactsPerThread, kImpactChunk,
                             [&](size_t i) { writeImpact(raw[kept[i]], now, out[i]); });
  // The soonest time to impact of an element's body (a source body's own).
  auto soonest = [&](size_t element) -> double& {
    return isSourced(element) ? sourced_soonest_[element - setBase()] : soonest_[elements[element].body];
  };
  for (size_t i = 0; i < kept.size(); ++i) {
    const vadop::Contact& hit = raw[kept[i]];
    soonest(hit.a_user) = std::min(soonest(hit.a_user), out[i].time_to_impact);
    soonest(hit.b_user) = std::min(soonest(hit.b_user), out[i].time_to_impact);
  }
}

void MonitorCore::noteUndecided() {
  for (const vadop::Contact& u : predictor_.lastUndecided()) {
    if (pair_rules_needed_ && pairIgnored(u.a_user, u.b_user)) {
      ++stats_.ignored_tested;
      continue;
    }
    if (stats_.undecided++ > 0) continue;
    auto label = [&](size_t element) {
      const ElementKey k = elementKey(element);
      return k.link.empty() ? k.body : k.body + "/" + k.link;
    };
    char after[64];
    std::snprintf(after, sizeof after, " after %.3f s", std::max(0.0, u.impact.time - t0_));
    stats_.undecided_first = label(u.a_user) + " <-> " + label(u.b_user) + after;
  }
  if (stats_.undecided > 0 && throttleOk(last_undecided_log_)) {
    ROS_WARN_NAMED("vadop_monitor", "%zu pair(s) not decided within the narrow phase's budget, the first %s: "
                   "clear until then, unknown after (not reported as impacts; throttled to one line per 5 s)",
                   stats_.undecided, stats_.undecided_first.c_str());
  }
}

visualization_msgs::MarkerArray MonitorCore::markers() const {
  MarkerInput in;
  in.frame = params_.fixed_frame;
  in.stamp = impacts_.header.stamp;
  in.t0 = t0_;
  in.horizon = params_.horizon;
  in.impacts = &impacts_;
  const auto& elements = registry_.elements();
  const auto& bodies = registry_.bodies();
  in.elements.reserve(elements.size());
  for (size_t i = 0; i < elements.size(); ++i) {
    if (!predictor_.contains(i)) continue;
    const Element& e = elements[i];
    MarkerElement m;
    m.body = bodies[e.body].name;
    m.link = e.link;
    m.is_static = bodies[e.body].is_static;
    m.shape = predictor_.shape(i);  // padded, as given to the world
    m.motion = predictor_.motion(i);
    if (predictor_.chain(i)) {
      m.path_pose = [this, i](double t) { return predictor_.poseAt(i, t); };
      m.path_times = predictor_.pathTimes(i, t0_, t0_ + params_.horizon);
    }
    m.mesh_uri = e.mesh_uri;
    m.mesh_scale = e.mesh_scale;
    m.soonest = soonest_[e.body];
    in.elements.push_back(std::move(m));
  }
  for (size_t k = 0; k < sourced_in_world_.size(); ++k) {
    const size_t i = setBase() + k;
    if (!predictor_.contains(i)) continue;
    MarkerElement m;
    m.body = sourced_in_world_[k];
    m.link = sourcedBody(i).link;
    m.shape = predictor_.shape(i);
    m.motion = predictor_.motion(i);
    m.soonest = sourced_soonest_[k];
    in.elements.push_back(std::move(m));
  }
  return buildMarkers(in);
}

void MonitorCore::adoptCommand(const CommandCheck& check) {
  if (check.status != CommandCheck::Status::kChecked) return;
  for (size_t k = 0; k < check.elements.size(); ++k) {
    const size_t i = check.elements[k];
    if (!gate_predictor_.contains(i)) continue;
    std::string error;
    // In the world already: only its motion changes (the shape argument is not used).
    if (!gate_predictor_.set(i, registry_.elements()[i].id, gate_predictor_.shape(i), check.motions[k], error)) {
      ROS_WARN("vadop_monitor: the gated motion of \"%s\" was refused by the world: %s",
               registry_.elements()[i].id.c_str(), error.c_str());
    }
    gate_predictor_.setStopDuration(i, check.stop_duration);
  }
}

void MonitorCore::appendCommandMarkers(const CommandCheck& check, const std::string& ns,
                                       visualization_msgs::MarkerArray& out) const {
  if (check.status != CommandCheck::Status::kChecked) return;
  MarkerInput in;
  in.frame = params_.fixed_frame;
  in.stamp = addSeconds(registry_.timeBase(), check.t0);
  in.t0 = check.t0;
  in.horizon = check.window;
  for (size_t k = 0; k < check.elements.size(); ++k) {
    const size_t i = check.elements[k];
    if (!predictor_.contains(i)) continue;
    const Element& e = registry_.elements()[i];
    MarkerElement m;
    m.body = ns;
    m.link = e.link;
    m.shape = predictor_.shape(i);
    m.motion = check.motions[k];
    if (k < check.paths.size()) {
      // The manoeuvre to standstill: its keyframes within the window.
      const vadop::TimedPath& path = check.paths[k];
      m.path_pose = [&path](double t) { return path.poseAt(t); };
      for (const vadop::Keyframe& key : path.keyframes()) {
        if (key.time > check.t0 && key.time < check.t0 + check.window) m.path_times.push_back(key.time);
      }
    }
    m.mesh_uri = e.mesh_uri;
    m.mesh_scale = e.mesh_scale;
    m.soonest = check.limited ? check.time_to_contact : std::numeric_limits<double>::infinity();
    in.elements.push_back(std::move(m));
  }
  const visualization_msgs::MarkerArray built = buildMarkers(in);
  // Its first marker is the DELETEALL of a whole array.
  out.markers.insert(out.markers.end(), built.markers.begin() + 1, built.markers.end());
}

void MonitorCore::appendGateDecision(const vadop::GateState& state, size_t body, const std::string& ns,
                                     visualization_msgs::MarkerArray& out) const {
  // Above the highest point of its elements' bounding balls, at the middle of their origins.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  const auto& elements = registry_.elements();
  for (size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].body != body || !predictor_.contains(i)) continue;
    const Eigen::Vector3d p = predictor_.poseAt(i, t0_).translation();
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p + Eigen::Vector3d(0.0, 0.0, predictor_.shape(i).bounding_radius));
  }
  if (!std::isfinite(lo.x())) return;
  const Eigen::Vector3d at(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), hi.z() + kGateDecisionRaise);
  out.markers.push_back(gateDecisionMarker(state, ns, params_.fixed_frame, impacts_.header.stamp, at));
}

std::string MonitorCore::describe(const vadop::Impact& i) {
  auto label = [](const std::string& body, const std::string& link) {
    return link.empty() ? body : body + "/" + link;
  };
  char buf[256];
  if (i.in_contact) {
    std::snprintf(buf, sizeof buf, " in contact now at (%.2f, %.2f, %.2f)", i.point.x, i.point.y, i.point.z);
  } else {
    std::snprintf(buf, sizeof buf, " in %.2f s at (%.2f, %.2f, %.2f), closing at %.2f m/s", i.time_to_impact,
                  i.point.x, i.point.y, i.point.z, i.closing_speed);
  }
  return label(i.body_a, i.link_a) + " <-> " + label(i.body_b, i.link_b) + buf;
}

}  // namespace vadop_ros
