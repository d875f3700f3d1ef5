// Continuous narrow phase: closed form for sphere-sphere, conservative advancement otherwise.
//
// Termination rule (why no contact can be stepped over). Every iteration at time t either
//  (1) finds the gap at t <= tol (GJK upper bound): hit at t; or
//  (2) obtains a step D certified by a lower bound of the gap that holds for ALL later
//      times: the separation of the shapes along a fixed direction n (a true lower bound of
//      the distance, computed with exact support functions, never the GJK estimate), bounded
//      below by a concave/linear function of the elapsed time built from the motion model
//      (detail::advanceStep). The gap is > tol/2 on [t, t + D), so t + D is still before any
//      contact; if the bound stays > tol/2 up to t1 the answer is "no hit".
// The iterate therefore never passes the first time the gap reaches tol/2, and the gap
// between tol/2 and tol is what guarantees progress: after landing on the bound's root the
// GJK upper bound (accurate to tol/200) is <= tol at the latest one face-contact step later.
#include "vadop/time_of_impact.h"

#include "vadop/error.h"

#include <cmath>
#include <sstream>
#include <string>

namespace vadop {
namespace {

void validateCommon(const Motion& ma, const Motion& mb, double t0, double t1, const ToiOptions& o) {
  if (!isValidMotion(ma)) validateMotion(ma, "timeOfImpact: motion a");
  if (!isValidMotion(mb)) validateMotion(mb, "timeOfImpact: motion b");
  if (!std::isfinite(t0)) throw InvalidArgument("timeOfImpact: t0 is not finite: " + formatNumber(t0));
  if (!std::isfinite(t1)) throw InvalidArgument("timeOfImpact: t1 is not finite: " + formatNumber(t1));
  if (t1 < t0) throw InvalidArgument("timeOfImpact: t1 < t0 (" + formatNumber(t1) + " < " + formatNumber(t0) + ")");
  if (!(std::isfinite(o.tolerance) && o.tolerance > 0.0)) {
    throw InvalidArgument("timeOfImpact: tolerance must be finite and > 0, got " + formatNumber(o.tolerance));
  }
  if (o.max_iterations <= 0) {
    throw InvalidArgument("timeOfImpact: max_iterations must be > 0, got " + std::to_string(o.max_iterations));
  }
}

// Spheres are centred on their body origin, so rotation about it never moves them: the gap is
// |d0 + dv s| - R, and the first time it reaches tol/2 is the smaller root of a quadratic.
Impact sphereSphere(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb, double t0,
                    double t1, double tol) {
  const double ra = a.radius + a.margin, rb = b.radius + b.margin;
  const double R = ra + rb;
  const Eigen::Vector3d d0 = mb.positionAt(t0) - ma.positionAt(t0);
  const Eigen::Vector3d dv = mb.linear_velocity - ma.linear_velocity;
  Impact out;
  out.iterations = 1;
  auto fill = [&](double t) {
    out.time = t;
    const Eigen::Vector3d pa = ma.positionAt(t), pb = mb.positionAt(t);
    const Eigen::Vector3d c = pb - pa;
    const double len = c.norm();
    Eigen::Vector3d n = Eigen::Vector3d::UnitX();
    if (len > 0.0) {
      n = c / len;
    } else if (dv.squaredNorm() > 0.0) {
      n = -dv.normalized();  // b came from that side
    }
    out.normal = n;
    out.point = 0.5 * ((pa + ra * n) + (pb - rb * n));
    out.distance = len - R;
  };
  if (d0.norm() - R <= tol) {
    out.hit = true;
    out.initially_touching = true;
    fill(t0);
    return out;
  }
  const double target = R + 0.5 * tol;
  const double qa = dv.squaredNorm();
  const double qb = d0.dot(dv);  // half the linear coefficient
  const double qc = d0.squaredNorm() - target * target;  // > 0 here
  if (qa > 0.0 && qb < 0.0) {
    const double disc = qb * qb - qa * qc;
    if (disc >= 0.0) {
      const double s = qc / (-qb + std::sqrt(disc));  // the smaller root, cancellation-free
      if (t0 + s <= t1) {
        out.hit = true;
        fill(t0 + s);
        return out;
      }
    }
  }
  fill(t1);
  return out;
}

Impact conservativeAdvancement(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                               const Motion& mb, double t0, double t1, const ToiOptions& o) {
  const double touch = o.tolerance;
  const double advance = 0.5 * o.tolerance;
  Impact out;
  auto fill = [&](double t, const DistanceResult& c) {
    out.time = t;
    out.normal = c.normal;
    out.point = 0.5 * (c.point_a + c.point_b);
    out.distance = c.distance;
  };
  double t = t0;
  Eigen::Vector3d hint = Eigen::Vector3d::Zero();
  for (int it = 1;; ++it) {
    const detail::AdvanceStep s = detail::advanceStep(a, ma, b, mb, t, t1 - t, touch, advance, &hint);
    out.iterations = it;
    if (s.touching) {
      out.hit = true;
      out.initially_touching = it == 1;
      fill(t, s.closest);
      return out;
    }
    if (s.clear) {
      fill(t1, s.closest);
      return out;
    }
    const double next = std::min(t + s.step, t1);
    if (it >= o.max_iterations || !(next > t)) {
      // Out of iterations, or no representable progress: the gap is certified > tol/2
      // only up to `next`. Report a conservative hit there rather than risk a miss.
      out.hit = true;
      out.conservative = true;
      fill(next, s.closest);
      return out;
    }
    t = next;
  }
}

}  // namespace

Impact timeOfImpact(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                    const Motion& mb, double t0, double t1, const ToiOptions& options) {
  validateCommon(ma, mb, t0, t1, options);
  if (a.shape().type == ShapeType::kSphere && b.shape().type == ShapeType::kSphere && !ma.hasPivot() &&
      !mb.hasPivot()) {
    return sphereSphere(a.shape(), ma, b.shape(), mb, t0, t1, options.tolerance);
  }
  return conservativeAdvancement(a, ma, b, mb, t0, t1, options);
}

Impact timeOfImpact(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb, double t0,
                    double t1, const ToiOptions& options) {
  validateShape(a, "timeOfImpact: shape a");
  validateShape(b, "timeOfImpact: shape b");
  validateCommon(ma, mb, t0, t1, options);
  if (a.type == ShapeType::kSphere && b.type == ShapeType::kSphere && !ma.hasPivot() && !mb.hasPivot()) {
    return sphereSphere(a, ma, b, mb, t0, t1, options.tolerance);
  }
  return conservativeAdvancement(PreparedShape(a), ma, PreparedShape(b), mb, t0, t1, options);
}

}  // namespace vadop
