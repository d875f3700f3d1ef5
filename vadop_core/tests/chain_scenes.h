// Random joint chains for the tests and the benchmark of joint_chain.h: the tests' own
// description of a chain (TChain), their own joint interpolation and forward kinematics
// (truthPose: rotation matrices by Rodrigues' formula, composed by hand; nothing from the
// library), the library's LinkChain built from it (ours), and random scenes of a chain's link
// passing near another link or a rigid body; the chain's base moves with one twist or along a
// timed path (a mobile manipulator on its plan: the path's truth from path_truth.h).
#pragma once

#include "path_truth.h"
#include "toi_scenes.h"
#include "toi_truth.h"

#include "vadop/joint_chain.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

namespace chain_scenes {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using vadop::ChainJoint;
using vadop::JointPath;
using vadop::JointType;
using vadop::LinkChain;
using vadop::TimedPath;

// ------------------------------------------------------------------------------------------
// The test's own description of a chain, and its own kinematics.

struct TJoint {
  JointType type = JointType::kFixed;
  Matrix3d R = Matrix3d::Identity();  // origin
  Vector3d p = Vector3d::Zero();
  Vector3d axis = Vector3d::UnitZ();  // unit
  std::vector<double> times{0.0}, q{0.0};
  std::vector<double> qd;  // empty: straight lines between the times; else the Hermite cubic
  double after = 0.0;
};

struct TChain {
  vadop::Motion base;              // the base's twist, unless it follows `path`
  std::vector<vadop::Keyframe> path;  // when not empty: the base's timed path
  vadop::AfterPath after = vadop::AfterPath::kContinue;
  std::vector<TJoint> joints;
  mutable std::vector<path_truth::TruthPiece> pieces;  // the truth's pieces of `path`, made on first use
};

inline const std::vector<path_truth::TruthPiece>& truthPieces(const TChain& c) {
  if (c.pieces.empty()) c.pieces = path_truth::truthPieces(c.path, c.after);
  return c.pieces;
}

// The base's motion at t: its twist, or the truth's piece of its path.
inline const vadop::Motion& truthBase(const TChain& c, double t) {
  return c.path.empty() ? c.base : path_truth::truthAt(truthPieces(c), t);
}

inline double truthQ(const TJoint& j, double t) {
  if (t <= j.times.front()) return j.q.front();
  if (t >= j.times.back()) return j.q.back() + j.after * (t - j.times.back());
  for (size_t i = 1; i < j.times.size(); ++i) {
    if (t < j.times[i]) {
      const double h = j.times[i] - j.times[i - 1], u = (t - j.times[i - 1]) / h;
      if (j.qd.empty()) return j.q[i - 1] + (j.q[i] - j.q[i - 1]) * u;
      // The Hermite basis, as in the textbooks.
      const double h00 = 2 * u * u * u - 3 * u * u + 1, h10 = u * u * u - 2 * u * u + u;
      const double h01 = -2 * u * u * u + 3 * u * u, h11 = u * u * u - u * u;
      return h00 * j.q[i - 1] + h10 * h * j.qd[i - 1] + h01 * j.q[i] + h11 * h * j.qd[i];
    }
  }
  return j.q.back();
}

inline toi_truth::Pose truthPose(const TChain& c, double t) {
  toi_truth::Pose P = toi_truth::poseAt(truthBase(c, t), t);
  for (const TJoint& j : c.joints) {
    P.p = P.p + P.R * j.p;
    P.R = P.R * j.R;
    if (j.type == JointType::kRevolute) P.R = P.R * toi_truth::rodrigues(j.axis * truthQ(j, t));
    if (j.type == JointType::kPrismatic) P.p = P.p + P.R * (j.axis * truthQ(j, t));
  }
  return P;
}

// Upper bounds over the whole window: |joint rate| and |prismatic position|.
// With velocities, from the basis' derivatives (|h00'|, |h01'| <= 1.5, |h10'|, |h11'| <= 1)
// and values (h00, h01 in [0, 1], |h10|, |h11| <= 4/27).
inline double truthRate(const TJoint& j) {
  double v = std::abs(j.after);
  for (size_t i = 1; i < j.times.size(); ++i) {
    const double h = j.times[i] - j.times[i - 1];
    const double dq = std::abs(j.q[i] - j.q[i - 1]);
    v = std::max(v, j.qd.empty() ? dq / h : 1.5 * dq / h + std::abs(j.qd[i - 1]) + std::abs(j.qd[i]));
  }
  return v;
}
inline double truthTravel(const TJoint& j, double t0, double t1) {
  double m = std::max(std::abs(truthQ(j, t0)), std::abs(truthQ(j, t1)));
  for (double q : j.q) m = std::max(m, std::abs(q));
  if (!j.qd.empty()) {
    for (size_t i = 1; i < j.times.size(); ++i) {
      const double h = j.times[i] - j.times[i - 1];
      m = std::max(m, std::abs(j.q[i - 1]) + std::abs(j.q[i]) + 4.0 / 27.0 * h * (std::abs(j.qd[i - 1]) + std::abs(j.qd[i])));
    }
  }
  return m;
}

// Every point of the link within `lever` of its origin moves at most this fast on [t0, t1]:
// the whole chain's reach (all offsets, all travel) at every joint and at the base.
inline double truthSpeed(const TChain& c, double lever, double t0, double t1) {
  double reach = lever;
  for (const TJoint& j : c.joints) {
    reach += j.p.norm();
    if (j.type == JointType::kPrismatic) reach += truthTravel(j, t0, t1);
  }
  // The base's twist on that reach: its one twist, or the fastest of its path's pieces over the window.
  double v = 0.0;
  const auto base = [&](const vadop::Motion& m) {
    v = std::max(v, m.linear_velocity.norm() + m.angular_velocity.norm() * (reach + m.pivot_offset.norm()));
  };
  if (c.path.empty()) {
    base(c.base);
  } else {
    for (const path_truth::TruthPiece& x : truthPieces(c)) {
      if (x.end > t0 && x.start < t1) base(x.motion);
    }
  }
  for (const TJoint& j : c.joints) {
    if (j.type == JointType::kRevolute) v += truthRate(j) * reach;
    if (j.type == JointType::kPrismatic) v += truthRate(j);
  }
  return v;
}

inline LinkChain ours(const TChain& c) {
  std::vector<ChainJoint> joints;
  for (const TJoint& j : c.joints) {
    ChainJoint x;
    x.type = j.type;
    x.origin = Isometry3d::Identity();
    x.origin.linear() = j.R;
    x.origin.translation() = j.p;
    x.axis = j.axis;
    x.path = JointPath(j.times, j.q, j.after, j.qd);
    joints.push_back(x);
  }
  return LinkChain(c.path.empty() ? TimedPath(c.base) : TimedPath(c.path, c.after), joints);
}

// ------------------------------------------------------------------------------------------
// Random chains and scenes.

inline TJoint randomJoint(toi_scenes::Rng& r) {
  TJoint j;
  const double kind = r.uni(0.0, 1.0);
  j.type = kind < 0.7 ? JointType::kRevolute : kind < 0.9 ? JointType::kPrismatic : JointType::kFixed;
  if (r.chance(0.5)) j.R = r.quat().toRotationMatrix();
  j.p = r.unit() * r.uni(0.05, 0.4);
  j.axis = r.chance(0.5) ? Vector3d::UnitZ() : r.unit();
  const bool prismatic = j.type == JointType::kPrismatic;
  const double qs = prismatic ? 0.2 : 1.0, vs = prismatic ? 0.3 : 1.5;
  if (r.chance(0.6)) {  // constant rate
    j.times = {0.0};
    j.q = {r.uni(-qs, qs)};
    j.after = r.uni(-vs, vs);
  } else {  // a joint trajectory: timed positions, then it holds
    const int n = r.integer(3, 6);
    j.times.clear();
    j.q.clear();
    double t = r.uni(-0.3, 0.3), q = r.uni(-qs, qs);
    for (int i = 0; i < n; ++i) {
      j.times.push_back(t);
      j.q.push_back(q);
      const double dt = r.uni(0.1, 0.6);
      t += dt;
      q += r.uni(-vs, vs) * dt;
    }
    if (r.chance(0.5)) {  // with velocities: the cubic through them
      for (int i = 0; i < n; ++i) j.qd.push_back(i == 0 || i == n - 1 ? 0.0 : r.uni(-vs, vs));
    }
    j.after = 0.0;
  }
  return j;
}

// on_path: the base follows 2 to 5 keyframes (times from before the window to past it, up to
// 0.5 m and 1 rad apart; held or continued after the last) instead of one twist.
inline TChain randomChain(toi_scenes::Rng& r, int joints, bool on_path = false) {
  TChain c;
  c.base.position = r.inBox(0.5);
  c.base.orientation = r.quat();
  if (r.chance(0.5)) c.base.linear_velocity = r.unit() * r.uni(0.0, 0.5);
  if (r.chance(0.4)) c.base.angular_velocity = r.unit() * r.uni(0.0, 0.6);
  for (int i = 0; i < joints; ++i) c.joints.push_back(randomJoint(r));
  if (on_path) {
    const int n = r.integer(2, 5);
    double t = r.uni(-0.5, 0.5);
    vadop::Keyframe k;
    k.position = c.base.position;
    k.orientation = c.base.orientation;
    for (int i = 0; i < n; ++i) {
      k.time = t;
      c.path.push_back(k);
      t += r.uni(0.2, 0.8);
      k.position += r.unit() * r.uni(0.0, 0.5);
      k.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(r.uni(0.0, 1.0), r.unit())) * k.orientation;
    }
    c.after = r.chance(0.5) ? vadop::AfterPath::kHold : vadop::AfterPath::kContinue;
  }
  return c;
}

// The chain moved by d (its base's twist or every keyframe of its path).
inline void shift(TChain& c, const Vector3d& d) {
  c.base.position += d;
  for (vadop::Keyframe& k : c.path) k.position += d;
  c.pieces.clear();
}

inline vadop::Shape randomLinkShape(toi_scenes::Rng& r) {
  static const vadop::ShapeType types[] = {vadop::ShapeType::kSphere, vadop::ShapeType::kBox,
                                           vadop::ShapeType::kCapsule, vadop::ShapeType::kCylinder,
                                           vadop::ShapeType::kConvex};
  vadop::Shape s;
  do {
    s = toi_scenes::randomShape(types[r.integer(0, 4)], r);
  } while (s.bounding_radius > 0.4);
  return s;
}

struct Case {
  vadop::Shape sa, sb;
  TChain a, b;
};

// a: a chain of n joints; b: a rigid body or another chain, placed so that it passes near a's
// link at a random time of the window.
// on_path: a's base (and b's when b is a chain, half the time) on a timed path.
inline Case randomCase(toi_scenes::Rng& r, int n, bool on_path = false) {
  Case c;
  c.sa = randomLinkShape(r);
  c.sb = randomLinkShape(r);
  c.a = randomChain(r, n, on_path);
  const int nb = r.chance(0.5) ? 0 : r.integer(1, n);
  c.b = randomChain(r, nb, on_path && nb > 0 && r.chance(0.5));
  const double tc = r.uni(0.1, 1.9);
  const Vector3d target = truthPose(c.a, tc).p + r.unit() * r.uni(0.0, 1.2 * (c.sa.bounding_radius + c.sb.bounding_radius));
  shift(c.b, target - truthPose(c.b, tc).p);
  return c;
}

}  // namespace chain_scenes
