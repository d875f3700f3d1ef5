#include "vadop/vadop.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace vadop {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// support(shape, d) for a unit d, without the norms that support() takes of d: |d| = 1 to a
// few ulps here (a unit axis turned by a rotation matrix), an error of that many ulps of the
// radii, far below the intervals' widening (kRoundingWiden, at least 1e-12 m).
double unitSupport(const Shape& s, const Eigen::Vector3d& d) {
  switch (s.type) {
    case ShapeType::kSphere: return s.radius + s.margin;
    case ShapeType::kBox: return s.half_extents.dot(d.cwiseAbs()) + s.margin;
    case ShapeType::kCapsule: return s.half_length * std::abs(d.z()) + s.radius + s.margin;
    case ShapeType::kCylinder:
      return s.half_length * std::abs(d.z()) + s.radius * std::sqrt(d.x() * d.x() + d.y() * d.y()) + s.margin;
    case ShapeType::kConvex:
    case ShapeType::kMesh: break;
  }
  return support(s, d);
}

// The shape's extent from its origin along each coordinate axis e_k, turned by R(t) (rotation_t =
// R(t)^T): up[k] = h(R^T e_k), down[k] = h(-R^T e_k) (one query for the centred primitives).
void axisExtents(const Shape& shape, const Eigen::Matrix3d& rotation_t, double* up, double* down) {
  const bool sphere = shape.type == ShapeType::kSphere;  // rotation_t is not read
  const bool symmetric = shape.type != ShapeType::kConvex && shape.type != ShapeType::kMesh;
  for (int k = 0; k < 3; ++k) {
    if (sphere) {
      up[k] = down[k] = shape.radius + shape.margin;
    } else {
      const Eigen::Vector3d a_body = rotation_t.col(k);  // R(t)^T e_k
      up[k] = unitSupport(shape, a_body);
      down[k] = symmetric ? up[k] : unitSupport(shape, -a_body);
    }
  }
}

}  // namespace

double validateVadopConfig(const VadopConfig& c, const AxisPool& pool) {
  if (c.axes != pool.size()) {
    throw InvalidArgument("axes = " + std::to_string(c.axes) + " does not match the pool size " +
                          std::to_string(pool.size()));
  }
  if (!std::isfinite(c.phi_deg) || c.phi_deg < 0.0 || c.phi_deg > 90.0) {
    throw InvalidArgument("phi_deg must be in [0, 90] (0 = the pool's covering radius), got " +
                          std::to_string(c.phi_deg));
  }
  const double rho = pool.coveringRadius();
  const double phi = c.phi_deg == 0.0 ? rho : c.phi_deg * kDeg;
  if (phi < rho) {
    throw InvalidArgument("phi_deg = " + std::to_string(c.phi_deg) +
                          " is below the covering radius rho = " + std::to_string(rho / kDeg) +
                          " deg of the " + std::to_string(pool.size()) +
                          "-axis pool: two bodies' zones could share no axis; use phi_deg >= rho "
                          "or more axes");
  }
  if (!std::isfinite(c.slow_fraction) || c.slow_fraction < 0.0) {
    throw InvalidArgument("slow_fraction must be finite and >= 0, got " +
                          std::to_string(c.slow_fraction));
  }
  if (!c.slow_direction.allFinite() || c.slow_direction.norm() < 1e-9) {
    throw InvalidArgument("slow_direction must be a finite non-zero vector");
  }
  if (!std::isfinite(c.hysteresis_deg) || c.hysteresis_deg < 0.0 || c.hysteresis_deg > 90.0) {
    throw InvalidArgument("hysteresis_deg must be in [0, 90], got " + std::to_string(c.hysteresis_deg));
  }
  return phi;
}

AxisZones axisZones(const VadopConfig& config, double phi_rad) {
  // The tiny slack keeps an axis that lies exactly on the zone's rim (|u.a| == sin(phi)) in,
  // whatever the rounding: the sharing guarantee needs the closed zone.
  const double hysteresis = config.hysteresis_deg * kDeg;
  AxisZones z;
  z.in_zone = std::sin(phi_rad) + 1e-12;
  z.keep_zone = std::sin(std::min(phi_rad + hysteresis, kPi / 2)) + 1e-12;
  z.fresh_zone = std::sin(std::min(phi_rad + 0.5 * hysteresis, kPi / 2)) + 1e-12;
  return z;
}

std::unique_ptr<AxisPool> makeAxisPool(int axes) {
  if (axes < 3 || axes > AxisPool::kMaxAxes) {
    throw InvalidArgument("axes must be in [3, " + std::to_string(AxisPool::kMaxAxes) + "], got " +
                          std::to_string(axes));
  }
  return std::make_unique<AxisPool>(axes);
}

Eigen::Vector3d axisSelectionDirection(const Motion& motion, double bounding_radius, double frame_length,
                              const VadopConfig& config) {
  const double speed = motion.linear_velocity.norm();
  const bool slow = !(speed * frame_length >= config.slow_fraction * bounding_radius) || speed == 0.0;
  if (!slow) return motion.linear_velocity / speed;
  if (config.slow_rule == SlowAxisRule::kAllAxes) return Eigen::Vector3d::Zero();
  return config.slow_direction.normalized();
}

bool updateAxes(const Motion& motion, double bounding_radius, double frame_length, const AxisPool& pool,
                const VadopConfig& config, const AxisZones& zones, std::vector<uint32_t>& axes) {
  const int m = pool.size();
  const Eigen::Vector3d u = axisSelectionDirection(motion, bounding_radius, frame_length, config);
  if (u.squaredNorm() == 0.0) {  // slow, SlowAxisRule::kAllAxes
    if (axes.size() == static_cast<size_t>(m)) return false;  // ascending and unique: all of them
    axes.resize(m);
    for (int k = 0; k < m; ++k) axes[k] = static_cast<uint32_t>(k);
    return true;
  }
  const double in_zone = zones.in_zone, keep_zone = zones.keep_zone;
  // Keep the previous set while it still holds the whole zone and nothing far outside it: a
  // steadily turning body then changes lists only every hysteresis / 2 of turn, not each time
  // an axis crosses the rim.
  if (!axes.empty()) {
    bool keep = true;
    size_t p = 0;
    for (int k = 0; k < m && keep; ++k) {
      const double c = std::abs(u.dot(pool.axis(k)));
      while (p < axes.size() && axes[p] < static_cast<uint32_t>(k)) ++p;
      const bool used = p < axes.size() && axes[p] == static_cast<uint32_t>(k);
      keep = used ? c <= keep_zone : c > in_zone;
    }
    if (keep) return false;
  }
  // A fresh set: the zone widened by half the hysteresis, so the body can turn either way.
  const double fresh_zone = zones.fresh_zone;
  // It differs from the previous set: that one would have been kept (the fresh set holds the
  // zone and lies within phi + hysteresis / 2).
  axes.clear();
  for (int k = 0; k < m; ++k) {
    if (std::abs(u.dot(pool.axis(k))) <= fresh_zone) axes.push_back(static_cast<uint32_t>(k));
  }
  return true;
}

std::vector<uint32_t> selectAxes(const Motion& motion, double bounding_radius, double frame_length,
                                 const AxisPool& pool, const VadopConfig& config, double phi_rad,
                                 const std::vector<uint32_t>& previous) {
  std::vector<uint32_t> axes = previous;
  updateAxes(motion, bounding_radius, frame_length, pool, config, axisZones(config, phi_rad), axes);
  return axes;
}

double SweptBody::setBody(const Shape& shape, const Motion& motion) {
  shape_ = &shape;
  radius_ = shape.radius + shape.margin;
  // Everything turns about the pivot: the shape is seen from it, its lever arm grown by the
  // offset.
  core_radius_ = std::max(0.0, shape.bounding_radius - shape.margin) + motion.pivotArm();
  const double w = motion.angular_velocity.norm();
  if (w > 0.0) {
    spin_axis_ = motion.angular_velocity / w;
  } else {
    spin_axis_.setZero();
  }
  return w;
}

SweptBody::SweptBody(const Shape& shape, const Motion& motion, double t0, double t1) {
  const double w = setBody(shape, motion);
  const double tm = 0.5 * (t0 + t1);
  // A sphere's projection does not depend on its orientation (see project).
  if (shape.type != ShapeType::kSphere) rotation_mid_t_ = motion.orientationAt(tm).toRotationMatrix().transpose();
  // The pivot moves in a straight line: the sweep is that of the pivot, the shape shifted by
  // origin - pivot at mid-frame.
  p0_ = motion.centreAt(t0);
  p1_ = motion.centreAt(t1);
  if (motion.hasPivot()) {
    shift_mid_ = motion.positionAt(tm) - motion.pivotAt(tm);
  } else {
    shift_mid_.setZero();
  }
  if (w > 0.0) {
    // Largest rotation angle away from the mid-frame orientation; a point at radius r on the
    // spin plane moves along a chord of 2 r sin(angle / 2), never more than 2 r.
    const double angle = std::min(w * 0.5 * (t1 - t0), kPi);
    chord_ = 2.0 * std::sin(0.5 * angle);
  }
  translating_sphere_ = shape.type == ShapeType::kSphere && !motion.hasPivot() && chord_ == 0.0;
}

namespace {

// r = r * step and r = step * r, a row (column) at a time from values held in registers.
// Eigen's product into a temporary stored the matrix in 8- and 16-byte pieces that the next
// part's 16-byte loads straddled: a store-forwarding stall that took a third of partBoxes' time
// (perf annotate, 10,000 bodies).
void stepRotation(Eigen::Matrix3d& r, const Eigen::Matrix3d& step) {
  for (int i = 0; i < 3; ++i) {
    const double a = r(i, 0), b = r(i, 1), c = r(i, 2);
    for (int j = 0; j < 3; ++j) r(i, j) = a * step(0, j) + b * step(1, j) + c * step(2, j);
  }
}
void turnRotation(const Eigen::Matrix3d& step, Eigen::Matrix3d& r) {
  for (int j = 0; j < 3; ++j) {
    const double a = r(0, j), b = r(1, j), c = r(2, j);
    for (int i = 0; i < 3; ++i) r(i, j) = step(i, 0) * a + step(i, 1) * b + step(i, 2) * c;
  }
}

}  // namespace

void SweptBody::partBoxes(const Shape& shape, const Motion& motion, double t0, double t1, int parts, double* out) {
  // The bounds of one SweptBody per part, without building one: what does not depend on the
  // part (spin axis, chord, the rotation term of each coordinate axis) is computed once, and
  // the parts' mid-frame orientations are stepped by one turn increment. A body that turns by
  // at most kEndsMaxTurn a part takes partBoxesFromEnds instead (tighter there).
  const double w = motion.angular_velocity.norm();
  if (w > 0.0 && w * (t1 - t0) / parts <= kEndsMaxTurn) return partBoxesFromEnds(shape, motion, t0, t1, parts, out);
  const bool pivot = motion.hasPivot();
  const bool sphere = shape.type == ShapeType::kSphere;  // its extent does not depend on orientation
  const double core_radius = std::max(0.0, shape.bounding_radius - shape.margin) + motion.pivotArm();
  Eigen::Vector3d spin_axis = Eigen::Vector3d::Zero();
  Eigen::Matrix3d spin = Eigen::Matrix3d::Identity();  // exp([w] (t_mid - t_ref)) of the part
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();  // from one part's mid-frame to the next
  double chord = 0.0;
  const double length = (t1 - t0) / parts;
  if (w > 0.0) {
    spin_axis = motion.angular_velocity / w;
    // The parts' lengths and mid-times differ from `length` and from the stepped rotation's
    // times by rounding: the angle gets a margin of 1e-12 s of turning (far above those
    // rounding errors) and 1e-12 rad (the rounding of the products of `parts` rotations).
    double longest = 0.0, s = t0;
    for (int k = 0; k < parts; ++k) {
      const double e = partEnd(t0, t1, k, parts);
      longest = std::max(longest, e - s);
      s = e;
    }
    const double angle = std::min(w * (0.5 * longest + 1e-12 * (1.0 + std::abs(t0) + std::abs(t1))) + 1e-12, kPi);
    chord = 2.0 * std::sin(0.5 * angle);
    spin = motion.spin(0.5 * (t0 + partEnd(t0, t1, 0, parts)));
    turn = Eigen::AngleAxisd(w * length, spin_axis).toRotationMatrix();
  }
  double rot[3];
  for (int k = 0; k < 3; ++k) rot[k] = rotationReach(core_radius, chord, spin_axis, k);
  // R(t_mid)^T of the part (a sphere's is never read), stepped by turn^T.
  Eigen::Matrix3d rotation_t = (spin * motion.orientation.toRotationMatrix()).transpose();
  const Eigen::Matrix3d turn_t = turn.transpose();
  // The centre (Motion::centreAt: the pivot, or the origin) moves in a straight line.
  const Eigen::Vector3d centre_ref = pivot ? Eigen::Vector3d(motion.position + motion.pivot_offset) : motion.position;
  auto centreAt = [&](double t) -> Eigen::Vector3d { return centre_ref + motion.linear_velocity * (t - motion.t_ref); };
  Eigen::Vector3d c0 = centreAt(t0);
  double up[3], down[3];
  for (int k = 0; k < parts; ++k, out += 6) {
    const double e = partEnd(t0, t1, k, parts);
    const Eigen::Vector3d c1 = centreAt(e);
    // Origin - pivot at mid-frame.
    const Eigen::Vector3d shift = pivot ? Eigen::Vector3d(-(spin * motion.pivot_offset)) : Eigen::Vector3d::Zero();
    // A body that does not turn has the same extents in every part: queried once (a sensor's
    // point set, a static mesh: each query visits every vertex).
    if (k == 0 || w > 0.0) axisExtents(shape, rotation_t, up, down);
    boxOf(up, down, c0, c1, shift, rot, out);
    if (w > 0.0) {
      if (pivot) turnRotation(turn, spin);
      if (!sphere) stepRotation(rotation_t, turn_t);
    }
    c0 = c1;
  }
}

void SweptBody::partBoxesFromEnds(const Shape& shape, const Motion& motion, double t0, double t1, int parts,
                                  double* out) {
  // A point at distance rho from the line the body turns about accelerates at |w|^2 rho, so
  // over a part of length h it stays within |w|^2 rho h^2 / 8 of the segment between where it
  // is at the part's two ends (each coordinate has |x''| <= |w|^2 rho: the interpolation error
  // of a C2 function), hence in the union of the shape's boxes at the ends grown by that. rho
  // <= the pivot's arm plus the bounding radius; for a sphere, whose box does not depend on
  // its orientation, the path of its centre is what matters (rho = the arm). Over a time slice
  // of a vehicle (a small turn about a far pivot) that is millimetres, where the chord bound
  // of partBoxes grows the box by the turn's chord at the whole lever arm on every side.
  // The ends' rotations are stepped by one turn increment, with the margin partBoxes takes for
  // that (1e-12 rad plus 1e-12 s of turning, here at rho) and the usual relative widening.
  const double w = motion.angular_velocity.norm();
  const bool pivot = motion.hasPivot();
  const bool sphere = shape.type == ShapeType::kSphere;
  const bool symmetric = shape.type != ShapeType::kConvex && shape.type != ShapeType::kMesh;
  const double rho = (sphere ? 0.0 : shape.bounding_radius) + motion.pivotArm();
  const double accel = w * w * rho;
  const double rounding = rho * (1e-12 + w * 1e-12 * (1.0 + std::abs(t0) + std::abs(t1)));
  const Eigen::Vector3d spin_axis = motion.angular_velocity / w;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(w * (t1 - t0) / parts, spin_axis).toRotationMatrix();
  const Eigen::Matrix3d turn_t = turn.transpose();
  Eigen::Matrix3d spin = motion.spin(t0);                                                // exp([w] (t - t_ref)) at the end
  Eigen::Matrix3d rotation_t = (spin * motion.orientation.toRotationMatrix()).transpose();  // R(t)^T (not read for a sphere)
  const Eigen::Vector3d centre_ref = pivot ? Eigen::Vector3d(motion.position + motion.pivot_offset) : motion.position;
  auto endBox = [&](double t, double* b) {
    const Eigen::Vector3d c = centre_ref + motion.linear_velocity * (t - motion.t_ref);
    const Eigen::Vector3d o = pivot ? Eigen::Vector3d(c - spin * motion.pivot_offset) : c;
    for (int k = 0; k < 3; ++k) {
      double up, down;
      if (sphere) {
        up = down = shape.radius + shape.margin;
      } else {
        up = unitSupport(shape, rotation_t.col(k));
        down = symmetric ? up : unitSupport(shape, -rotation_t.col(k));
      }
      b[k] = o[k] - down;
      b[3 + k] = o[k] + up;
    }
  };
  double ends[2][6];
  endBox(t0, ends[0]);
  double s = t0;
  for (int k = 0; k < parts; ++k, out += 6) {
    const double e = partEnd(t0, t1, k, parts);
    if (pivot) turnRotation(turn, spin);
    if (!sphere) stepRotation(rotation_t, turn_t);
    const double* a = ends[k % 2];
    double* b = ends[(k + 1) % 2];
    endBox(e, b);
    const double grow = accel * (e - s) * (e - s) / 8.0 + rounding;
    for (int c = 0; c < 3; ++c) {
      const double lo = std::min(a[c], b[c]) - grow, hi = std::max(a[3 + c], b[3 + c]) + grow;
      const double widen = kRoundingWiden * (1.0 + std::max(std::abs(lo), std::abs(hi)) + grow);
      out[c] = lo - widen;
      out[3 + c] = hi + widen;
    }
    s = e;
  }
}

Interval SweptBody::projectGeneral(const Eigen::Vector3d& a) const {
  double up, down;
  if (shape_->type == ShapeType::kSphere) {
    // Orientation does not matter and |a| = 1 (to rounding, which the widening below covers).
    up = down = shape_->radius + shape_->margin;
  } else {
    const Eigen::Vector3d a_body = rotation_mid_t_ * a;
    up = unitSupport(*shape_, a_body);
    // The primitives are centred (symmetric under x -> -x): one support query gives both ends.
    const bool symmetric = shape_->type != ShapeType::kConvex && shape_->type != ShapeType::kMesh;
    down = symmetric ? up : unitSupport(*shape_, -a_body);
  }
  const double shift = a.dot(shift_mid_);
  up += shift;
  down -= shift;
  // Only the component of a point orthogonal to the spin axis moves, and only the part of the
  // axis orthogonal to the spin axis sees it: hence |a x w_hat|.
  const double rot = chord_ > 0.0 ? core_radius_ * chord_ * a.cross(spin_axis_).norm() : 0.0;
  return axisBounds(a.dot(p0_), a.dot(p1_), up, down, rot);
}

void SweptBody::boxGeneral(double* out) const {
  double rot[3];
  for (int k = 0; k < 3; ++k) rot[k] = rotationReach(core_radius_, chord_, spin_axis_, k);
  double up[3], down[3];
  axisExtents(*shape_, rotation_mid_t_, up, down);
  boxOf(up, down, p0_, p1_, shift_mid_, rot, out);
}

void SweptBody::boxOf(const double* up, const double* down, const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                      const Eigen::Vector3d& shift, const double* rot, double* out) {
  for (int k = 0; k < 3; ++k) {
    const Interval iv = axisBounds(p0[k], p1[k], up[k] + shift[k], down[k] - shift[k], rot[k]);
    out[k] = iv.lo;
    out[3 + k] = iv.hi;
  }
}

Interval sweptInterval(const Shape& shape, const Motion& motion, double t0, double t1,
                       const Eigen::Vector3d& axis) {
  return SweptBody(shape, motion, t0, t1).project(axis);
}

}  // namespace vadop
