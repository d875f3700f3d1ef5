#include "vadop_ros/monitor_diagnostics.h"

#include <diagnostic_msgs/DiagnosticStatus.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <limits>

namespace vadop_ros {
namespace {

using diagnostic_msgs::DiagnosticStatus;

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

}  // namespace

double CycleTimeWindow::percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(p * static_cast<double>(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

void CycleTimeWindow::add(const CycleStats& s) {
  if (times_.size() < kMaxSamples) {
    times_.push_back(s.cycle_seconds);
  } else {
    times_[next_] = s.cycle_seconds;
    next_ = (next_ + 1) % kMaxSamples;
  }
  ++count_;
  sum_ += s.cycle_seconds;
  max_ = std::max(max_, s.cycle_seconds);
  if (rate_for_overrun_ > 0.0 && s.cycle_seconds > 1.0 / rate_for_overrun_) ++overruns_;
  reused_ += s.reused;
  last_ = s;
  has_last_ = true;
}

void CycleTimeWindow::report(diagnostic_updater::DiagnosticStatusWrapper& stat, double rate) {
  if (!has_last_) {
    stat.summary(DiagnosticStatus::OK, "no cycle yet");
    return;
  }
  const double period = 1.0 / rate;
  const double mean = count_ ? sum_ / count_ : 0.0;
  if (!last_.error.empty()) {
    stat.summary(DiagnosticStatus::ERROR, "prediction failed: " + last_.error);
  } else if (!last_.recovered.empty()) {
    stat.summary(DiagnosticStatus::WARN, "prediction recovered: " + last_.recovered);
  } else if (last_.undecided > 0) {
    stat.summaryf(DiagnosticStatus::WARN, "%zu pair(s) undecided within the narrow phase's budget, the first %s",
                  last_.undecided, last_.undecided_first.c_str());
  } else if (overruns_ > 0) {
    stat.summaryf(DiagnosticStatus::WARN, "%zu of %zu cycles overran the period (%.1f ms)", overruns_, count_,
                  period * 1e3);
  } else {
    stat.summaryf(DiagnosticStatus::OK, "cycle %.2f ms mean (%.0f%% of the period), %zu impacts", mean * 1e3,
                  100.0 * mean / period, last_.impacts);
  }
  stat.add("cycle time last (ms)", fmt("%.3f", last_.cycle_seconds * 1e3));
  stat.add("cycle time mean (ms)", fmt("%.3f", mean * 1e3));
  stat.add("cycle time p95 (ms)", fmt("%.3f", percentile(times_, 0.95) * 1e3));
  stat.add("cycle time max (ms)", fmt("%.3f", max_ * 1e3));
  stat.add("predict time last (ms)", fmt("%.3f", last_.predict_seconds * 1e3));
  stat.add("period (ms)", fmt("%.3f", period * 1e3));
  stat.add("share of the period (mean)", fmt("%.3f", mean / period));
  stat.add("cycles in window", count_);
  stat.add("overruns in window", overruns_);
  stat.add("elements in world", last_.elements_in_world);
  stat.add("moving elements", last_.moving_elements);
  stat.add("narrow-phase candidates", last_.candidates);
  stat.add("candidates answered by certificates", last_.reused);
  stat.add("candidates answered by certificates in window", reused_);
  stat.add("pairs culled by time slices", last_.slice_culled);
  stat.add("impacts (before filtering)", last_.raw_impacts);
  stat.add("impacts", last_.impacts);
  stat.add("undecided pairs", last_.undecided);
  stat.add("ignored pairs tested", last_.ignored_tested);
  count_ = 0;
  sum_ = max_ = 0.0;
  times_.clear();
  next_ = 0;
  overruns_ = 0;
  reused_ = 0;
}

std::string describeBody(const Body& b, const ros::Time& now, double stale_timeout, unsigned char* level,
                         double waited) {
  unsigned char lvl = DiagnosticStatus::OK;
  std::string text;
  const BodyStatus& s = b.status;
  switch (s.state) {
    case BodyState::kWaiting:
      text = "waiting for the first message";
      if (!b.sources.empty()) text += " on " + b.sources.front()->topic();
      if (waited > kFirstMessageWarnSeconds) {
        lvl = DiagnosticStatus::WARN;
        text += " (" + fmt("%.0f", waited) + " s since start-up)";
      }
      break;
    case BodyState::kOk: text = "ok"; break;
    case BodyState::kStatic: text = "static obstacle"; break;
    case BodyState::kStale:
      lvl = DiagnosticStatus::WARN;
      text = "stale: no message for " + fmt("%.2f", secondsBetween(now, s.last_receipt)) + " s (timeout " +
             fmt("%.2f", stale_timeout) + " s): standing still at its last pose";
      break;
    case BodyState::kTfMissing:
      lvl = DiagnosticStatus::WARN;
      text = (s.links_skipped ? std::to_string(s.links_skipped) + " link(s) skipped: " : std::string("skipped: ")) +
             "transform missing: " + s.tf_error;
      break;
    case BodyState::kNoGeometry:
      lvl = DiagnosticStatus::ERROR;
      text = "not monitored: no geometry";
      break;
  }
  if (!s.last_invalid_receipt.isZero() &&
      secondsBetween(now, s.last_invalid_receipt) < BodyRegistry::kInvalidMarkSeconds) {
    lvl = std::max<unsigned char>(lvl, DiagnosticStatus::WARN);
    text += "; bad input: " + std::to_string(s.dropped_invalid) + " message(s) dropped";
    if (s.elements_left_out > 0) text += ", " + std::to_string(s.elements_left_out) + " element-cycle(s) left out";
    text += ", last: " + s.last_invalid;
  }
  if (!s.geometry_errors.empty()) {
    // Part of the body is monitored (a body with none stops the node at start-up).
    lvl = std::max<unsigned char>(lvl, DiagnosticStatus::WARN);
    text += "; geometry error: " + s.geometry_errors.front();
    if (s.geometry_errors.size() > 1) text += " (+" + std::to_string(s.geometry_errors.size() - 1) + " more)";
  }
  if (s.dropped_out_of_order > 0) text += "; " + std::to_string(s.dropped_out_of_order) + " out-of-order/duplicate ignored";
  // Which input the prediction follows (bodies with only a velocity source have nothing more to
  // say), with each other input's counts; a mobile manipulator has several.
  std::string counts;
  for (size_t k = 1; k < b.sources.size(); ++k) {
    counts += (counts.empty() ? "" : "; ") + b.sources[k]->describe(b, now);
  }
  if (!b.is_static && !counts.empty()) text += std::string("; predicted along: ") + motionSource(b) + " (" + counts + ")";
  if (level) *level = lvl;
  return text;
}

void reportBodies(diagnostic_updater::DiagnosticStatusWrapper& stat, const BodyRegistry& registry,
                  const ros::Time& now) {
  unsigned char worst = DiagnosticStatus::OK;
  size_t counts[6] = {0, 0, 0, 0, 0, 0};
  size_t bad_input = 0;
  size_t on_path = 0;
  size_t geometry_errors = 0;
  const double waited = registry.firstUpdate().isZero() ? 0.0 : secondsBetween(now, registry.firstUpdate());
  for (const Body& b : registry.bodies()) {
    on_path += b.status.on_path ? 1 : 0;
    geometry_errors += b.status.geometry_errors.empty() ? 0 : 1;
    unsigned char lvl = 0;
    stat.add(b.name, describeBody(b, now, registry.staleTimeout(), &lvl, waited));
    worst = std::max(worst, lvl);
    ++counts[static_cast<int>(b.status.state)];
    if (!b.status.last_invalid_receipt.isZero() &&
        secondsBetween(now, b.status.last_invalid_receipt) < BodyRegistry::kInvalidMarkSeconds) {
      ++bad_input;
    }
  }
  char buf[256];
  std::snprintf(buf, sizeof buf, "%zu ok, %zu static, %zu waiting, %zu stale, %zu tf missing, %zu no geometry, %zu bad input",
                counts[static_cast<int>(BodyState::kOk)], counts[static_cast<int>(BodyState::kStatic)],
                counts[static_cast<int>(BodyState::kWaiting)], counts[static_cast<int>(BodyState::kStale)],
                counts[static_cast<int>(BodyState::kTfMissing)], counts[static_cast<int>(BodyState::kNoGeometry)],
                bad_input);
  std::string summary = buf;
  if (geometry_errors > 0) summary += ", " + std::to_string(geometry_errors) + " with geometry errors";
  if (on_path > 0) summary += ", " + std::to_string(on_path) + " following a path";
  for (const auto& [topic, c] : registry.bodyStatesTopics()) {
    std::snprintf(buf, sizeof buf, "%llu arrays; entries: %llu accepted, %llu dropped, %llu out of order, %llu naming no body",
                  static_cast<unsigned long long>(c.arrays), static_cast<unsigned long long>(c.accepted),
                  static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.out_of_order),
                  static_cast<unsigned long long>(c.unknown));
    stat.add("states_topic " + topic, buf);
  }
  stat.summary(worst, summary);
}

}  // namespace vadop_ros
