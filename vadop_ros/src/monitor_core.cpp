#include "vadop_ros/monitor_core.h"

#include <vadop/error.h>

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
  return c;
}

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

Predictor makePredictor(const MonitorParams& p) {
  try {
    return Predictor(predictorConfig(p));
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

}  // namespace

MonitorCore::MonitorCore(const MonitorParams& params, const ParamReader& read_param, const MeshLoader& load_mesh)
    : params_(params),
      registry_(params, read_param, load_mesh),
      filter_(params.ignore_pairs),
      predictor_(makePredictor(params)) {
  soonest_.assign(registry_.bodies().size(), std::numeric_limits<double>::infinity());
  impacts_.header.frame_id = params_.fixed_frame;
  registry_.setMaxStampSkew(params.max_stamp_skew);
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
      requested.padding != params_.padding) {
    params_.padding = requested.padding;
    // Shapes change: every element leaves the world and comes back, padded anew, at the next
    // cycle (World has no setShape).
    predictor_.clear();
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

void MonitorCore::reset() {
  registry_.reset();
  const auto& elements = registry_.elements();
  for (size_t i = 0; i < elements.size(); ++i) {
    if (!registry_.bodies()[elements[i].body].is_static) {
      predictor_.unset(i);
      refused_[i] = 0;
    }
  }
  impacts_.impacts.clear();
  std::fill(soonest_.begin(), soonest_.end(), std::numeric_limits<double>::infinity());
}

void MonitorCore::syncWorld(const ros::Time& now) {
  const auto& elements = registry_.elements();
  size_t moving = 0;
  std::string error;
  for (size_t i = 0; i < elements.size(); ++i) {
    const Element& e = elements[i];
    if (refused_[i] && !(e.active && sameMotion(e.motion, refused_motion_[i]))) refused_[i] = 0;
    if (!e.active || refused_[i]) {
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
                        ? predictor_.set(i, e.id, vadop::inflate(e.shape, params_.padding), e.motion, error, group, mask)
                        : predictor_.set(i, e.id, e.shape, e.motion, error, group, mask);
    if (!ok) {
      predictor_.unset(i);
      registry_.markElementBad(i, "refused by the world: " + error, now);  // throttled per body
    }
  }
  stats_.moving_elements = moving;
  stats_.elements_in_world = predictor_.size();
}

bool MonitorCore::pairIgnored(size_t ea, size_t eb) const {
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
    std::string why = BodyRegistry::motionRangeError(predictor_.motion(i), t0_, t0_ + params_.horizon);
    if (why.empty() && error.find("\"" + e.id + "\"") == std::string::npos) continue;
    if (why.empty()) why = "the prediction failed on it: " + error;
    predictor_.unset(i);
    refused_[i] = 1;
    refused_motion_[i] = e.motion;
    registry_.markElementBad(i, why, now);
    names += (names.empty() ? "" : ", ") + e.id;
  }
  if (names.empty()) return false;
  stats_.recovered = "left out " + names + " after: " + error;
  return true;
}

const vadop::ImpactArray& MonitorCore::cycle(const ros::Time& now, TransformSource& tf) {
  const auto start = std::chrono::steady_clock::now();
  stats_ = CycleStats();
  stats_.stamp = now;
  registry_.update(now, tf);
  syncWorld(now);

  impacts_.header.stamp = now;
  impacts_.header.frame_id = params_.fixed_frame;
  impacts_.impacts.clear();
  std::fill(soonest_.begin(), soonest_.end(), std::numeric_limits<double>::infinity());
  t0_ = registry_.seconds(now);

  // One element the world refuses must not cost everybody the cycle: find it (out of range
  // over the window, or named by the error), leave it out while its motion stays the same,
  // and predict once more.
  std::vector<RawImpact> raw;
  const auto predict_start = std::chrono::steady_clock::now();
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      raw = predictor_.predict(t0_, params_.horizon);
      stats_.error.clear();
      break;
    } catch (const std::exception& e) {  // vadop::InvalidArgument; anything else is treated alike
      stats_.error = e.what();
      if (attempt == 0 && leaveOutOffenders(e.what(), now)) continue;
      break;
    }
  }
  if (!stats_.recovered.empty() && stats_.error.empty() && throttleOk(last_error_log_)) {
    ROS_WARN_NAMED("vadop_monitor", "prediction recovered this cycle: %s (throttled to one line per 5 s)",
                   stats_.recovered.c_str());
  }
  if (!stats_.error.empty() && throttleOk(last_error_log_)) {
    ROS_ERROR_NAMED("vadop_monitor", "prediction failed this cycle: %s (throttled to one line per 5 s)",
                    stats_.error.c_str());
  }
  stats_.elements_in_world = predictor_.size();
  stats_.predict_seconds = secondsSince(predict_start);
  stats_.candidates = predictor_.lastCandidateCount();
  stats_.raw_impacts = raw.size();

  const auto& elements = registry_.elements();
  const auto& bodies = registry_.bodies();
  impacts_.impacts.reserve(raw.size());
  for (const RawImpact& hit : raw) {
    if (pairIgnored(hit.a, hit.b)) {
      ++stats_.ignored_tested;
      continue;
    }
    const Element& ea = elements[hit.a];
    const Element& eb = elements[hit.b];
    vadop::Impact msg;
    msg.body_a = bodies[ea.body].name;
    msg.link_a = ea.link;
    msg.body_b = bodies[eb.body].name;
    msg.link_b = eb.link;
    // In [0, horizon]: t0 + horizon - t0 may differ from the horizon by a rounding.
    msg.time_to_impact = std::min(params_.horizon, std::max(0.0, hit.time - t0_));
    msg.time_of_impact = addSeconds(now, msg.time_to_impact);  // saturates: now may be near 2^32 s
    msg.point.x = hit.point.x();
    msg.point.y = hit.point.y();
    msg.point.z = hit.point.z();
    msg.normal.x = hit.normal.x();
    msg.normal.y = hit.normal.y();
    msg.normal.z = hit.normal.z();
    msg.closing_speed = hit.closing_speed;
    msg.in_contact = hit.initially_touching;
    soonest_[ea.body] = std::min(soonest_[ea.body], msg.time_to_impact);
    soonest_[eb.body] = std::min(soonest_[eb.body], msg.time_to_impact);
    impacts_.impacts.push_back(std::move(msg));
  }
  // The world sorts by time; the clamp to 0 keeps that order.
  stats_.impacts = impacts_.impacts.size();
  for (const RawImpact& u : predictor_.lastUndecided()) {
    if (pairIgnored(u.a, u.b)) {
      ++stats_.ignored_tested;
      continue;
    }
    if (stats_.undecided++ > 0) continue;
    auto label = [&](const Element& e) {
      return e.link.empty() ? bodies[e.body].name : bodies[e.body].name + "/" + e.link;
    };
    char after[64];
    std::snprintf(after, sizeof after, " after %.3f s", std::max(0.0, u.time - t0_));
    stats_.undecided_first = label(elements[u.a]) + " <-> " + label(elements[u.b]) + after;
  }
  if (stats_.undecided > 0 && throttleOk(last_undecided_log_)) {
    ROS_WARN_NAMED("vadop_monitor", "%zu pair(s) not decided within the narrow phase's budget, the first %s: "
                   "clear until then, unknown after (not reported as impacts; throttled to one line per 5 s)",
                   stats_.undecided, stats_.undecided_first.c_str());
  }
  stats_.cycle_seconds = secondsSince(start);
  return impacts_;
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
    m.mesh_uri = e.mesh_uri;
    m.mesh_scale = e.mesh_scale;
    m.soonest = soonest_[e.body];
    in.elements.push_back(std::move(m));
  }
  return buildMarkers(in);
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
