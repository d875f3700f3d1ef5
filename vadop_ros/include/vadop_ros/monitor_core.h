// One prediction cycle of vadop_monitor, without ROS transport: the body registry feeds the
// vadop::World (through Predictor, kept incrementally: elements are added when they first have
// a motion, setMotion'ed when their motion changes, removed while they are skipped; never
// rebuilt), the World predicts with the VADOP broad phase and the continuous narrow phase, and
// the impacts are filtered (static-static, self-collisions, ~ignore_pairs) and converted to
// the message.
// The node (vadop_monitor.cpp), the tests and the benchmark drive this class.
#pragma once

#include "vadop_ros/body_registry.h"
#include "vadop_ros/markers.h"
#include "vadop_ros/pair_filter.h"
#include "vadop_ros/params.h"
#include "vadop_ros/predictor.h"

// The message; this header must not pull in vadop/world.h (see predictor.h).
#include <vadop/ImpactArray.h>

#include <ros/time.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace vadop_ros {

struct CycleStats {
  ros::Time stamp;
  double cycle_seconds = 0.0;    // wall time of the whole cycle (registry + world + message)
  double predict_seconds = 0.0;  // of which World::predict
  size_t elements_in_world = 0;
  size_t moving_elements = 0;
  size_t candidates = 0;         // narrow-phase calls (World::lastCandidateCount)
  size_t raw_impacts = 0;        // before filtering
  size_t impacts = 0;            // published
  std::string error;             // predict failed this cycle (nothing published but an empty array)
};

class MonitorCore {
 public:
  // Throws ParamError when ~axes / ~phi_deg are rejected by the library.
  MonitorCore(const MonitorParams& params, const ParamReader& read_param,
              const MeshLoader& load_mesh = makeDefaultMeshLoader());

  BodyRegistry& registry() { return registry_; }
  const BodyRegistry& registry() const { return registry_; }
  const MonitorParams& params() const { return params_; }

  // Runs one cycle at `now` and returns the impacts (header stamped `now`, in the fixed frame).
  const vadop::ImpactArray& cycle(const ros::Time& now, TransformSource& tf);
  const vadop::ImpactArray& lastImpacts() const { return impacts_; }
  const CycleStats& lastStats() const { return stats_; }

  // Soonest time to impact of each body (index into registry().bodies()) in the last cycle;
  // +inf when none.
  const std::vector<double>& soonest() const { return soonest_; }

  // Markers of the last cycle (swept volumes, impacts); see markers.h.
  visualization_msgs::MarkerArray markers() const;

  // dynamic_reconfigure. A new padding re-adds every element with its new shape at the next cycle.
  void setHorizon(double horizon) { params_.horizon = horizon; }
  void setPadding(double padding);
  double horizon() const { return params_.horizon; }
  double padding() const { return params_.padding; }

  // Time jumped backwards: forget every state (and the world's moving elements).
  void reset();

  // One line per impact: "robot_1 <-> robot_2/mast in 0.83 s at (x, y, z), closing 1.2 m/s".
  static std::string describe(const vadop::Impact& impact);

 private:
  bool pairIgnored(size_t ea, size_t eb) const;
  void syncWorld();

  MonitorParams params_;
  BodyRegistry registry_;
  PairFilter filter_;
  Predictor predictor_;
  vadop::ImpactArray impacts_;
  CycleStats stats_;
  std::vector<double> soonest_;
  double t0_ = 0.0;  // registry seconds of the last cycle
};

}  // namespace vadop_ros
