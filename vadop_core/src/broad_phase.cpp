#include "vadop/broad_phase.h"

#include "vadop/error.h"
#include "vadop/vadop.h"
#include "cell_grid.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace vadop {

namespace {
void requireInterval(double t0, double t1, const char* operation) {
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0) {
    throw InvalidArgument(std::string(operation) + ": need finite t0 <= t1, got [" + std::to_string(t0) +
                          ", " + std::to_string(t1) + "]");
  }
}
void sortUnique(std::vector<BodyId>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

// The capsule swept by the ball about the pivot that holds the shape in every orientation.
struct Capsule {
  Eigen::Vector3d p0, p1;
  double r;
};
Capsule sweptCapsule(const Shape& shape, const Motion& m, double t0, double t1) {
  return {m.centreAt(t0), m.centreAt(t1), shape.bounding_radius + m.pivotArm()};
}
bool capsulesMayTouch(const Capsule& a, const Capsule& b) {
  // The relative widening keeps the test conservative under rounding.
  const double reach = (a.r + b.r) * (1.0 + 1e-12) + 1e-12;
  return segmentSegmentDistanceSquared(a.p0, a.p1, b.p0, b.p1) <= reach * reach;
}
}  // namespace

BroadPhase::BroadPhase() = default;
BroadPhase::~BroadPhase() = default;

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
  markChanged(id);
  return id;
}

void BroadPhase::throwUnknown(BodyId id, const char* operation) {
  throw InvalidArgument(std::string(operation) + ": unknown body id " + std::to_string(id));
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
  markChanged(id);  // the frame's answers must drop it
}

void BroadPhase::setMotion(BodyId id, const Motion& motion) {
  requireKnown(id, "setMotion");
  if (!isValidMotion(motion)) validateMotion(motion, "setMotion: body " + std::to_string(id));
  onSetMotion(id);
  bodies_[id].motion = motion;
  markChanged(id);
}

void BroadPhase::markChanged(BodyId id) {
  if (!framed_) return;  // no frame to answer queries from yet
  if (changed_flag_.size() <= id) changed_flag_.resize(std::max<size_t>(id + 1, 2 * changed_flag_.size()), 0);
  changed_flag_[id] = 1;
  changed_.push_back(id);
}

void BroadPhase::setThreads(int threads) {
  if (threads < 1) throw InvalidArgument("setThreads: threads must be >= 1, got " + std::to_string(threads));
  threads_ = threads;
}

void BroadPhase::update(double t0, double t1) {
  // The caller's boxes serve this update only, whether it completes or throws.
  struct Forget {
    const double*& boxes;
    ~Forget() { boxes = nullptr; }
  } forget{frame_boxes_};
  requireInterval(t0, t1, "update");
  pairs_.clear();
  framed_ = false;  // a throwing computePairs leaves no frame to answer queries from
  computePairs(t0, t1, pairs_);
  if (!std::is_sorted(pairs_.begin(), pairs_.end())) std::sort(pairs_.begin(), pairs_.end());
  for (BodyId id : changed_) changed_flag_[id] = 0;
  changed_.clear();
  changed_indexed_ = 0;
  changed_grid_valid_ = false;
  frame_t0_ = t0;
  frame_t1_ = t1;
  framed_ = true;
}


void BroadPhase::query(BodyId id, double t0, double t1, std::vector<BodyId>& out) {
  requireKnown(id, "query");
  requireInterval(t0, t1, "query");
  // Nothing below throws but an allocation: `out` is the work space (no allocation per query).
  out.clear();
  queryCandidates(*bodies_[id].shape, bodies_[id].motion, id, t0, t1, out);
  sortUnique(out);
}

void BroadPhase::query(const Shape& shape, const Motion& motion, double t0, double t1,
                       std::vector<BodyId>& out) {
  validateShape(shape, "query: shape");
  validateMotion(motion, "query: motion");
  requireInterval(t0, t1, "query");
  out.clear();
  queryCandidates(shape, motion, kNoBody, t0, t1, out);
  sortUnique(out);
}

void BroadPhase::queryCandidates(const Shape& shape, const Motion& motion, BodyId self, double t0,
                                 double t1, std::vector<BodyId>& out) {
  if (framed_ && t0 >= frame_t0_ && t1 <= frame_t1_) {
    double box[6];
    SweptBody(shape, motion, t0, t1).box(box);
    frame_found_.clear();
    if (queryFrame(box, frame_found_)) {
      // The engine's volumes of the frame hold the unchanged bodies' paths over [t0, t1].
      for (BodyId id : frame_found_) {
        // changed_flag_ also marks the bodies removed (and re-added) since the update.
        if (id != self && !(id < changed_flag_.size() && changed_flag_[id])) out.push_back(id);
      }
      queryChanged(box, self, t0, t1, out);
      return;
    }
  }
  const Capsule q = sweptCapsule(shape, motion, t0, t1);
  for (BodyId i = 0; i < bodies_.size(); ++i) {
    if (!bodies_[i].alive || i == self) continue;
    if (capsulesMayTouch(q, sweptCapsule(*bodies_[i].shape, bodies_[i].motion, t0, t1))) out.push_back(i);
  }
}

void BroadPhase::queryChanged(const double* box, BodyId self, double t0, double t1, std::vector<BodyId>& out) {
  auto overlaps = [box](const double* x) {
    return x[0] <= box[3] && box[0] <= x[3] && x[1] <= box[4] && box[1] <= x[4] && x[2] <= box[5] && box[2] <= x[5];
  };
  // A few changed bodies: their swept boxes over [t0, t1], directly.
  constexpr size_t kScanAtMost = 32;
  if (changed_.size() <= kScanAtMost) {
    for (BodyId id : changed_) {
      if (id == self || !contains(id)) continue;
      double x[6];
      SweptBody(*bodies_[id].shape, bodies_[id].motion, t0, t1).box(x);
      if (overlaps(x)) out.push_back(id);
    }
    return;
  }
  // More: a grid of their boxes, each over [the t0 of the query that indexed it, frame_t1_],
  // which holds every later window of the frame: valid while queries do not start before the
  // latest such t0 (changed_t0_; a response loop's queries only move forward), rebuilt from
  // scratch otherwise. A body changed again is indexed again (its old box goes stale).
  if (!changed_grid_valid_ || t0 < changed_t0_) {
    if (!changed_grid_) changed_grid_ = std::make_unique<detail::CellGrid>();
    // Cells about the size of the median box, measured on the first changed bodies.
    std::vector<double> extent;
    double max_abs = 0.0;
    for (size_t i = 0; i < std::min<size_t>(changed_.size(), 64); ++i) {
      const BodyId id = changed_[i];
      if (!contains(id)) continue;
      double x[6];
      SweptBody(*bodies_[id].shape, bodies_[id].motion, t0, frame_t1_).box(x);
      extent.push_back(std::max({x[3] - x[0], x[4] - x[1], x[5] - x[2]}));
      for (double v : x) max_abs = std::max(max_abs, std::abs(v));
    }
    double h = 1.0;
    if (!extent.empty()) {
      std::nth_element(extent.begin(), extent.begin() + extent.size() / 2, extent.end());
      h = extent[extent.size() / 2];
    }
    changed_grid_->reset(std::isfinite(h) && h > 1e-9 ? h : 1e-9, max_abs);
    changed_t0_ = t0;
    changed_indexed_ = 0;
    changed_grid_valid_ = true;
  }
  if (changed_indexed_ < changed_.size()) changed_t0_ = t0;
  for (; changed_indexed_ < changed_.size(); ++changed_indexed_) {
    const BodyId id = changed_[changed_indexed_];
    if (!contains(id)) {
      changed_grid_->remove(id);
      continue;
    }
    double x[6];
    SweptBody(*bodies_[id].shape, bodies_[id].motion, t0, frame_t1_).box(x);
    changed_grid_->set(id, x);
  }
  changed_grid_->forEachOverlap(box, [&](BodyId id) {
    if (id != self && contains(id)) out.push_back(id);
  });
  for (BodyId id : changed_grid_->large()) {
    if (id != self && contains(id) && overlaps(changed_grid_->box(id))) out.push_back(id);
  }
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
  std::vector<Capsule> caps;
  std::vector<BodyId> ids;
  caps.reserve(size());
  ids.reserve(size());
  for (BodyId i = 0; i < b.size(); ++i) {
    if (!b[i].alive) continue;
    caps.push_back(sweptCapsule(*b[i].shape, b[i].motion, t0, t1));
    ids.push_back(i);
  }
  for (size_t i = 0; i < caps.size(); ++i) {
    for (size_t j = i + 1; j < caps.size(); ++j) {
      if (capsulesMayTouch(caps[i], caps[j])) out.push_back(makePair(ids[i], ids[j]));
    }
  }
}

}  // namespace vadop
