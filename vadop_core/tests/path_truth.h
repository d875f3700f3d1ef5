// The tests' own interpolation of timed paths (timed_path.h), nothing from the library but the
// Motion record: between two keyframes the screw that joins them (the rotation from the
// matrices, its axis and angle by Eigen's AngleAxis, an axis point by least squares), before the
// first keyframe and after the last (kHold) the pose held. test_timed_path and test_joint_chain
// (chains on a path) pose bodies with it through toi_truth::poseAt.
#pragma once

#include "vadop/motion.h"
#include "vadop/timed_path.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <limits>
#include <vector>

namespace path_truth {

using Eigen::AngleAxisd;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using vadop::AfterPath;
using vadop::Keyframe;

struct TruthPiece {
  double start, end;  // holds on [start, end)
  vadop::Motion motion;
};

inline vadop::Motion truthRest(const Keyframe& k) {
  vadop::Motion m;
  m.t_ref = k.time;
  m.position = k.position;
  m.orientation = k.orientation.normalized();
  return m;
}

// The screw taking k0 to k1: R = R1 R0^T; its axis u and angle from the matrix; the slide
// d_par = (u . d) u; an axis point c from (I - R) c = p1 - R p0 - d_par (least squares: the
// system is singular along u). The body origin then turns about c while c slides.
inline vadop::Motion truthScrew(const Keyframe& k0, const Keyframe& k1) {
  const double dt = k1.time - k0.time;
  const Matrix3d R = k1.orientation.normalized().toRotationMatrix() * k0.orientation.normalized().toRotationMatrix().transpose();
  const AngleAxisd aa(R);
  const double theta = aa.angle();
  const Vector3d u = aa.axis();
  const Vector3d d = k1.position - k0.position;
  vadop::Motion m = truthRest(k0);
  m.angular_velocity = u * theta / dt;
  m.linear_velocity = d / dt;
  if (theta == 0.0) return m;
  const Vector3d d_par = u * u.dot(d);
  const Matrix3d A = Matrix3d::Identity() - R;
  const Vector3d c = A.jacobiSvd(Eigen::ComputeFullU | Eigen::ComputeFullV)
                         .setThreshold(1e-9)
                         .solve(k1.position - R * k0.position - d_par);
  Vector3d arm = c - k0.position;
  arm -= u * u.dot(arm);  // the axis point nearest p0
  if (!(arm.norm() <= 1e5)) return m;  // timed_path.h: a far axis slides straight
  m.linear_velocity = d_par / dt;
  m.pivot_offset = arm;
  return m;
}

inline std::vector<TruthPiece> truthPieces(const std::vector<Keyframe>& k, AfterPath after) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<TruthPiece> out;
  out.push_back({-inf, k.front().time, truthRest(k.front())});
  for (size_t i = 1; i < k.size(); ++i) out.push_back({k[i - 1].time, k[i].time, truthScrew(k[i - 1], k[i])});
  if (after == AfterPath::kHold || k.size() == 1) {
    out.push_back({k.back().time, inf, truthRest(k.back())});
  } else {
    out.back().end = inf;
  }
  return out;
}

inline const vadop::Motion& truthAt(const std::vector<TruthPiece>& p, double t) {
  for (const TruthPiece& x : p) {
    if (t >= x.start && t < x.end) return x.motion;
  }
  return p.back().motion;
}

}  // namespace path_truth
