// A velocity gate's question with a reaction time and a braking model (issue 48's rule): the
// gated body's elements follow, from `now`, the last forwarded command for the reaction time,
// then the new command scaled by s for `hold` seconds, then (with the body's decelerations)
// brake to standstill along the same arc; each element's manoeuvre is a vadop::TimedPath the
// narrow phase certifies (the braking within kDeviation of the exact one: the query's tolerance
// covers it). The scale search asks the gates' world, with the others as predicted and, when
// asked, braking to standstill too. It does not pick the rule's parameters (VelocityGate) nor
// read the registry (MonitorCore::checkCommand fills it).
#pragma once

#include "vadop_ros/monitor_core.h"
#include "vadop_ros/predictor.h"
#include "scale_contacts.h"

#include <vadop/timed_path.h>
#include <vadop/world.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <functional>
#include <vector>

namespace vadop_ros {

class GateManoeuvre {
 public:
  // m: how far the keyframed braking may lie from the exact braking.
  static constexpr double kDeviation = 1e-3;

  // The body frame's pose at t_now (registry seconds) and the question.
  GateManoeuvre(Predictor& world, const Eigen::Isometry3d& body_pose, const CommandQuestion& question, double t_now,
                const std::function<bool(size_t element)>& skip);

  // One element of the body: its pose at t_now, its velocity relative to the body frame (fixed
  // frame: links moving on tf keep it under any command) and its bounding radius.
  void add(size_t element, const Eigen::Isometry3d& pose, const Eigen::Vector3d& own_v, const Eigen::Vector3d& own_w,
           double radius);

  // The largest clear scale (vadop::searchGateScale). Throws vadop::InvalidArgument on a motion
  // out of the library's range.
  vadop::GateScale search();
  // The manoeuvre at scale s: each element's path, and the time it stands still (t_now-based).
  const std::vector<vadop::TimedPath>& pathsAt(double s);
  double endAt(double s) const;
  // The constant-twist motions of the command scaled by s from t_now (the gates' world adopts
  // them: what other gates see of this body).
  std::vector<vadop::Motion> motionsAt(double s) const;
  // The contact limiting `scale` (ScaleContacts::limit); null when nothing does.
  const vadop::World::MoverContact* limit(const vadop::GateScale& scale) const { return seen_.limit(scale); }
  const std::vector<size_t>& movers() const { return movers_; }
  // How long the body brakes from the command scaled by s (0 without the braking model).
  double brakingDuration(double s) const;

 private:
  struct Part {
    Eigen::Isometry3d pose;
    Eigen::Vector3d own_v, own_w;
    double radius;
  };
  // The motion of element `part` at `pose` (the body frame at `body`) under body-frame twist
  // (v, w), from t.
  vadop::Motion stageMotion(const Part& part, const Eigen::Isometry3d& pose, const Eigen::Isometry3d& body,
                            const Eigen::Vector3d& v, const Eigen::Vector3d& w, double t) const;
  double firstContactAt(double s);

  Predictor& world_;
  const Eigen::Isometry3d body_pose_;
  const CommandQuestion question_;
  const double t_now_;
  const std::function<bool(size_t element)>& skip_;
  std::vector<size_t> movers_;
  std::vector<Part> parts_;
  std::vector<vadop::TimedPath> paths_;
  double deviation_ = 0.0;  // of the last pathsAt
  ScaleContacts seen_;
};

}  // namespace vadop_ros
