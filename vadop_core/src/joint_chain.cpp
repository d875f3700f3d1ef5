// Conservative advancement for links of joint chains.
//
// Why the step is safe. On a stretch [s, e] where no velocity jumps, every point x of a link
// within radius r of its origin moves with the sum of the base's twist and each joint's twist:
//   v(x) = v_pivot + w_base x (x - pivot) + sum_revolute qdot_i axis_i x (x - p_i) + sum_prismatic qdot_i axis_i
// with p_i on joint i's axis. |x - p_i| is at most r plus the lengths of the joint origins after
// i (and the prismatic travels from i on), whatever the joint angles; |x - pivot| at most that
// from the base plus the base's pivot lever. So |v(x)| <= mu_a (LinkChain::bounds) and the gap of two
// links shrinks no faster than mu_a + mu_b: from a certified lower bound lb > tol/2 of the gap
// at t (distance.h's lower_bound), the gap stays > tol/2 on [t, t + (lb - tol/2) / (mu_a + mu_b)).
// Near a contact that first-order step converges slowly; the second certificate follows each
// link's twist at t (its pose, the velocity of its origin, its angular velocity): a point's
// distance from where that constant twist takes it grows at most as (A + |w|^2 r) D^2 / 2 over
// D, A bounding the point's acceleration on the stretch (LinkChain::bounds) and |w|^2 r the
// twist's own, so the constant-twist certificates of advance_step.h less that bound the gap.
// Each iteration either finds the gap <= tol at t (hit), or moves t to a time up to which the
// gap is certified > tol/2, never past the stretch's end (its bounds hold there only): the
// contract of time_of_impact.h.
#include "vadop/joint_chain.h"

#include "advance_step.h"
#include "body_side.h"
#include "contact_patch.h"
#include "vadop/error.h"
#include "vadop/vadop.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

namespace vadop {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The base piece `m` carrying a link rigidly at `offset` (link frame in the base frame): the
// link's own constant twist, turning about the base's pivot.
Motion carried(const Motion& m, const Eigen::Isometry3d& offset) {
  Motion out = m;
  const Eigen::Isometry3d base = m.poseAt(m.t_ref);
  const Eigen::Isometry3d link = base * offset;
  out.position = link.translation();
  out.orientation = Eigen::Quaterniond(link.rotation()).normalized();
  out.pivot_offset = m.position + m.pivot_offset - out.position;
  if (!m.isRotating()) out.pivot_offset.setZero();
  return out;
}

// The u in (0, 1) where the cubic's derivative (degree d = 1: of the derivative itself) is zero.
void stationary(const double* c, int count, double roots[2], int& n) {
  // a u^2 + b u + e = 0 with (a, b, e) = (3 c3, 2 c2, c1) (count 2: the derivative's derivative,
  // 6 c3 u + 2 c2 = 0).
  n = 0;
  if (count == 1) {
    if (c[3] != 0.0) {
      const double u = -c[2] / (3.0 * c[3]);
      if (u > 0.0 && u < 1.0) roots[n++] = u;
    }
    return;
  }
  const double a = 3.0 * c[3], b = 2.0 * c[2], e = c[1];
  if (a == 0.0) {
    if (b != 0.0 && -e / b > 0.0 && -e / b < 1.0) roots[n++] = -e / b;
    return;
  }
  const double disc = b * b - 4.0 * a * e;
  if (disc < 0.0) return;
  for (const double u : {(-b - std::sqrt(disc)) / (2.0 * a), (-b + std::sqrt(disc)) / (2.0 * a)}) {
    if (u > 0.0 && u < 1.0) roots[n++] = u;
  }
}

}  // namespace

JointPath::JointPath(std::vector<double> times, std::vector<double> positions, double velocity_after,
                     std::vector<double> velocities)
    : times_(std::move(times)),
      positions_(std::move(positions)),
      velocities_(std::move(velocities)),
      velocity_after_(velocity_after) {
  if (times_.empty()) throw InvalidArgument("JointPath: no position");
  if (times_.size() != positions_.size()) {
    throw InvalidArgument("JointPath: " + std::to_string(times_.size()) + " times but " +
                          std::to_string(positions_.size()) + " positions");
  }
  if (!velocities_.empty() && velocities_.size() != times_.size()) {
    throw InvalidArgument("JointPath: " + std::to_string(times_.size()) + " times but " +
                          std::to_string(velocities_.size()) + " velocities (give none or one per time)");
  }
  for (size_t i = 0; i < times_.size(); ++i) {
    if (!std::isfinite(times_[i])) throw InvalidArgument("JointPath: time " + std::to_string(i) + " is not finite");
    if (!std::isfinite(positions_[i])) {
      throw InvalidArgument("JointPath: position " + std::to_string(i) + " is not finite");
    }
    if (!velocities_.empty() && !std::isfinite(velocities_[i])) {
      throw InvalidArgument("JointPath: velocity " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(times_[i] > times_[i - 1])) {
      throw InvalidArgument("JointPath: time " + std::to_string(i) + " (" + formatNumber(times_[i]) +
                            ") does not increase");
    }
  }
  if (!std::isfinite(velocity_after_)) throw InvalidArgument("JointPath: velocity_after is not finite");
  // Piece k, in u = (t - times[k-1]) / h in [0, 1]: the Hermite cubic q(u) = c0 + c1 u + c2 u^2 +
  // c3 u^3 (c2 = c3 = 0 without velocities). Its rate is largest at an end or where its
  // derivative turns; its acceleration, linear in time, at an end.
  pieces_.resize(times_.size() - 1);
  for (size_t k = 1; k < times_.size(); ++k) {
    Piece& piece = pieces_[k - 1];
    Cubic& c = piece.cubic;
    c.h = times_[k] - times_[k - 1];
    const double p0 = positions_[k - 1], p1 = positions_[k];
    c.c[0] = p0;
    if (velocities_.empty()) {
      c.c[1] = p1 - p0;
    } else {
      const double m0 = velocities_[k - 1] * c.h, m1 = velocities_[k] * c.h;
      c.c[1] = m0;
      c.c[2] = -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1;
      c.c[3] = 2.0 * p0 + m0 - 2.0 * p1 + m1;
    }
    double v = std::max(std::abs(c.rate(0.0)), std::abs(c.rate(1.0)));
    double roots[2];
    int n = 0;
    stationary(c.c, 1, roots, n);
    for (int i = 0; i < n; ++i) v = std::max(v, std::abs(c.rate(roots[i])));
    piece.max_rate = v;
    piece.max_acceleration = std::max(std::abs(2.0 * c.c[2]), std::abs(2.0 * c.c[2] + 6.0 * c.c[3])) / (c.h * c.h);
  }
}

JointPath JointPath::constantVelocity(double t_ref, double position, double velocity, double lower, double upper) {
  if (!std::isfinite(t_ref) || !std::isfinite(position) || !std::isfinite(velocity)) {
    throw InvalidArgument("JointPath: t_ref, position and velocity must be finite");
  }
  if (std::isnan(lower) || std::isnan(upper) || lower > upper) {
    throw InvalidArgument("JointPath: need lower <= upper, got " + formatNumber(lower) + " > " + formatNumber(upper));
  }
  const double q = std::clamp(position, lower, upper);
  const double stop = velocity > 0.0 ? upper : velocity < 0.0 ? lower : q;
  if (!std::isfinite(stop)) return JointPath({t_ref}, {q}, velocity);
  const double dt = (stop - q) / velocity;
  if (velocity == 0.0 || !(dt > 0.0) || !std::isfinite(t_ref + dt) || !(t_ref + dt > t_ref)) {
    return JointPath({t_ref}, {q}, 0.0);
  }
  return JointPath({t_ref, t_ref + dt}, {q, stop}, 0.0);
}

size_t JointPath::pieceAt(double t) const {
  return static_cast<size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());
}

double JointPath::Cubic::at(double u) const { return c[0] + u * (c[1] + u * (c[2] + u * c[3])); }
double JointPath::Cubic::rate(double u) const { return (c[1] + u * (2.0 * c[2] + u * 3.0 * c[3])) / h; }

double JointPath::maxRate(size_t k) const {
  if (k == 0) return 0.0;
  if (k >= times_.size()) return std::abs(velocity_after_);
  return pieces_[k - 1].max_rate;
}

JointPath::State JointPath::stateAt(double t) const {
  const size_t k = pieceAt(t);
  if (k == 0) return {positions_.front(), 0.0};
  if (k == times_.size()) return {positions_.back() + velocity_after_ * (t - times_.back()), velocity_after_};
  const Cubic& c = cubic(k);
  const double u = (t - times_[k - 1]) / c.h;
  return {c.at(u), c.rate(u)};
}

double JointPath::positionAt(double t) const { return stateAt(t).position; }

double JointPath::velocityAt(double t) const { return stateAt(t).velocity; }

double JointPath::nextBreak(double t) const {
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  return it == times_.end() ? kInf : *it;
}

double JointPath::maxSpeed(double t0, double t1) const {
  double v = 0.0;
  for (size_t k = pieceAt(t0), k1 = pieceAt(t1); k <= k1; ++k) v = std::max(v, maxRate(k));
  return v;
}

double JointPath::maxAcceleration(double t0, double t1) const {
  // A cubic piece's acceleration is linear in time: largest at one of its ends. Before the first
  // time and after the last the velocity is constant.
  double a = 0.0;
  for (size_t k = pieceAt(t0), k1 = pieceAt(t1); k <= k1; ++k) {
    if (k > 0 && k < times_.size()) a = std::max(a, pieces_[k - 1].max_acceleration);
  }
  return a;
}

double JointPath::maxAbsPosition(double t0, double t1) const {
  // The extremes are at the ends, at the times in between, or where a cubic piece turns
  // (over each piece that holds in [t0, t1], a superset).
  double m = std::max(std::abs(positionAt(t0)), std::abs(positionAt(t1)));
  for (size_t k = pieceAt(t0), k1 = pieceAt(t1); k <= k1; ++k) {
    if (k == 0 || k >= times_.size()) continue;
    const Cubic& c = cubic(k);
    if (times_[k] < t1) m = std::max(m, std::abs(positions_[k]));
    double roots[2];
    int n = 0;
    stationary(c.c, 2, roots, n);
    for (int i = 0; i < n; ++i) m = std::max(m, std::abs(c.at(roots[i])));
  }
  return m;
}

LinkChain::LinkChain(TimedPath base, std::vector<ChainJoint> joints)
    : base_(std::move(base)), joints_(std::move(joints)) {
  for (size_t i = 0; i < joints_.size(); ++i) {
    ChainJoint& j = joints_[i];
    auto fail = [i](const char* what) {
      throw InvalidArgument("LinkChain: joint " + std::to_string(i) + ": " + what);
    };
    if (!j.origin.matrix().allFinite()) fail("origin is not finite");
    const Eigen::Matrix3d r = j.origin.linear();
    if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() <= 1e-6 && r.determinant() > 0.0)) {
      fail("origin rotation is not a rotation");
    }
    if (j.type != JointType::kFixed) {
      if (!j.axis.allFinite() || j.axis.norm() < 1e-9) fail("axis is zero or not finite");
      j.axis.normalize();
    }
    offset_.push_back(j.origin.translation().norm());
  }
}

Eigen::Isometry3d LinkChain::poseAt(double t) const { return stateAt(t).pose; }

bool LinkChain::jointsMove(double t0, double t1) const {
  for (const ChainJoint& j : joints_) {
    if (j.type != JointType::kFixed && j.path.maxSpeed(t0, t1) > 0.0) return true;
  }
  return false;
}

double LinkChain::nextBreak(double t) const {
  double e = base_.start(base_.pieceAt(t) + 1);
  for (const ChainJoint& j : joints_) {
    if (j.type != JointType::kFixed) e = std::min(e, j.path.nextBreak(t));
  }
  return e;
}

LinkChain::StretchBounds LinkChain::bounds(double t0, double t1, double radius) const {
  // Speed: reach = the largest distance from joint i's axis point to the link's origin, built
  // from the link back to the base; a point x within radius of the origin then moves at most at
  // sum_revolute |qdot_i| (reach_i + radius) + sum_prismatic |qdot_i| + the base's twist on it.
  // Acceleration: x moves with v = V + W x (x - c) + sum_j u_j (file header), with u_j =
  // qdot_j a_j x (x - p_j) (revolute) or qdot_j a_j (prismatic); the axis a_j turns with the
  // frame before joint j, at W_j = W + sum_{k < j} qdot_k a_k, and v - dp_j/dt = W_j x (x - p_j)
  // + sum_{k >= j} u_k. Differentiating along the point's path:
  //   |d/dt W x (x - c)| = |W x (v - V)| <= |W| (|W| rho_c + U_1)
  //   revolute:   |d/dt u_j| <= |qddot_j| rho_j + |qdot_j| (2 |W_j| rho_j + U_j)
  //   prismatic:  |d/dt u_j| <= |qddot_j| + |qdot_j| |W_j|
  // with rho the largest distances of x from c and from p_j, U_j = sum_{k >= j} |u_k|.
  // In one pass from the link back, with |W_j| = |W| + P_j (P_j the sum of the revolute rates
  // before j): the sum is A_const + |W| A_w + A_cross, A_cross collecting the P_j terms through
  // suffix sums (sum_j 2 |qdot_j| rho_j P_j = sum_k |qdot_k| 2 S_k, S_k = sum_{j > k} |qdot_j| rho_j
  // over revolute j; the prismatic ones alike with |qdot_j|). U_1 is also the joints' share of
  // the speed bound.
  double reach = 0.0, u_from = 0.0, a_const = 0.0, a_w = 0.0, a_cross = 0.0, joint_w = 0.0;
  double rev_after = 0.0, pri_after = 0.0;  // S_k, and the prismatic rates after k
  for (size_t i = joints_.size(); i-- > 0;) {
    const ChainJoint& j = joints_[i];
    if (j.type == JointType::kRevolute) {
      const double rate = j.path.maxSpeed(t0, t1), rho = reach + radius;
      u_from += rate * rho;
      a_const += j.path.maxAcceleration(t0, t1) * rho + rate * u_from;
      a_w += 2.0 * rate * rho;
      a_cross += rate * (2.0 * rev_after + pri_after);
      rev_after += rate * rho;
      joint_w += rate;
    } else if (j.type == JointType::kPrismatic) {
      const double rate = j.path.maxSpeed(t0, t1);
      reach += j.path.maxAbsPosition(t0, t1);
      u_from += rate;
      a_const += j.path.maxAcceleration(t0, t1);
      a_w += rate;
      pri_after += rate;
    }
    reach += offset_[i];
  }
  // The base: every piece that holds in [t0, t1].
  StretchBounds out;
  double base_speed = 0.0, base_w = 0.0;
  base_.forEachPiece(t0, t1, [&](size_t k, double, double) {
    const Motion& m = base_.motion(k);
    const double W = m.angular_velocity.norm();
    const double rho_c = m.pivot_offset.norm() + reach + radius;
    base_speed = std::max(base_speed, m.linear_velocity.norm() + W * rho_c);
    base_w = std::max(base_w, W);
    out.acceleration = std::max(out.acceleration, a_const + W * a_w + a_cross + W * (W * rho_c + u_from));
  });
  out.speed = u_from + base_speed;
  out.angular_speed = base_w + joint_w;
  return out;
}

void LinkChain::partBoxes(const Shape& shape, double t0, double t1, int parts, double* out) const {
  // No joint moves over the window and the base stays on one piece (a mobile manipulator's
  // base link, an arm at rest): the link is a rigid body on that piece's twist, whose boxes
  // SweptBody computes without posing the chain at every part's end.
  const size_t piece = base_.pieceAt(t0);
  if (piece == base_.pieceAt(t1) && !jointsMove(t0, t1)) {
    const Motion& m = base_.motion(piece);
    const double mid = 0.5 * (t0 + t1);
    SweptBody::partBoxes(shape, carried(m, m.poseAt(mid).inverse() * poseAt(mid)), t0, t1, parts, out);
    return;
  }
  // On a stretch [a, b] without velocity jumps every point's path is within A (b - a)^2 / 8 of
  // the chord between where it is at a and at b (|x''| <= A, the stretch's acceleration bound:
  // the interpolation error of a C1 path with A-Lipschitz velocity), so the link stays in the
  // boxes of its shape at a and at b grown by that. Over a time slice the growth is millimetres.
  // The shape's box at each end is computed once (a part's end is the next one's start).
  auto shapeBox = [&](double t, double* b) {
    const Eigen::Isometry3d pose = stateAt(t).pose;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d axis = pose.linear().row(k).transpose();  // the fixed axis k in the link frame
      const double c = pose.translation()[k];
      b[k] = c - support(shape, -axis);
      b[3 + k] = c + support(shape, axis);
    }
  };
  double at_a[6], at_b[6];
  shapeBox(t0, at_a);
  double a = t0;
  for (int p = 0; p < parts; ++p) {
    const double end = SweptBody::partEnd(t0, t1, p, parts);
    double* box = out + 6 * p;
    for (int k = 0; k < 3; ++k) {
      box[k] = std::numeric_limits<double>::infinity();
      box[3 + k] = -std::numeric_limits<double>::infinity();
    }
    for (;;) {
      const double b = std::min(end, nextBreak(a));
      const double grow = bounds(a, b, shape.bounding_radius).acceleration * (b - a) * (b - a) / 8.0;
      shapeBox(b, at_b);
      for (int k = 0; k < 3; ++k) {
        const double lo = std::min(at_a[k], at_b[k]) - grow, hi = std::max(at_a[3 + k], at_b[3 + k]) + grow;
        // Rounding of the poses and the supports: a few ulps of the magnitudes involved.
        const double widen = SweptBody::kRoundingWiden * (1.0 + std::max(std::abs(lo), std::abs(hi)) + grow);
        box[k] = std::min(box[k], lo - widen);
        box[3 + k] = std::max(box[3 + k], hi + widen);
      }
      a = b;
      std::copy_n(at_b, 6, at_a);
      if (!(b < end)) break;
    }
  }
}

double LinkChain::reach(double t0, double t1) const {
  double r = 0.0;
  for (size_t i = 0; i < joints_.size(); ++i) {
    r += offset_[i];
    if (joints_[i].type == JointType::kPrismatic) r += joints_[i].path.maxAbsPosition(t0, t1);
  }
  return r;
}

Eigen::Vector3d LinkChain::velocityOfPoint(const Eigen::Vector3d& x, double t) const {
  const PosedTwist s = stateAt(t);
  return s.velocity + s.angular_velocity.cross(x - s.pose.translation());
}

Eigen::Vector3d LinkChain::angularVelocity(double t) const { return stateAt(t).angular_velocity; }

PosedTwist LinkChain::stateAt(double t) const {
  // The velocity field of the link is affine, v(x) = lin + w x (x - c): accumulated about the
  // base's pivot c at t (small lever arms, no cancellation of large coordinates).
  const Motion& m = base_.motion(base_.pieceAt(t));
  const Eigen::Vector3d c = m.pivotAt(t);
  PosedTwist s;
  Eigen::Isometry3d frame = m.poseAt(t);
  Eigen::Vector3d lin = m.linear_velocity, w = m.angular_velocity;
  for (const ChainJoint& j : joints_) {
    frame = frame * j.origin;  // the joint's frame
    if (j.type == JointType::kFixed) continue;
    const JointPath::State q = j.path.stateAt(t);
    const Eigen::Vector3d axis = frame.linear() * j.axis;
    if (j.type == JointType::kPrismatic) {
      lin += q.velocity * axis;
      frame.translation() += q.position * axis;
      continue;
    }
    w += q.velocity * axis;
    lin -= q.velocity * axis.cross(frame.translation() - c);
    // R Rot(k, q) = cos q R + sin q [R k]x R + (1 - cos q) (R k) k^T (Rodrigues), column by column.
    const double cq = std::cos(q.position), sq = std::sin(q.position);
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d r = frame.linear().col(i);
      frame.linear().col(i) = cq * r + sq * axis.cross(r) + ((1.0 - cq) * j.axis[i]) * axis;
    }
  }
  s.pose = frame;
  s.angular_velocity = w;
  s.velocity = lin + w.cross(frame.translation() - c);
  return s;
}

namespace {

// One query of timeOfImpact for links of joint chains, stretch by stretch (between velocity
// jumps of either chain): the constant-twist narrow phase where both links ride rigidly on
// their bases, conservative advancement on the chains' bounds elsewhere.
class ChainImpactSearch {
 public:
  ChainImpactSearch(const PreparedShape& a, const LinkChain& ca, const PreparedShape& b, const LinkChain& cb,
                    double t0, double t1, const ToiOptions& options)
      : a_(a), ca_(ca), b_(b), cb_(cb), t0_(t0), t1_(t1), options_(options), t_(t0) {
    // A mesh: first-order steps alone (the twist steps take convex shapes), on distances to
    // 1/200 of the touch threshold near a contact and to 4e-3 of the gap farther out, as the
    // twist steps' (a step rests on the certified lower bound: a looser estimate only shortens it).
    mesh_ = a.shape().type == ShapeType::kMesh || b.shape().type == ShapeType::kMesh;
    dopt_.tolerance = options.tolerance / 200.0;
    dopt_.relative_tolerance = 4e-3;
  }

  TimeOfImpact run() {
    for (;;) {
      const double e = std::min({t1_, ca_.nextBreak(t_), cb_.nextBreak(t_)});
      const bool rigid = !ca_.jointsMove(t_, e) && !cb_.jointsMove(t_, e);
      if (rigid ? rigidStretch(e) : movingStretch(e)) return out_;
    }
  }

 private:
  void fill(double at, const DistanceResult& c) {
    out_.time = at;
    out_.normal = c.normal;
    out_.point = 0.5 * (c.point_a + c.point_b);
    out_.distance = c.distance;
  }

  // A contact at the query's start: the point where the links meet (contact_patch.h).
  void fillTouching(const DistanceResult& c) {
    out_.hit = true;
    out_.initially_touching = t_ == t0_;
    fill(t_, c);
    if (!out_.initially_touching) return;
    const Eigen::Isometry3d pa = ca_.poseAt(t_), pb = cb_.poseAt(t_);
    out_.point = detail::contactPatchPoint(detail::makeSide(a_.data(), pa.linear(), pa.translation()),
                                           detail::makeSide(b_.data(), pb.linear(), pb.translation()), c);
  }

  // Both links ride rigidly on their bases over [t, e]: the constant-twist narrow phase. True
  // when that decides the query (out_ holds the answer); else t moves to e.
  bool rigidStretch(double e) {
    const double t = t_;
    const double mid = t < e ? 0.5 * (t + e) : t;
    const Eigen::Isometry3d fa = ca_.base().poseAt(mid).inverse() * ca_.poseAt(mid);
    const Eigen::Isometry3d fb = cb_.base().poseAt(mid).inverse() * cb_.poseAt(mid);
    ToiOptions o = options_;
    o.max_iterations = options_.max_iterations - used_;
    if (o.max_iterations <= 0) {
      out_.undecided = true;
      out_.iterations = used_;
      out_.time = t;
      return true;
    }
    const Motion& ma = ca_.base().motion(ca_.base().pieceAt(mid));
    const Motion& mb = cb_.base().motion(cb_.base().pieceAt(mid));
    TimeOfImpact r = timeOfImpact(a_, carried(ma, fa), b_, carried(mb, fb), t, e, o);
    used_ += r.iterations;
    r.iterations = used_;
    r.initially_touching = r.initially_touching && t == t0_;
    if (r.hit || r.undecided || e >= t1_) {
      out_ = r;
      return true;
    }
    t_ = e;
    return false;
  }

  // Conservative advancement within [t, e] (the stretch's bounds hold up to e only). True when
  // that decides the query; else t moves to e.
  bool movingStretch(double e) {
    const double ra = a_.shape().bounding_radius, rb = b_.shape().bounding_radius;
    const LinkChain::StretchBounds ba = ca_.bounds(t_, e, ra), bb = cb_.bounds(t_, e, rb);
    const double mu = ba.speed + bb.speed;
    // Within the stretch each link stays within deviation D^2 / 2 of the constant twist it has
    // at t (the screw's own points accelerate by at most |w|^2 r): the twist steps' certificates
    // (advance_step.h) less that, which converge on a contact as fast as theirs.
    const double deviation = mesh_ ? 0.0
                                   : ba.acceleration + ba.angular_speed * ba.angular_speed * ra + bb.acceleration +
                                         bb.angular_speed * bb.angular_speed * rb;
    const double advance = 0.5 * options_.tolerance;
    for (;;) {
      double step = 0.0;
      DistanceResult d;
      if (measure(e, deviation, step, d)) return true;
      // The first-order certificate over the stretch: the gap's lower bound at the links'
      // speed bounds (longer than the twist step in about a quarter of the ground truths'
      // steps: far from a contact, where the deviation's D^2 has grown).
      step = std::max(step, mu > 0.0 ? (d.lower_bound - advance) / mu : kInf);
      const double next = t_ + step;
      const bool stuck = !(step > 0.0) || !(next > t_);  // no representable progress
      if (!stuck && next >= e) {
        if (e >= t1_ && next > t1_) {
          fill(t1_, d);
          return true;
        }
        t_ = e;
        return false;
      }
      if (stuck || used_ >= options_.max_iterations) {
        out_.undecided = true;  // certified clear up to t only
        fill(t_, d);
        return true;
      }
      t_ = next;
    }
  }

  // The gap at t: a twist step (its certified step into `step`) or, for a mesh, the distance.
  // True when that decides the query (a contact, or clear up to t1).
  bool measure(double e, double deviation, double& step, DistanceResult& d) {
    const double touch = options_.tolerance, advance = 0.5 * options_.tolerance;
    if (!mesh_) {
      const detail::AdvanceStep s = detail::advanceStepNearTwist(a_, ca_.stateAt(t_), b_, cb_.stateAt(t_), deviation,
                                                                 e - t_, touch, advance, &warm_);
      ++used_;
      out_.iterations = used_;
      if (s.touching) {
        fillTouching(s.closest);
        return true;
      }
      if (s.clear && e >= t1_) {
        fill(t1_, s.closest);
        return true;
      }
      d = s.closest;
      step = s.clear ? e - t_ : s.step;
      return false;
    }
    d = distance(a_, ca_.poseAt(t_), b_, cb_.poseAt(t_), dopt_);
    ++used_;
    out_.iterations = used_;
    if (d.distance <= touch) {
      fillTouching(d);
      return true;
    }
    return false;
  }

  const PreparedShape& a_;
  const LinkChain& ca_;
  const PreparedShape& b_;
  const LinkChain& cb_;
  const double t0_, t1_;
  const ToiOptions& options_;
  bool mesh_ = false;
  DistanceOptions dopt_;
  detail::WarmStart warm_;  // from one twist step to the next
  TimeOfImpact out_;
  int used_ = 0;
  double t_;
};

}  // namespace

TimeOfImpact timeOfImpact(const PreparedShape& a, const LinkChain& ca, const PreparedShape& b, const LinkChain& cb,
                    double t0, double t1, const ToiOptions& options) {
  if (!(std::isfinite(t0) && std::isfinite(t1) && t0 <= t1)) {
    throw InvalidArgument("timeOfImpact: need finite t0 <= t1, got t0 = " + formatNumber(t0) +
                          ", t1 = " + formatNumber(t1));
  }
  if (!(std::isfinite(options.tolerance) && options.tolerance > 0.0) || options.max_iterations <= 0) {
    throw InvalidArgument("timeOfImpact: tolerance and max_iterations must be > 0");
  }
  return ChainImpactSearch(a, ca, b, cb, t0, t1, options).run();
}

}  // namespace vadop
