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

// The first t in [t0, t1] at which a (along pa) and b (along pb) touch: timeOfImpact on each
// stretch of the window where both stay on one piece, in time order, with its contract; an
// undecided stretch ends the search (undecided from there). Throws as timeOfImpact.
TimeOfImpact timeOfImpact(const PreparedShape& a, const TimedPath& pa, const PreparedShape& b, const TimedPath& pb,
                    double t0, double t1, const ToiOptions& options = {});

}  // namespace vadop
