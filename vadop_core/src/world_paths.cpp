// World::firstContactAlong and World::setStopDuration (world.h): movers on paths, a velocity
// gate's manoeuvre (the last command held, the candidate, braking to standstill), against the
// other bodies in their own future and, when asked, in the one where each brakes.
#include "world_engine.h"

#include "contact_patch.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace vadop {
namespace {

// m: how far the others' braking paths (PathQuery::others_stop) may lie from the exact braking.
constexpr double kOthersDeviation = 5e-4;

// Whether a pair found touching at s but not pressed together there (the closing speed at the
// witness point <= 0) still digs in over [s, e]: the witness of a face contact is one point of
// the face, and another corner may press (a box turning in place against a wall). The gap at
// four times of the stretch, against the gap at s less the tolerance. A guard of the exemption
// only (sampled): a pair that presses at the witness is a contact whatever this says.
bool digsIn(const PreparedShape& a, const Motion& ma, const PreparedShape& b, const Motion& mb, double s, double e,
            double start_gap, double tolerance) {
  for (int k = 1; k <= 4; ++k) {
    const double t = s + (e - s) * k / 4.0;
    if (distance(a, ma.poseAt(t), b, mb.poseAt(t)).distance < std::min(start_gap, 0.0) - tolerance) return true;
  }
  return false;
}

// The first contact of a along pa and b along pb over [t0, t1], stretch by stretch (each a pair of
// constant twists, timeOfImpact's contract on each): a pair touching at the start of a stretch is
// a contact only when the two pieces press it together at the touching point; else that stretch
// is passed over (moving apart, sliding) and the search goes on with the next.
// `radius`: the sum of the two shapes' bounding radii: a stretch whose bounding balls stay
// apart by more than the tolerance is clear without the narrow phase.
TimeOfImpact pressingImpact(const PreparedShape& a, const TimedPath& pa, const PreparedShape& b, const TimedPath& pb,
                            double t0, double t1, double radius, const ToiOptions& options) {
  size_t ka = pa.pieceAt(t0), kb = pb.pieceAt(t0);
  double s = t0;
  int iterations = 0;
  // A lower bound on the origins' distance at s: measured where needed, else the last measure
  // less how far both origins travelled since (no pose evaluated while the pair is far apart).
  double apart = -std::numeric_limits<double>::infinity();
  for (;;) {
    const double e = std::min({t1, pa.start(ka + 1), pb.start(kb + 1)});
    const Motion& ma = pa.motion(ka);
    const Motion& mb = pb.motion(kb);
    const double step = (originSpeed(ma) + originSpeed(mb)) * (e - s);
    if (apart - radius - step <= options.tolerance) apart = (ma.positionAt(s) - mb.positionAt(s)).norm();
    TimeOfImpact out;
    if (apart - radius - step > options.tolerance) {
      out.time = e;  // the bounding balls stay apart over the stretch
      apart -= step;
    } else {
      out = timeOfImpact(a, ma, b, mb, s, e, options);
      apart = -std::numeric_limits<double>::infinity();
    }
    iterations += out.iterations;
    bool pressing = true;
    if (out.hit && out.initially_touching) {
      const Eigen::Vector3d closing = ma.velocityOfPoint(out.point, s) - mb.velocityOfPoint(out.point, s);
      pressing = detail::pressesIn(closing, out.normal) || digsIn(a, ma, b, mb, s, e, out.distance, options.tolerance);
    }
    if (pressing && (out.hit || out.undecided)) {
      out.iterations = iterations;
      return out;
    }
    if (e >= t1) {
      TimeOfImpact clear;
      clear.time = t1;
      clear.iterations = iterations;
      return clear;
    }
    if (pa.start(ka + 1) <= e) ++ka;
    if (pb.start(kb + 1) <= e) ++kb;
    s = e;
  }
}

}  // namespace

WorldEngine::Reachable WorldEngine::pathPartners(const std::vector<std::string>& movers,
                                                 const std::vector<TimedPath>& paths, double t0, double t1,
                                                 double deviation) {
  std::vector<Eigen::Vector3d> origins;
  std::vector<double> reach;
  for (const TimedPath& p : paths) {
    origins.push_back(p.poseAt(t0).translation());
    reach.push_back(p.travel(t0, t1) + deviation);
  }
  return reachable(movers, origins, reach, t0, t1 - t0);
}

std::optional<WorldEngine::MoverContact> WorldEngine::firstContactAlong(const std::vector<std::string>& movers,
                                                                        const std::vector<TimedPath>& paths,
                                                                        double t0, double horizon,
                                                                        const World::PathQuery& query) {
  const char* op = "firstContactAlong";
  if (movers.size() != paths.size()) {
    throw InvalidArgument(std::string(op) + ": " + std::to_string(movers.size()) + " movers but " +
                          std::to_string(paths.size()) + " paths");
  }
  if (!(std::isfinite(query.deviation) && query.deviation >= 0.0)) {
    throw InvalidArgument(std::string(op) + ": deviation must be finite and >= 0, got " + formatNumber(query.deviation));
  }
  double t1 = checkedWindow(op, t0, horizon);
  std::vector<BodyId> ids;
  for (size_t i = 0; i < movers.size(); ++i) {
    ids.push_back(bodyId(movers[i], op));
    paths[i].forEachPiece(t0, t1, [&](size_t k, double s, double e) { checkMotionReach(ids[i], paths[i].motion(k), s, e); });
  }
  std::vector<BodyId> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw InvalidArgument(std::string(op) + ": a mover is listed twice");
  }
  Reachable own;
  const Reachable& among = query.among ? *query.among : (own = pathPartners(movers, paths, t0, t1, query.deviation));
  std::optional<MoverContact> best;
  for (size_t i = 0; i < ids.size(); ++i) {
    const Record& rm = records_[ids[i]];
    // A ball the mover stays in over the window: the others' futures that stay out of it are
    // clear without a path or a narrow phase.
    const Ball reach{paths[i].poseAt(t0).translation(),
                     broad_phase_->shape(ids[i]).bounding_radius + paths[i].travel(t0, t1)};
    for (BodyId other : among.ids) {
      if (!broad_phase_->contains(other) || std::binary_search(sorted.begin(), sorted.end(), other)) continue;
      const Record& ro = records_[other];
      if (!shouldTest(rm, ro) || (query.skip && query.skip(ro.user))) continue;
      // Only the first contact matters: later pairs search up to the best time so far.
      std::optional<MoverContact> c = pathImpact(rm, ids[i], i, paths[i], reach, other, query, t0, t1);
      if (c && (!best || c->impact.time < best->impact.time)) {
        best = std::move(c);
        t1 = best->impact.time;
      }
    }
  }
  return best;
}

const WorldEngine::BrakingPath& WorldEngine::brakingOf(BodyId other, double t0) const {
  if (braking_t0_ != t0 || braking_epoch_ != epoch_) {
    braking_paths_.clear();
    braking_t0_ = t0;
    braking_epoch_ = epoch_;
  }
  const auto found = braking_paths_.find(other);
  if (found != braking_paths_.end()) return found->second;
  std::vector<Keyframe> keyframes;
  const double deviation = appendBrakingKeyframes(broad_phase_->motion(other), t0, records_[other].stop_duration,
                                                  broad_phase_->shape(other).bounding_radius, kOthersDeviation,
                                                  keyframes);
  return braking_paths_.emplace(other, BrakingPath{TimedPath(std::move(keyframes), AfterPath::kHold), deviation})
      .first->second;
}

std::optional<WorldEngine::MoverContact> WorldEngine::pathImpact(const Record& rm, BodyId rm_id, size_t mover,
                                                                 const TimedPath& path, const Ball& reach,
                                                                 BodyId other, const World::PathQuery& query,
                                                                 double t0, double t1) const {
  const Record& ro = records_[other];
  // The broad phase's shapes are padded by the tolerance: their radii bound the shapes'.
  const double radius = broad_phase_->shape(rm_id).bounding_radius + broad_phase_->shape(other).bounding_radius;
  ToiOptions options = config_.toi;
  options.tolerance = std::max(options.tolerance, 2.0 * query.deviation);
  std::optional<MoverContact> out;
  const auto consider = [&](const TimeOfImpact& hit, bool stopping) {
    if ((hit.hit || hit.undecided) && (!out || hit.time < out->impact.time)) {
      out = MoverContact{mover, ro.name, ro.key, ro.user, hit, hit.undecided, stopping};
    }
  };
  if (ro.chain) {
    const LinkChain& oc = *ro.chain;
    if (oc.joints().empty()) {
      consider(pressingImpact(*rm.prepared, path, *ro.prepared, oc.base(), t0, t1, radius, options), false);
      return out;
    }
    TimeOfImpact hit = timeOfImpact(*rm.prepared, LinkChain(path), *ro.prepared, oc, t0, t1, options);
    if (hit.hit && hit.initially_touching) {
      const Eigen::Vector3d closing =
          path.motion(path.pieceAt(t0)).velocityOfPoint(hit.point, t0) - oc.velocityOfPoint(hit.point, t0);
      if (!detail::pressesIn(closing, hit.normal)) return out;  // separating or sliding: not blocked
    }
    consider(hit, false);
    return out;
  }
  const Motion& om = broad_phase_->motion(other);
  // The other's origin travels at most originSpeed * time along its screw; braking, half its
  // stop duration's worth.
  const double gap = (reach.centre - om.positionAt(t0)).norm() - reach.radius -
                     broad_phase_->shape(other).bounding_radius;
  const double speed = originSpeed(om);
  if (gap - speed * (t1 - t0) <= options.tolerance) {
    consider(pressingImpact(*rm.prepared, path, *ro.prepared, TimedPath(om), t0, t1, radius, options), false);
  }
  const double braking_reach = speed * std::min(0.5 * ro.stop_duration, t1 - t0);
  if (query.others_stop && std::isfinite(ro.stop_duration) &&
      gap - braking_reach <= 2.0 * (query.deviation + kOthersDeviation) + config_.toi.tolerance) {
    const BrakingPath& braking = brakingOf(other, t0);
    ToiOptions braking_options = config_.toi;
    braking_options.tolerance = std::max(braking_options.tolerance, 2.0 * (query.deviation + braking.deviation));
    const double t_end = out ? out->impact.time : t1;
    consider(pressingImpact(*rm.prepared, path, *ro.prepared, braking.path, t0, t_end, radius, braking_options), true);
  }
  return out;
}

}  // namespace vadop
