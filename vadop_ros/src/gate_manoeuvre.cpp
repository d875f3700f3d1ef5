#include "gate_manoeuvre.h"

#include "vadop_ros/body_registry.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace vadop_ros {

GateManoeuvre::GateManoeuvre(Predictor& world, const Eigen::Isometry3d& body_pose, const CommandQuestion& question,
                             double t_now, const std::function<bool(size_t element)>& skip)
    : world_(world), body_pose_(body_pose), question_(question), t_now_(t_now), skip_(skip) {}

void GateManoeuvre::add(size_t element, const Eigen::Isometry3d& pose, const Eigen::Vector3d& own_v,
                        const Eigen::Vector3d& own_w, double radius) {
  movers_.push_back(element);
  parts_.push_back({pose, own_v, own_w, radius});
}

double GateManoeuvre::brakingDuration(double s) const {
  if (!question_.braking()) return 0.0;
  return std::max(s * question_.v.norm() / question_.linear_decel, s * question_.w.norm() / question_.angular_decel);
}

double GateManoeuvre::endAt(double s) const {
  return t_now_ + question_.reaction_time + question_.hold + brakingDuration(s);
}

vadop::Motion GateManoeuvre::stageMotion(const Part& part, const Eigen::Isometry3d& pose, const Eigen::Isometry3d& body,
                                         const Eigen::Vector3d& v, const Eigen::Vector3d& w, double t) const {
  // The body-frame twist in the fixed frame at the stage's start, carried to the element's origin.
  const Eigen::Vector3d cv = body.linear() * v, cw = body.linear() * w;
  const Eigen::Vector3d r = pose.translation() - body.translation();
  return twistMotion(pose, part.own_v + cv + cw.cross(r), part.own_w + cw, t);
}

const std::vector<vadop::TimedPath>& GateManoeuvre::pathsAt(double s) {
  const CommandQuestion& q = question_;
  const double t_react = t_now_ + q.reaction_time, t_hold = t_react + q.hold;
  const double braking = brakingDuration(s);
  // The body frame through the stages (its own motion: the element of no offset and no own velocity).
  const Part frame{body_pose_, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0};
  const vadop::Motion frame_last = stageMotion(frame, body_pose_, body_pose_, q.last_v, q.last_w, t_now_);
  const Eigen::Isometry3d body_at_react = frame_last.poseAt(t_react);
  paths_.clear();
  deviation_ = 0.0;
  std::vector<vadop::Keyframe> keyframes;
  for (const Part& part : parts_) {
    keyframes.clear();
    const vadop::Motion last = stageMotion(part, part.pose, body_pose_, q.last_v, q.last_w, t_now_);
    vadop::appendKeyframes(last, t_now_, t_react, keyframes);
    const vadop::Motion held = stageMotion(part, last.poseAt(t_react), body_at_react, s * q.v, s * q.w, t_react);
    vadop::appendKeyframes(held, t_react, t_hold, keyframes);
    if (q.braking()) {
      deviation_ = std::max(deviation_, vadop::appendBrakingKeyframes(held, t_hold, braking, part.radius, kDeviation,
                                                                      keyframes));
    }
    // Without braking the command goes on after the window (kContinue); with, the body stands.
    paths_.emplace_back(keyframes, q.braking() ? vadop::AfterPath::kHold : vadop::AfterPath::kContinue);
  }
  return paths_;
}

std::vector<vadop::Motion> GateManoeuvre::motionsAt(double s) const {
  std::vector<vadop::Motion> out;
  for (const Part& part : parts_) out.push_back(stageMotion(part, part.pose, body_pose_, s * question_.v, s * question_.w, t_now_));
  return out;
}

double GateManoeuvre::firstContactAt(double s) {
  pathsAt(s);
  std::optional<vadop::World::MoverContact> c =
      world_.firstContactAlong(movers_, paths_, t_now_, endAt(s) - t_now_, skip_, deviation_, question_.others_may_stop);
  return seen_.note(s, std::move(c));
}

vadop::GateScale GateManoeuvre::search() {
  // One candidate query for all the scales: each element's origin travels its reaction stretch,
  // then at most the faster of the extreme scales' speeds (|own + s cmd| is convex in s) over
  // the hold and the longest braking (s = 1).
  std::vector<Eigen::Vector3d> origins;
  std::vector<double> reach;
  const double t_react = t_now_ + question_.reaction_time, hold = question_.hold;
  const std::vector<vadop::TimedPath> slowest = pathsAt(0.0);
  const std::vector<vadop::TimedPath>& fastest = pathsAt(1.0);
  const double t_end = endAt(1.0);
  for (size_t k = 0; k < parts_.size(); ++k) {
    const double speed =
        std::max(slowest[k].travel(t_react, t_react + hold), fastest[k].travel(t_react, t_react + hold)) / hold;
    origins.push_back(parts_[k].pose.translation());
    // The queries count contacts within a tolerance of 2 (kDeviation + the others' 0.5 mm).
    reach.push_back(fastest[k].travel(t_now_, t_react) + speed * (hold + brakingDuration(1.0)) + 4.0 * kDeviation);
  }
  const Predictor::ReachScope reach_scope(world_, movers_, origins, reach, t_now_, t_end - t_now_);
  // A contact within the reaction time comes before any command takes effect: every scale meets
  // it, and s = 0 last (its query has the smallest tolerance, no braking keyframes), so the
  // scan would end at s = 0: answered at once (blocked commands try every scale otherwise).
  const double at_one = firstContactAt(1.0);
  if (at_one < t_react) {
    const double at_zero = firstContactAt(0.0);
    if (at_zero < t_react) {
      vadop::GateScale stopped;
      stopped.scale = 0.0;
      stopped.contact_time = at_zero;
      stopped.evaluations = 2;
      return stopped;
    }
  }
  size_t evaluations = 0;
  return vadop::searchGateScale([&](double s) { return ++evaluations == 1 ? at_one : firstContactAt(s); });
}

}  // namespace vadop_ros
