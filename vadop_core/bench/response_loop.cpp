#include "response_loop.h"

#include "vadop/error.h"
#include "grid_cells.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>
#include <string>

namespace vadop {

size_t ResponseLoop::KeyHash::operator()(uint64_t k) const { return static_cast<size_t>(detail::mixCellKey(k)); }

namespace {

uint64_t pairKey(BodyId a, BodyId b) { return (static_cast<uint64_t>(a) << 32) | b; }
// The queue's key of a body's boundary contact: above every BodyId, so that the body is a.
uint64_t boundaryKey(BodyId id) { return (uint64_t{1} << 32) | id; }

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

ResponseLoop::ResponseLoop(std::unique_ptr<BroadPhase> broad_phase, const ToiOptions& toi)
    : bp_(std::move(broad_phase)), toi_(toi) {
  if (!bp_) throw InvalidArgument("ResponseLoop: the broad phase is null");
  if (bp_->size() != 0) throw InvalidArgument("ResponseLoop: the broad phase must be empty");
  if (!(std::isfinite(toi.tolerance) && toi.tolerance > 0.0)) {
    throw InvalidArgument("ResponseLoop: toi.tolerance must be finite and > 0, got " + formatNumber(toi.tolerance));
  }
  if (toi.max_iterations <= 0) {
    throw InvalidArgument("ResponseLoop: toi.max_iterations must be > 0, got " + std::to_string(toi.max_iterations));
  }
}

BodyId ResponseLoop::add(const Shape& shape, const Motion& motion) {
  return add(std::make_shared<const Shape>(shape), motion);
}

BodyId ResponseLoop::add(std::shared_ptr<const Shape> shape, const Motion& motion) {
  if (!shape) throw InvalidArgument("ResponseLoop::add: the shape is null");
  validateMotion(motion, "ResponseLoop::add: motion");
  // Everything that can throw comes before the broad phase's add (strong guarantee): the
  // shape's prepared form and padded copy, and room in every per-body and per-shape array.
  const bool new_shape = shape != last_shape_;
  std::optional<PreparedShape> prepared;
  std::shared_ptr<const Shape> padded = last_padded_;
  if (new_shape) {
    validateShape(*shape, "ResponseLoop::add: shape");
    prepared.emplace(*shape);
    // The broad phase sees the shape padded by the tolerance: every pair the narrow phase can
    // report (gap <= tolerance) is then a candidate.
    padded = std::make_shared<const Shape>(inflate(*shape, toi_.tolerance));
    if (free_shapes_.empty() && shapes_.size() == shapes_.capacity()) {
      shapes_.reserve(std::max<size_t>(4, 2 * shapes_.capacity()));
    }
    free_shapes_.reserve(shapes_.capacity());
  }
  // The broad phase's new id is at most one past every id given so far (kinematics_.size()).
  if (kinematics_.size() == kinematics_.capacity()) {
    kinematics_.reserve(std::max<size_t>(16, 2 * kinematics_.capacity()));
  }
  const BodyId id = bp_->add(padded, motion);  // strong guarantee; nothing below throws
  if (new_shape) {
    uint32_t index;
    if (!free_shapes_.empty()) {
      index = free_shapes_.back();
      free_shapes_.pop_back();
    } else {
      index = static_cast<uint32_t>(shapes_.size());
      shapes_.emplace_back();  // within capacity
    }
    shapes_[index].prepared = std::move(prepared);
    last_shape_ = std::move(shape);
    last_padded_ = std::move(padded);
    last_index_ = index;
  }
  if (id >= kinematics_.size()) kinematics_.resize(id + 1);  // within capacity
  kinematics_[id].shape = last_index_;
  ++shapes_[last_index_].uses;
  setKinematics(id);
  return id;
}

size_t ResponseLoop::memoryBytes() const {
  return queue_.memoryBytes() + kinematics_.capacity() * sizeof(Kinematics) +
         shapes_.capacity() * sizeof(SharedShape) + reported_.memoryBytes();
}

void ResponseLoop::remove(BodyId id) {
  bp_->remove(id);  // throws for an unknown id
  const uint32_t index = kinematics_[id].shape;
  if (--shapes_[index].uses == 0) {
    shapes_[index].prepared.reset();
    free_shapes_.push_back(index);  // within capacity (reserved when the shape was added)
    if (index == last_index_) {
      last_shape_.reset();
      last_padded_.reset();
    }
  }
}

void ResponseLoop::setMotion(BodyId id, const Motion& motion) {
  bp_->setMotion(id, motion);
  setKinematics(id);
}

void ResponseLoop::setKinematics(BodyId id) {
  const Motion& m = bp_->motion(id);
  Kinematics& k = kinematics_[id];
  k.position = m.position;
  k.velocity = m.linear_velocity;
  k.t_ref = m.t_ref;
  // Bounding radius about the origin (which moves in a straight line when the body does not
  // turn); rotating bodies are left to the narrow phase. The broad phase holds the shape
  // padded by the tolerance: its radius is the reach, rounded up to a float.
  if (m.isRotating()) {
    k.reach = -1.0f;
  } else {
    const double r = bp_->shape(id).bounding_radius;
    float f = static_cast<float>(r);
    if (static_cast<double>(f) < r) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    k.reach = f;
  }
}

bool ResponseLoop::mayTouch(const Kinematics& ka, const Kinematics& kb, double from, double t1) {
  if (ka.reach < 0.0f || kb.reach < 0.0f) return true;
  // Relative position d(s) = d0 + w s, s in [0, t1 - from]: its least norm against the padded
  // radii, i.e. the radii plus two tolerances (a hit needs a gap <= one; the rounding here is
  // far below a tolerance).
  const Eigen::Vector3d d0 = (kb.position + kb.velocity * (from - kb.t_ref)) - (ka.position + ka.velocity * (from - ka.t_ref));
  const Eigen::Vector3d w = kb.velocity - ka.velocity;
  const double ww = w.squaredNorm();
  const double s = ww > 0.0 ? std::clamp(-d0.dot(w) / ww, 0.0, t1 - from) : 0.0;
  const double reach = static_cast<double>(ka.reach) + static_cast<double>(kb.reach);
  return (d0 + w * s).squaredNorm() <= reach * reach * (1.0 + 1e-12) + 1e-18;
}

void ResponseLoop::Response::setMotion(BodyId id, const Motion& motion) {
  loop_.setMotion(id, motion);
  changed_.push_back(id);
}

bool ResponseLoop::reportedAt(BodyId a, BodyId b, double t) const {
  const double* at = reported_.find(pairKey(a, b));
  return at != nullptr && t <= *at;
}

void ResponseLoop::predict(BodyId a, BodyId b, double from, double t1) {
  if (a > b) std::swap(a, b);
  ++stats_.narrow;
  const Kinematics& ka = kinematics_[a];
  const Kinematics& kb = kinematics_[b];
  if (!mayTouch(ka, kb, from, t1)) return;
  const TimeOfImpact hit = timeOfImpact(*shapes_[ka.shape].prepared, bp_->motion(a), *shapes_[kb.shape].prepared,
                                  bp_->motion(b), from, t1, toi_);
  if (hit.undecided) ++stats_.undecided;  // not a contact (see TimeOfImpact::undecided)
  if (!hit.hit || reportedAt(a, b, hit.time)) return;
  queue_.push(a, b, hit);
}

void ResponseLoop::predictBoundary(BodyId id, double from, double t1) {
  if (!boundary_) return;
  const TimeOfImpact hit = boundary_(id, bp_->motion(id), from, t1);
  if (!hit.hit) return;
  if (!(hit.time >= from && hit.time <= t1) || !hit.point.allFinite() || !hit.normal.allFinite()) {
    throw InvalidArgument("ResponseLoop: the boundary function returned, for body " + std::to_string(id) +
                          ", a contact at t = " + formatNumber(hit.time) + " outside [" + formatNumber(from) + ", " +
                          formatNumber(t1) + "] or with a non-finite point or normal");
  }
  if (reportedAt(id, kBoundary, hit.time)) return;
  queue_.push(id, boundaryKey(id), hit);
}

ResponseLoop::Stats ResponseLoop::advance(double t0, double t1, const Callback& on_contact) {
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0) {
    throw InvalidArgument("ResponseLoop::advance: need finite t0 <= t1, got [" + formatNumber(t0) + ", " +
                          formatNumber(t1) + "]");
  }
  for (const auto& [value, what] : {std::pair<double, const char*>{t0, "advance: t0"}, {t1, "advance: t1"}}) {
    const std::string error = rangeError(value, kMaxTime, what, "s");
    if (!error.empty()) throw InvalidArgument(error);
  }
  if (!on_contact) throw InvalidArgument("ResponseLoop::advance: the callback is empty");
  stats_ = Stats{};
  queue_.clear();
  reported_.clear();
  // Whatever happens below (a throwing callback, a throwing narrow phase), nothing stays
  // pending: the next advance starts from the motions as they are.
  struct Reset {
    ResponseLoop& loop;
    ~Reset() {
      loop.queue_.clear();
      loop.reported_.clear();
    }
  } reset{*this};

  const auto update_start = Clock::now();
  bp_->update(t0, t1);
  stats_.update_seconds = since(update_start);
  stats_.candidates = bp_->pairs().size();
  const auto narrow_start = Clock::now();
  const std::vector<Pair>& pairs = bp_->pairs();
  // The pairs come in no useful memory order: fetch the records of a pair a few ahead.
  constexpr size_t kAhead = 8;
  for (size_t i = 0; i < pairs.size(); ++i) {
    if (i + kAhead < pairs.size()) {
      __builtin_prefetch(&kinematics_[pairs[i + kAhead].a]);
      __builtin_prefetch(&kinematics_[pairs[i + kAhead].b]);
    }
    predict(pairs[i].a, pairs[i].b, t0, t1);
  }
  stats_.narrow_seconds = since(narrow_start);
  if (boundary_) {
    for (BodyId id = 0; id < kinematics_.size(); ++id) {
      if (bp_->contains(id)) predictBoundary(id, t0, t1);
    }
  }

  std::vector<BodyId> found;
  while (!queue_.empty()) {
    const QueuedImpact q = queue_.pop();
    const double tc = q.impact.time;
    const bool with_boundary = q.b > kBoundary;
    const Contact contact{static_cast<BodyId>(q.a), with_boundary ? kBoundary : static_cast<BodyId>(q.b), q.impact};
    reported_.insert(pairKey(contact.a, contact.b), tc) = tc;
    ++stats_.contacts;
    if (with_boundary) ++stats_.boundary_contacts;
    Response response(*this, tc);
    on_contact(contact, response);
    std::vector<BodyId>& changed = response.changed_;
    std::sort(changed.begin(), changed.end());
    changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
    // Their pending impacts are stale; each is re-predicted from tc against what it can reach
    // now (the broad phase's query, with the new motions), each pair once.
    for (BodyId id : changed) queue_.invalidate(id);
    for (BodyId id : changed) {
      if (!bp_->contains(id)) continue;
      ++stats_.requeried;
      const auto query_start = Clock::now();
      bp_->query(id, tc, t1, found);
      const auto narrow_start = Clock::now();
      stats_.query_seconds += std::chrono::duration<double>(narrow_start - query_start).count();
      for (BodyId other : found) {
        if (other < id && std::binary_search(changed.begin(), changed.end(), other)) continue;
        predict(id, other, tc, t1);
      }
      stats_.narrow_seconds += since(narrow_start);
      predictBoundary(id, tc, t1);
    }
  }
  return stats_;
}

}  // namespace vadop
