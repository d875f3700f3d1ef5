#include "vadop/broad_phase.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace vadop {

BodyId BroadPhase::add(const Shape& shape, const Motion& motion) {
  return add(std::make_shared<const Shape>(shape), motion);
}

BodyId BroadPhase::add(std::shared_ptr<const Shape> shape, const Motion& motion) {
  if (!shape) throw InvalidArgument("add: shape is null");
  validateShape(*shape, "add: shape");
  validateMotion(motion, "add: motion");
  BodyId id;
  if (!free_ids_.empty()) {
    id = free_ids_.front();
  } else {
    if (bodies_.size() >= 0xfffffff0u) throw InvalidArgument("add: too many bodies");
    id = static_cast<BodyId>(bodies_.size());
  }
  Body body{std::move(shape), motion, true};
  if (id == bodies_.size()) {
    bodies_.push_back(std::move(body));
  } else {
    std::pop_heap(free_ids_.begin(), free_ids_.end(), std::greater<BodyId>());
    free_ids_.pop_back();
    bodies_[id] = std::move(body);
  }
  ++alive_count_;
  onAdd(id);
  return id;
}

void BroadPhase::requireKnown(BodyId id, const char* operation) const {
  if (!contains(id)) {
    throw InvalidArgument(std::string(operation) + ": unknown body id " + std::to_string(id));
  }
}

void BroadPhase::remove(BodyId id) {
  requireKnown(id, "remove");
  // Grow geometrically before anything changes, so the push below cannot fail half-way.
  if (free_ids_.size() == free_ids_.capacity()) free_ids_.reserve(2 * free_ids_.capacity() + 8);
  onRemove(id);
  bodies_[id].alive = false;
  bodies_[id].shape.reset();
  free_ids_.push_back(id);
  std::push_heap(free_ids_.begin(), free_ids_.end(), std::greater<BodyId>());
  --alive_count_;
}

void BroadPhase::setMotion(BodyId id, const Motion& motion) {
  requireKnown(id, "setMotion");
  if (!isValidMotion(motion)) validateMotion(motion, "setMotion: body " + std::to_string(id));
  onMotionChanging(id);
  bodies_[id].motion = motion;
  onSetMotion(id);
}

void BroadPhase::update(double t0, double t1) {
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0) {
    throw InvalidArgument("update: need finite t0 <= t1, got [" + std::to_string(t0) + ", " +
                          std::to_string(t1) + "]");
  }
  pairs_.clear();
  computePairs(t0, t1, pairs_);
  std::sort(pairs_.begin(), pairs_.end());
}

const Shape& BroadPhase::shape(BodyId id) const {
  requireKnown(id, "shape");
  return *bodies_[id].shape;
}

const Motion& BroadPhase::motion(BodyId id) const {
  requireKnown(id, "motion");
  return bodies_[id].motion;
}

double segmentSegmentDistanceSquared(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                     const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) {
  // Minimise |p0 + s d1 - q0 - t d2|^2 over the unit square; the clamped closed form.
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 0.0 && e <= 0.0) return r.squaredNorm();
  if (a <= 0.0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 0.0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;
      s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return (p0 + s * d1 - q0 - t * d2).squaredNorm();
}

void BruteForceBroadPhase::computePairs(double t0, double t1, std::vector<Pair>& out) {
  const auto& b = bodies();
  struct Capsule {
    Eigen::Vector3d p0, p1;
    double r;
    BodyId id;
  };
  std::vector<Capsule> caps;
  caps.reserve(size());
  for (BodyId i = 0; i < b.size(); ++i) {
    if (!b[i].alive) continue;
    // The ball about the pivot that holds the shape in every orientation, swept along the
    // pivot's straight path.
    const Motion& m = b[i].motion;
    const double r = b[i].shape->bounding_radius + (m.hasPivot() ? m.pivot_offset.norm() : 0.0);
    caps.push_back({m.pivotAt(t0), m.pivotAt(t1), r, i});
  }
  for (size_t i = 0; i < caps.size(); ++i) {
    for (size_t j = i + 1; j < caps.size(); ++j) {
      const double r = caps[i].r + caps[j].r;
      // The relative widening keeps the test conservative under rounding.
      const double reach = r * (1.0 + 1e-12) + 1e-12;
      if (segmentSegmentDistanceSquared(caps[i].p0, caps[i].p1, caps[j].p0, caps[j].p1) <= reach * reach) {
        out.push_back(makePair(caps[i].id, caps[j].id));
      }
    }
  }
}

}  // namespace vadop
