// A link at the end of a serial chain of joints on a moving base (an arm's link, a mobile
// manipulator's gripper), and its first contact with another such link, certified as the rest
// of the narrow phase. Each joint moves along a JointPath (constant velocity up to a limit, or
// timed positions of a joint trajectory, linear between them); the base moves along a TimedPath.
// It does not model joint accelerations within a piece, nor closed chains or mimic joints.
#pragma once

#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"
#include "vadop/timed_path.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <limits>
#include <vector>

namespace vadop {

// A joint position over time through timed positions: between two of them the straight line,
// or with velocities the cubic Hermite through both positions and velocities (as ros_control's
// joint_trajectory_controller interpolates); the first position before the first time, and
// after the last time moving on at velocity_after (0: holds). Revolute positions in rad,
// prismatic in m.
class JointPath {
 public:
  // Holds `position` at every time.
  JointPath() : JointPath({0.0}, {0.0}) {}
  // Throws vadop::InvalidArgument naming the entry: no position, sizes differ, a NaN/Inf,
  // times that do not increase. `velocities`: none (straight lines) or one per time.
  JointPath(std::vector<double> times, std::vector<double> positions, double velocity_after = 0.0,
            std::vector<double> velocities = {});
  // From `position` at t_ref on, moving at `velocity` until it reaches lower or upper (then
  // holds there; a position outside the limits is clamped first). Before t_ref it holds.
  // Throws on NaN, lower > upper. Infinite limits: none.
  static JointPath constantVelocity(double t_ref, double position, double velocity,
                                    double lower = -std::numeric_limits<double>::infinity(),
                                    double upper = std::numeric_limits<double>::infinity());

  double positionAt(double t) const;
  // The velocity at t (of the piece that holds from t on).
  double velocityAt(double t) const;
  // Both at t, from one lookup of the piece.
  struct State {
    double position = 0.0, velocity = 0.0;
  };
  State stateAt(double t) const;
  const std::vector<double>& times() const { return times_; }
  const std::vector<double>& positions() const { return positions_; }
  const std::vector<double>& velocities() const { return velocities_; }
  double velocityAfter() const { return velocity_after_; }
  // The first time > t at which the velocity may jump (+inf: none).
  double nextBreak(double t) const;
  // Upper bounds over [t0, t1] of |velocity|, of |position| and, when no velocity jumps inside
  // (t0, t1) (nextBreak), of |acceleration|.
  double maxSpeed(double t0, double t1) const;
  double maxAbsPosition(double t0, double t1) const;
  double maxAcceleration(double t0, double t1) const;

 private:
  struct Cubic {
    double h = 1.0;            // the piece's duration
    double c[4] = {0, 0, 0, 0};  // q(u) = c0 + c1 u + c2 u^2 + c3 u^3, u in [0, 1]
    double at(double u) const;
    double rate(double u) const;  // dq/dt
  };
  // Piece k in 1 .. n-1, with the largest |dq/dt| and |d2q/dt2| over it (computed once: the
  // narrow phase asks for them at every stretch of every pair).
  struct Piece {
    Cubic cubic;
    double max_rate = 0.0, max_acceleration = 0.0;
  };
  size_t pieceAt(double t) const;  // piece k holds on [times[k-1], times[k]); 0 before, n after
  const Cubic& cubic(size_t k) const { return pieces_[k - 1].cubic; }  // k in 1 .. n-1
  double maxRate(size_t k) const;  // max |dq/dt| over piece k
  std::vector<double> times_, positions_, velocities_;
  double velocity_after_ = 0.0;
  std::vector<Piece> pieces_;
};

enum class JointType { kFixed, kRevolute, kPrismatic };  // a URDF continuous joint is kRevolute

struct ChainJoint {
  JointType type = JointType::kFixed;
  // The joint frame in its parent link's frame at position 0 (URDF <origin>); the child link's
  // frame is the joint frame turned about / slid along `axis` by the position.
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // joint frame; normalised on construction
  JointPath path;                                    // ignored for kFixed
};

class LinkChain {
 public:
  // The link's pose at t is base.poseAt(t) * origin_1 * J_1(q_1(t)) * ... * origin_n * J_n(q_n(t))
  // (joints from the base to the link). Throws vadop::InvalidArgument naming the joint: a
  // non-finite origin or a rotation that is not orthonormal, a zero or non-finite axis.
  explicit LinkChain(TimedPath base, std::vector<ChainJoint> joints = {});

  Eigen::Isometry3d poseAt(double t) const;
  const TimedPath& base() const { return base_; }
  const std::vector<ChainJoint>& joints() const { return joints_; }
  // The link's pose at t with the velocity of its origin and its angular velocity (fixed
  // frame): poseAt, velocityOfPoint and angularVelocity in one pass over the joints.
  PosedTwist stateAt(double t) const;
  // Whether some joint moves somewhere in [t0, t1].
  bool jointsMove(double t0, double t1) const;
  // The first time > t at which a velocity (the base's or a joint's) may jump; +inf when none.
  double nextBreak(double t) const;
  // Bounds over [t0, t1], when no velocity jumps inside (t0, t1) (see nextBreak), for every
  // point within `radius` of the link's origin:
  // - speed: the base's twist acting on the point, plus each revolute joint's rate times the
  //   point's largest distance from the joint's axis point, plus each prismatic joint's rate;
  // - acceleration: the centripetal and Coriolis terms of the base's turning and of the joints,
  //   and the joints' own accelerations;
  // - angular_speed: the link's angular speed.
  // One pass over the joints (the narrow phase takes all three at every stretch).
  struct StretchBounds {
    double speed = 0.0, acceleration = 0.0, angular_speed = 0.0;
  };
  StretchBounds bounds(double t0, double t1, double radius) const;
  // Axis-aligned boxes (lo x y z, hi x y z) holding `shape` (link frame) over each of `parts`
  // consecutive parts of [t0, t1] (SweptBody::partEnd), 6 doubles each, velocity breaks inside
  // included: over each stretch, the shape's boxes at its two ends grown by its acceleration
  // bound times its length squared over 8 (every point stays that close to its chord). Tight
  // over short parts (the world's time slices), loose over long ones; conservative in floating
  // point.
  void partBoxes(const Shape& shape, double t0, double t1, int parts, double* out) const;
  // A bound on the distance of the link's origin from the base's origin over [t0, t1].
  double reach(double t0, double t1) const;
  // The velocity at t of the material point of the link at x (fixed frame).
  Eigen::Vector3d velocityOfPoint(const Eigen::Vector3d& x, double t) const;
  // The link's angular velocity at t (fixed frame).
  Eigen::Vector3d angularVelocity(double t) const;

 private:
  TimedPath base_;
  std::vector<ChainJoint> joints_;
  std::vector<double> offset_;  // |origin_i translation|
};

// The first t in [t0, t1] at which link a (moved by ca) and link b (by cb) touch, with the
// contract of time_of_impact.h (never after the first contact, a certified clear window, or
// undecided when the budget runs out). While no joint moves, each stretch is the TimedPath
// narrow phase; otherwise conservative advancement on the certified GJK lower bound with the
// chains' bounds (LinkChain::bounds) over each stretch of constant velocities.
// Throws as timeOfImpact.
TimeOfImpact timeOfImpact(const PreparedShape& a, const LinkChain& ca, const PreparedShape& b, const LinkChain& cb,
                    double t0, double t1, const ToiOptions& options = {});

}  // namespace vadop
