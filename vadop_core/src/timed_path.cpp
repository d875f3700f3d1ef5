#include "vadop/timed_path.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace vadop {
namespace {

// Farther than this from the origin (a near-pure translation), the screw axis would carry the
// origin's path to rounding; the piece then slides straight while turning about the origin.
constexpr double kMaxScrewArm = 1e5;  // m

Motion restAt(const Keyframe& k) {
  Motion m;
  m.t_ref = k.time;
  m.position = k.position;
  m.orientation = k.orientation;
  return m;
}

}  // namespace

Motion screwBetween(double t0, const Eigen::Vector3d& p0, const Eigen::Quaterniond& q0, double t1,
                    const Eigen::Vector3d& p1, const Eigen::Quaterniond& q1) {
  const double dt = t1 - t0;
  Eigen::Quaterniond r = q1 * q0.conjugate();
  if (r.w() < 0.0) r.coeffs() = -r.coeffs();  // the shortest way
  const Eigen::AngleAxisd turn(r.normalized());
  const double theta = turn.angle();  // [0, pi]
  const Eigen::Vector3d u = turn.axis();
  const Eigen::Vector3d d = p1 - p0;
  Motion m;
  m.t_ref = t0;
  m.position = p0;
  m.orientation = q0;
  m.angular_velocity = u * (theta / dt);
  m.linear_velocity = d / dt;
  if (theta == 0.0) return m;
  // Chasles: the slide along u, and the turn by theta about an axis through p0 + o with
  // (I - R) o = d_perp, whose solution in the plane normal to u is
  // o = (d_perp + cot(theta / 2) u x d_perp) / 2.
  const Eigen::Vector3d d_par = u * u.dot(d);
  const Eigen::Vector3d d_perp = d - d_par;
  const Eigen::Vector3d o = 0.5 * (d_perp + u.cross(d_perp) / std::tan(0.5 * theta));
  if (!(o.norm() <= kMaxScrewArm)) return m;
  m.linear_velocity = d_par / dt;
  m.pivot_offset = o;
  return m;
}

TimedPath::TimedPath(std::vector<Keyframe> keyframes, AfterPath after) : keyframes_(std::move(keyframes)) {
  if (keyframes_.empty()) throw InvalidArgument("TimedPath: no keyframe");
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    Keyframe& k = keyframes_[i];
    const std::string what = "TimedPath: keyframe " + std::to_string(i);
    if (!std::isfinite(k.time)) throw InvalidArgument(what + ": time is not finite");
    if (!k.position.allFinite()) throw InvalidArgument(what + ": position is not finite");
    if (!k.orientation.coeffs().allFinite()) throw InvalidArgument(what + ": orientation is not finite");
    if (k.orientation.norm() < 1e-9) throw InvalidArgument(what + ": orientation is a zero quaternion (norm < 1e-9)");
    if (i > 0 && !(k.time > keyframes_[i - 1].time)) {
      throw InvalidArgument(what + ": time " + formatNumber(k.time) + " does not increase (keyframe " +
                            std::to_string(i - 1) + " at " + formatNumber(keyframes_[i - 1].time) + ")");
    }
    k.orientation.normalize();
  }
  motion_.push_back(restAt(keyframes_.front()));
  for (size_t i = 1; i < keyframes_.size(); ++i) {
    const Keyframe& k0 = keyframes_[i - 1];
    const Keyframe& k1 = keyframes_[i];
    start_.push_back(k0.time);
    motion_.push_back(screwBetween(k0.time, k0.position, k0.orientation, k1.time, k1.position, k1.orientation));
  }
  // After the last keyframe: the last piece goes on, or the body rests there.
  if (after == AfterPath::kHold || keyframes_.size() == 1) {
    start_.push_back(keyframes_.back().time);
    motion_.push_back(restAt(keyframes_.back()));
  }
  for (size_t k = 0; k < motion_.size(); ++k) {
    // The message is built only for a piece the quick test refuses (a gate builds paths per scale).
    if (isValidMotion(motion_[k])) continue;
    validateMotion(motion_[k], k == 0 || k >= keyframes_.size()
                                   ? "TimedPath: keyframe " + std::to_string(k == 0 ? 0 : keyframes_.size() - 1)
                                   : "TimedPath: piece from keyframe " + std::to_string(k - 1) + " to " +
                                         std::to_string(k));
  }
}

TimedPath::TimedPath(const Motion& motion) {
  // The message is built only for a motion the quick test refuses (a chain per link per cycle).
  if (!isValidMotion(motion)) validateMotion(motion, "TimedPath: motion");
  Keyframe k;
  k.time = motion.t_ref;
  k.position = motion.position;
  k.orientation = motion.orientation;
  keyframes_.push_back(k);
  motion_.push_back(motion);
}

double TimedPath::start(size_t k) const {
  if (k == 0) return -std::numeric_limits<double>::infinity();
  if (k > start_.size()) return std::numeric_limits<double>::infinity();
  return start_[k - 1];
}

double TimedPath::travel(double t0, double t1) const {
  double d = 0.0;
  forEachPiece(t0, t1, [&](size_t k, double s, double e) { d += originSpeed(motion_[k]) * (e - s); });
  return d;
}

size_t TimedPath::pieceAt(double t) const {
  return static_cast<size_t>(std::upper_bound(start_.begin(), start_.end(), t) - start_.begin());
}

TimeOfImpact timeOfImpact(const PreparedShape& a, const TimedPath& pa, const PreparedShape& b, const TimedPath& pb,
                    double t0, double t1, const ToiOptions& options) {
  if (!(std::isfinite(t0) && std::isfinite(t1) && t0 <= t1)) {
    throw InvalidArgument("timeOfImpact: need finite t0 <= t1, got t0 = " + formatNumber(t0) +
                          ", t1 = " + formatNumber(t1));
  }
  size_t ka = pa.pieceAt(t0), kb = pb.pieceAt(t0);
  double s = t0;
  int iterations = 0;
  for (;;) {
    const double e = std::min({t1, pa.start(ka + 1), pb.start(kb + 1)});
    TimeOfImpact out = timeOfImpact(a, pa.motion(ka), b, pb.motion(kb), s, e, options);
    iterations += out.iterations;
    if (out.hit || out.undecided || e >= t1) {
      out.iterations = iterations;
      out.initially_touching = out.initially_touching && s == t0;
      return out;
    }
    // Clear (certified) on [s, e]: on to the next stretch.
    if (pa.start(ka + 1) <= e) ++ka;
    if (pb.start(kb + 1) <= e) ++kb;
    s = e;
  }
}

}  // namespace vadop
