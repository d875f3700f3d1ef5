// A body moving through timed poses (a planned path, a sampled trajectory), and its first
// contact with another such body. Between consecutive keyframes the body moves with the
// constant twist that joins them (Chasles' screw: a rotation about one axis and a slide along
// it), so each piece is a Motion and the narrow phase keeps its certificate on every piece.
// Before the first keyframe the body holds its first pose; after the last it holds
// (AfterPath::kHold) or goes on with the last piece's twist (kContinue). It does not smooth:
// the velocity jumps at the keyframes. The broad phases move every body with one Motion;
// World::setPath puts a body on a path (its partners found by queries along each piece).
#pragma once

#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace vadop {

struct Keyframe {
  double time = 0.0;                                               // s
  Eigen::Vector3d position = Eigen::Vector3d::Zero();              // body origin, fixed frame
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity(); // normalised on construction
};

enum class AfterPath { kHold, kContinue };

class TimedPath {
 public:
  // Throws vadop::InvalidArgument naming the keyframe and field: no keyframe, a NaN/Inf, a
  // zero quaternion, times that do not increase, or a piece whose motion is beyond the range
  // of error.h (e.g. two keyframes 1 ns apart and metres away). Each piece turns the
  // shortest way (at most half a turn): keyframes must be dense enough for that.
  explicit TimedPath(std::vector<Keyframe> keyframes, AfterPath after = AfterPath::kContinue);
  // One constant twist at every time (a path of one piece). Throws as validateMotion.
  explicit TimedPath(const Motion& motion);

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  size_t pieces() const { return motion_.size(); }
  // Piece k holds on [start(k), start(k + 1)); start(0) = -inf, start(pieces()) = +inf.
  double start(size_t k) const;
  const Motion& motion(size_t k) const { return motion_[k]; }
  // The piece that holds at t.
  size_t pieceAt(double t) const;
  // f(k, from, to) for each piece k that holds somewhere in [t0, t1] (t0 <= t1), in order, with
  // the stretch [from, to] of the window it covers (the stretches tile the window).
  template <class F>
  void forEachPiece(double t0, double t1, F&& f) const {
    const size_t first = pieceAt(t0);
    for (size_t k = first; k < pieces() && (k == first || start(k) < t1); ++k) {
      f(k, std::max(t0, start(k)), std::min(t1, start(k + 1)));
    }
  }
  Eigen::Isometry3d poseAt(double t) const { return motion_[pieceAt(t)].poseAt(t); }
  // The fixed-frame velocity at t of the body point at fixed-frame x (the piece in effect at t).
  Eigen::Vector3d velocityOfPoint(const Eigen::Vector3d& x, double t) const {
    return motion_[pieceAt(t)].velocityOfPoint(x, t);
  }
  // How far the body origin travels along the path over [t0, t1] (t0 <= t1): the length of its
  // trajectory, each piece's origin speed (originSpeed) times its stretch.
  double travel(double t0, double t1) const;

 private:
  std::vector<Keyframe> keyframes_;
  std::vector<Motion> motion_;
  std::vector<double> start_;  // start_[k] = start(k + 1): the keyframe times between pieces
};

// The constant twist taking pose (p0, q0) at t0 to (p1, q1) at t1 > t0 (the shortest
// rotation; a rotation below 1e-7 rad moves the origin on the straight segment), as a Motion
// with t_ref = t0. Unit quaternions; not validated.
Motion screwBetween(double t0, const Eigen::Vector3d& p0, const Eigen::Quaterniond& q0, double t1,
                    const Eigen::Vector3d& p1, const Eigen::Quaterniond& q1);

// Keyframes of a body following `motion` exactly over [t0, t1] (t0 <= t1), appended to `out`:
// its pose at t0 (left out when out's last keyframe is at t0 already), then poses at most a
// quarter turn apart up to t1, so that each piece of a TimedPath through them is `motion` itself
// (screwBetween recovers the screw). Nothing is appended after t0 when t1 - t0 < 1e-9 s. Not
// validated (validateMotion first).
void appendKeyframes(const Motion& motion, double t0, double t1, std::vector<Keyframe>& out);

// Braking along a motion: from t0 the body keeps to the path `motion` takes (the same screw),
// its speed falling at a constant rate from motion's to zero at t0 + duration, where it stands:
// at t0 + u (0 <= u <= duration) it is where `motion` puts it at t0 + u - u^2 / (2 duration),
// half the way motion would cover. The keyframes of that braking (as appendKeyframes: the pose at
// t0 first, the last at t0 + duration) are appended to `out`. Between two keyframes a TimedPath
// moves along the same screw at the stretch's mean speed, never farther than the returned bound
// (m) from the exact braking, for every material point within `radius` of the body origin: the
// secant of a parabola of n equal stretches is off by at most duration / (8 n^2) in motion's
// time, at the speed S = |origin velocity| + |w| radius. n is the smallest that keeps the bound
// within `max_deviation` (and each stretch within a quarter turn), at most 512 (the bound is
// then larger: it is what is returned). duration 0: the body stops at t0 (one keyframe).
// Throws vadop::InvalidArgument for a duration or radius < 0 or not finite, or a max_deviation
// <= 0 or not finite.
double appendBrakingKeyframes(const Motion& motion, double t0, double duration, double radius, double max_deviation,
                              std::vector<Keyframe>& out);

// How fast the origin of a body moving with `motion` goes (constant along a screw).
double originSpeed(const Motion& motion);

// The first t in [t0, t1] at which a (along pa) and b (along pb) touch: timeOfImpact on each
// stretch of the window where both stay on one piece, in time order, with its contract; an
// undecided stretch ends the search (undecided from there). Throws as timeOfImpact.
TimeOfImpact timeOfImpact(const PreparedShape& a, const TimedPath& pa, const PreparedShape& b, const TimedPath& pb,
                    double t0, double t1, const ToiOptions& options = {});

}  // namespace vadop
