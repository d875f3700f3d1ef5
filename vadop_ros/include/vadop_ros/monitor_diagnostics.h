// /diagnostics of vadop_monitor (diagnostic_updater tasks):
//  - "cycle": cycle time (last, mean, p95 and max over the reporting window), share of the period,
//    elements in the world, narrow-phase candidates (and those answered by certificates, last
//    cycle and summed over the window: one sampled cycle a second misses a rare reuse), impacts;
//    WARN when a cycle overran its period, the last prediction recovered by leaving an element
//    out or left pairs undecided within the narrow phase's budget (named, never published as
//    impacts), ERROR when the last prediction failed;
//  - "bodies": one key per body with its state ("ok", "stale: no message for 1.3 s",
//    "transform missing: ...", "dropped 3 bad messages, last: NaN/Inf in ...", "geometry
//    error: ..."), the level being the worst of them (stale, tf missing and bad messages: WARN;
//    a geometry error: ERROR; waiting for the first message: OK), and per states_topic T a key
//    "states_topic T" with its arrays and entries accepted, dropped, out of order and naming no
//    body;
//  - "tracks" (with ~tracks; filled by the tracked objects' source, Tracks::report, as each
//    body-set source fills its own entry): "N tracked objects from M source(s)", and per source (its prefix
//    P) "P: objects" (in the world now), "P: arrays accepted", "P: arrays dropped", "P: arrays
//    out of order", "P: objects dropped", "P: objects expired", "P: last problem"; WARN while a
//    source dropped something within the last BodyRegistry::kInvalidMarkSeconds;
//  - "sensors" (with ~sensors; SensorsSource::report): "N point(s) from M sensor(s)" and the
//    stale ones, and per sensor S "S: topic", "S: type", "S: points" (kept now), "S: stale",
//    "S: messages accepted", "S: messages dropped", "S: messages out of order", "S: beams NaN",
//    "S: points skipped", "S: points filtered (own body)", "S: points filtered (other bodies)",
//    "S: expired", "S: last problem"; WARN while a sensor is stale (the
//    gates stop) or dropped something within the last BodyRegistry::kInvalidMarkSeconds.
#pragma once

#include "vadop_ros/monitor_core.h"

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include <vector>

namespace vadop_ros {

// Accumulates cycle times between two diagnostics reports: their count, sum, max and the times
// themselves (for the p95), the latter bounded to the last kMaxSamples cycles of a window (a
// window is one diagnostics period, about 1 s: 30 cycles at 30 Hz). Not thread-safe: the node
// adds and reports under its core's mutex.
class CycleTimeWindow {
 public:
  static constexpr size_t kMaxSamples = 4096;
  // The p-quantile (p in [0, 1]) of `values` as fleet_report.py and the gates' latency take it:
  // the sorted values' element at round(p * (n - 1)); NaN when empty. O(n) (nth_element on a copy).
  static double percentile(std::vector<double> values, double p);

  // Cycles longer than 1 / rate count as overruns.
  void setRate(double rate) { rate_for_overrun_ = rate; }
  void add(const CycleStats& s);
  // Fills the "cycle" status and restarts the window.
  void report(diagnostic_updater::DiagnosticStatusWrapper& stat, double rate);

 private:
  size_t count_ = 0;
  double sum_ = 0.0, max_ = 0.0;
  std::vector<double> times_;  // seconds: the window's cycles, the last kMaxSamples of them
  size_t next_ = 0;            // where the next time goes once times_ is full (a ring)
  size_t overruns_ = 0;
  size_t reused_ = 0;  // candidates answered by certificates, summed over the window
  double rate_for_overrun_ = 0.0;
  CycleStats last_;
  bool has_last_ = false;
};

// A moving body still waiting for its first message this long after start-up is a warning (its
// topic is probably wrong, or nothing publishes it yet).
constexpr double kFirstMessageWarnSeconds = 5.0;

// One line describing a body's state at `now` (ROS time); `waited`: seconds since the node's
// first cycle (a body waiting longer than kFirstMessageWarnSeconds is a warning).
std::string describeBody(const Body& body, const ros::Time& now, double stale_timeout, unsigned char* level,
                         double waited = 0.0);

// Fills the "bodies" status.
void reportBodies(diagnostic_updater::DiagnosticStatusWrapper& stat, const BodyRegistry& registry,
                  const ros::Time& now);

}  // namespace vadop_ros
