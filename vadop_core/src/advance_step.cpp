// The certified steps of conservative advancement (advance_step.h): a convex pair through
// convexDistance and separationStep, a mesh through meshStep.
#include "advance_step.h"

#include "body_side.h"
#include "convex_distance.h"
#include "gjk.h"
#include "mesh_queries.h"
#include "separation_step.h"

#include "vadop/error.h"

namespace vadop {
namespace detail {

namespace {

// GJK accuracy of the steps: a small fraction of the band between the advance target and the
// touch threshold, so that the loop always reaches "touching" after landing on the target;
// and, farther out, a small fraction of the gap (relative to the gap, not to the cores'
// distance): the step is certified by the exact separation along the direction found, so a
// direction a little off only shortens the step by about as much, while the last iterations
// of a curved shape cost as much as the first ones. At the touch threshold the relative part
// (4e-3 of the threshold) stays below the absolute one (1/200 of it).
Tolerances stepTolerances(double touch_gap, double advance_gap) { return {0.01 * (touch_gap - advance_gap), 4e-3, 128}; }

// advanceStep for two convex sides (kin set), with the deviation of separationStep.
AdvanceStep convexStep(const Side& A, const Side& B, double deviation, double horizon, double touch_gap,
                       double advance_gap, WarmStart* warm) {
  const Tolerances tol = stepTolerances(touch_gap, advance_gap);
  AdvanceStep out;
  const Convex ca = A.convex(0), cb = B.convex(0);
  const Eigen::Vector3d guess = (warm && warm->dir.squaredNorm() > 0.0) ? warm->dir : Eigen::Vector3d(ca.origin() - cb.origin());
  Eigen::Vector3d cert;
  out.closest = convexDistance(ca, cb, guess, tol.abs_tol, tol.rel_tol, tol.max_iter, &cert, warm);
  if (warm) warm->dir = -out.closest.normal;
  if (out.closest.cores_overlap || out.closest.distance <= touch_gap) {
    out.touching = true;
    out.closest = refineContact(ca, cb, out.closest, warm);
    return out;
  }
  out.step = separationStep(ca, A.kin, cb, B.kin, cert, horizon, advance_gap, horizon, &out.clear, deviation);
  return out;
}

}  // namespace

AdvanceStep advanceStep(const PreparedShape& a, const Motion& ma, const PreparedShape& b,
                        const Motion& mb, double t, double horizon, double touch_gap,
                        double advance_gap, WarmStart* warm) {
  const Side A = sideAt(a.data(), ma, t);
  const Side B = sideAt(b.data(), mb, t);
  if (A.mesh || B.mesh) return meshStep(A, B, horizon, touch_gap, advance_gap, stepTolerances(touch_gap, advance_gap));
  return convexStep(A, B, 0.0, horizon, touch_gap, advance_gap, warm);
}

AdvanceStep advanceStepNearTwist(const PreparedShape& a, const PosedTwist& ta, const PreparedShape& b,
                                 const PosedTwist& tb, double deviation, double horizon, double touch_gap,
                                 double advance_gap, WarmStart* warm) {
  Side A = makeSide(a.data(), ta.pose.linear(), ta.pose.translation());
  Side B = makeSide(b.data(), tb.pose.linear(), tb.pose.translation());
  if (A.mesh || B.mesh) throw InvalidArgument("advanceStepNearTwist: convex shapes only, not meshes");
  A.kin = {ta.velocity, ta.angular_velocity};
  B.kin = {tb.velocity, tb.angular_velocity};
  return convexStep(A, B, deviation, horizon, touch_gap, advance_gap, warm);
}

}  // namespace detail
}  // namespace vadop
