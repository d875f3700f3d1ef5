// Keyframes of a motion and of braking along it (timed_path.h): what a velocity gate asks of a
// robot that holds a command, then brakes to standstill, and of others that may brake.
#include "vadop/error.h"
#include "vadop/timed_path.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace vadop {
namespace {

constexpr double kQuarterTurn = 1.5707963267948966;  // rad: a piece's largest turn
constexpr double kShortest = 1e-9;                  // s: shorter stretches add no keyframe
constexpr int kMaxBrakingPieces = 512;

Keyframe keyframeAt(const Motion& motion, double t_motion, double t) {
  Keyframe k;
  k.time = t;
  k.position = motion.positionAt(t_motion);
  k.orientation = motion.orientationAt(t_motion);
  return k;
}

void appendFirst(const Motion& motion, double t0, std::vector<Keyframe>& out) {
  if (out.empty() || out.back().time < t0) out.push_back(keyframeAt(motion, t0, t0));
}

}  // namespace

double originSpeed(const Motion& motion) {
  // The origin's velocity at t_ref; along a screw its length stays.
  return (motion.linear_velocity - motion.angular_velocity.cross(motion.pivot_offset)).norm();
}

void appendKeyframes(const Motion& motion, double t0, double t1, std::vector<Keyframe>& out) {
  appendFirst(motion, t0, out);
  const double length = t1 - t0;
  if (!(length >= kShortest)) return;
  const double turn = motion.angular_velocity.norm() * length;
  const int n = std::max(1, static_cast<int>(std::ceil(turn / kQuarterTurn)));
  for (int k = 1; k <= n; ++k) {
    const double t = k == n ? t1 : t0 + length * k / n;
    out.push_back(keyframeAt(motion, t, t));
  }
}

double appendBrakingKeyframes(const Motion& motion, double t0, double duration, double radius, double max_deviation,
                              std::vector<Keyframe>& out) {
  if (!(std::isfinite(duration) && duration >= 0.0)) {
    throw InvalidArgument("appendBrakingKeyframes: duration must be finite and >= 0, got " + formatNumber(duration));
  }
  if (!(std::isfinite(radius) && radius >= 0.0)) {
    throw InvalidArgument("appendBrakingKeyframes: radius must be finite and >= 0, got " + formatNumber(radius));
  }
  if (!(std::isfinite(max_deviation) && max_deviation > 0.0)) {
    throw InvalidArgument("appendBrakingKeyframes: max_deviation must be finite and > 0, got " +
                          formatNumber(max_deviation));
  }
  appendFirst(motion, t0, out);
  if (!(duration >= kShortest)) return 0.0;
  const double speed = originSpeed(motion) + motion.angular_velocity.norm() * radius;
  // Stretches of duration / n; the first, the fastest, turns by at most |w| duration / n.
  const double by_deviation = std::ceil(std::sqrt(speed * duration / (8.0 * max_deviation)));
  const double by_turn = std::ceil(motion.angular_velocity.norm() * duration / kQuarterTurn);
  const int n = static_cast<int>(std::min<double>(kMaxBrakingPieces, std::max({1.0, by_deviation, by_turn})));
  // The parameter of motion (time after t0) reached at u: u - u^2 / (2 duration).
  const auto along = [duration](double u) { return u - u * u / (2.0 * duration); };
  for (int k = 1; k <= n; ++k) {
    const double u = k == n ? duration : duration * k / n;
    out.push_back(keyframeAt(motion, t0 + along(u), t0 + u));
  }
  return speed * duration / (8.0 * static_cast<double>(n) * n);
}

}  // namespace vadop
