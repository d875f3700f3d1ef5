// Continuous narrow phase: closed form for sphere-sphere, conservative advancement otherwise.
//
// Termination rule (why no contact can be stepped over). The iterate t only ever moves to a
// time up to which the gap is certified > tol/2, by one of:
//  (1) a conservative-advancement step D certified by a lower bound of the gap that holds for
//      ALL later times: the separation of the shapes along a fixed direction n (a true lower
//      bound of the distance, computed with exact support functions, never the GJK
//      estimate), bounded below by a concave/linear function of the elapsed time built from
//      the motion model (detail::advanceStep). The gap is > tol/2 on [t, t + D);
//  (2) a swept-volume certificate over a window [t, t + W] (detail::sweptLowerBound): each
//      body lies, throughout the window, in a convex set (a turning body in the cylinder
//      swept by its revolution about its pivot, plus the pivot's displacement; a body that
//      does not turn in its shape plus its displacement), and a certified lower bound of the
//      distance between the two sets is > tol/2; or the two bounding spheres about the
//      pivots, moving with the pivots, never come within tol/2 over the window (the swept
//      spheres of BruteForceBroadPhase). Used when rotation keeps the steps of (1) short:
//      after kPatience steps each shorter than 1/kSmallStep of the remaining window, the
//      whole remaining window is tried, then windows growing from a few steps ahead.
// Every iteration at the current t either finds the gap at t <= tol (GJK upper bound): hit
// at t; or certifies the rest of the window: no hit; or moves t as above. The iterate
// therefore never passes the first time the gap reaches tol/2, and the gap between tol/2 and
// tol is what guarantees progress of (1): after landing on the bound's root the GJK upper
// bound (accurate to tol/200) is <= tol at the latest one face-contact step later.
// Budget: every evaluation of (1) or (2) counts against ToiOptions::max_iterations; when it
// runs out (or no representable progress is possible) the answer is `undecided` at the
// current t, the end of the certified interval: never a contact, never a miss.
#include "vadop/time_of_impact.h"
#include "advance_step.h"
#include "body_side.h"
#include "contact_patch.h"

#include "vadop/error.h"

#include <algorithm>
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
// |d0 + dv s| - R, and the first time it reaches tol/2 is the smaller root of a quadratic,
// solved in units of |d0| and |d0| / |dv| so that no intermediate can overflow or underflow
// whatever the scale (all its coefficients are of order 1).
TimeOfImpact sphereSphere(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb, double t0,
                    double t1, double tol) {
  const double ra = a.radius + a.margin, rb = b.radius + b.margin;
  const double R = ra + rb;
  const Eigen::Vector3d d0 = mb.positionAt(t0) - ma.positionAt(t0);
  const Eigen::Vector3d dv = mb.linear_velocity - ma.linear_velocity;
  TimeOfImpact out;
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
  const double len0 = d0.norm();
  if (len0 - R <= tol) {
    out.hit = true;
    out.initially_touching = true;
    fill(t0);
    return out;
  }
  // Here len0 > target > 0.
  const double target = R + 0.5 * tol;
  const double speed = dv.norm();
  if (speed > 0.0) {
    const Eigen::Vector3d e = d0 / len0;   // unit
    const Eigen::Vector3d u = dv / speed;  // unit
    const double g = target / len0;        // in (0, 1)
    // |e + u x|^2 = g^2 in x = s |dv| / |d0|: x^2 + 2 qb x + qc = 0.
    const double qb = e.dot(u);
    const double qc = (1.0 - g) * (1.0 + g);  // > 0
    if (qb < 0.0) {
      const double disc = qb * qb - qc;
      if (disc >= 0.0) {
        const double x = qc / (-qb + std::sqrt(disc));  // the smaller root, cancellation-free
        const double s = x * (len0 / speed);            // may be +inf: then no hit
        if (t0 + s <= t1) {
          out.hit = true;
          fill(t0 + s);
          return out;
        }
      }
    }
  }
  fill(t1);
  return out;
}

// The swept bounding spheres (about the pivots; the radius holds the shape in every
// orientation, as BruteForceBroadPhase's) never come within adv of each other on [ta, tb]:
// the closest approach of two linearly moving centres, with an allowance for rounding.
bool spheresClear(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb, double ta, double tb,
                  double adv) {
  auto radius = [](const Shape& s, const Motion& m) { return s.bounding_radius + m.pivotArm(); };
  const Eigen::Vector3d d0 = mb.centreAt(ta) - ma.centreAt(ta);
  const Eigen::Vector3d dv = mb.linear_velocity - ma.linear_velocity;
  const double T = tb - ta;
  const double vv = dv.squaredNorm();
  const double s = vv > 0.0 ? std::clamp(-d0.dot(dv) / vv, 0.0, T) : 0.0;
  const double closest = (d0 + s * dv).norm();
  const double r = radius(a, ma) + radius(b, mb);
  const double slack = 1e-14 * (d0.norm() + std::sqrt(vv) * T + r);
  return closest - r - slack > adv;
}

// The swept-volume certificates of the file header, (2). From t (certified so far), with at
// most `budget` evaluations in all: the swept spheres, then the swept volumes over [t, t1],
// then windows [t, t + w] growing from w0 (doubling after each success, halving after a
// failure, down to w0). Returns the time up to which the gap is now certified (>= t).
double sweepAhead(const PreparedShape& a, const Motion& ma, const PreparedShape& b, const Motion& mb, double t,
                  double t1, double adv, double w0, int budget, int& used) {
  if (used >= budget) return t;
  ++used;
  if (spheresClear(a.shape(), ma, b.shape(), mb, t, t1, adv)) return t1;
  auto clear = [&](double ta, double tb) {
    ++used;
    return detail::sweptLowerBound(a, ma, b, mb, ta, tb, adv).lower_bound > adv;
  };
  if (used >= budget) return t;
  if (clear(t, t1)) return t1;
  double w = w0;
  for (int tests = 0; tests < 64 && used < budget && t < t1; ++tests) {
    const double tb = std::min(t + w, t1);
    if (!(tb > t)) break;
    if (clear(t, tb)) {
      t = tb;
      w *= 2.0;
    } else if (0.5 * w >= w0) {
      w *= 0.5;
    } else {
      break;
    }
  }
  return t;
}

// After kPatience consecutive steps each shorter than 1/kSmallStep of the remaining window
// (rotation-limited), the swept volumes are tried; after an attempt that gains nothing the
// patience doubles (up to kMaxPatience), so that their cost stays a small share of the steps'.
constexpr int kPatience = 24;
constexpr int kMaxPatience = 1 << 12;
constexpr double kSmallStep = 64.0;

TimeOfImpact conservativeAdvancement(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                               const Motion& mb, double t0, double t1, const ToiOptions& o) {
  const double touch = o.tolerance;
  const double advance = 0.5 * o.tolerance;
  const bool rotating = ma.isRotating() || mb.isRotating();
  TimeOfImpact out;
  auto fill = [&](double t, const DistanceResult& c) {
    out.time = t;
    out.normal = c.normal;
    out.point = 0.5 * (c.point_a + c.point_b);
    out.distance = c.distance;
  };
  double t = t0;
  detail::WarmStart warm;
  int used = 0;  // evaluations: CA steps and swept-volume tests
  int small = 0, patience = kPatience;
  for (;;) {
    const detail::AdvanceStep s = detail::advanceStep(a, ma, b, mb, t, t1 - t, touch, advance, &warm);
    const bool first = used == 0;
    ++used;
    out.iterations = used;
    if (s.touching) {
      out.hit = true;
      out.initially_touching = first;
      fill(t, s.closest);
      // In contact at the start: the point where the bodies meet (the witness points of a face
      // are any of its corners).
      if (first) {
        out.point = detail::contactPatchPoint(detail::sideAt(a.data(), ma, t), detail::sideAt(b.data(), mb, t),
                                              s.closest);
      }
      return out;
    }
    if (s.clear) {
      fill(t1, s.closest);
      return out;
    }
    double next = std::min(t + s.step, t1);
    const bool stuck = !(next > t);  // no representable progress by the step
    if (rotating && s.step * kSmallStep < t1 - next) {
      ++small;
    } else {
      small = 0;
    }
    if (rotating && (stuck || small >= patience) && used < o.max_iterations) {
      // Windows from a few steps ahead: shorter ones cannot gain over the steps themselves.
      const double w0 = std::max(8.0 * s.step, 1e-9 * (t1 - t0));
      const double reached = sweepAhead(a, ma, b, mb, next, t1, advance, w0, o.max_iterations, used);
      if (reached >= t1) {
        out.iterations = used;
        fill(t1, s.closest);
        return out;
      }
      // Worth repeating soon only when it gained more per evaluation than the steps do.
      const int spent = used - out.iterations;
      patience = reached - next > 2.0 * spent * s.step ? kPatience : std::min(2 * patience, kMaxPatience);
      out.iterations = used;
      small = 0;
      next = reached;
    }
    if (!(next > t) || used >= o.max_iterations) {
      // Out of budget, or no representable progress: the gap is certified > tol/2 only up
      // to `next`. No verdict: neither a contact nor a miss.
      out.undecided = true;
      fill(next, s.closest);
      return out;
    }
    t = next;
  }
}

}  // namespace

TimeOfImpact timeOfImpact(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                    const Motion& mb, double t0, double t1, const ToiOptions& options) {
  validateCommon(ma, mb, t0, t1, options);
  if (a.shape().type == ShapeType::kSphere && b.shape().type == ShapeType::kSphere && !ma.hasPivot() &&
      !mb.hasPivot()) {
    return sphereSphere(a.shape(), ma, b.shape(), mb, t0, t1, options.tolerance);
  }
  return conservativeAdvancement(a, ma, b, mb, t0, t1, options);
}

TimeOfImpact timeOfImpact(const Shape& a, const Motion& ma, const Shape& b, const Motion& mb, double t0,
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
