#include "vadop/response_loop.h"

#include "vadop/error.h"
#include "vadop/limits.h"
#include "grid_cells.h"

#include <algorithm>
#include <chrono>
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
  if (shape != last_shape_) {
    validateShape(*shape, "ResponseLoop::add: shape");
    PreparedShape prepared(*shape);
    // The broad phase sees the shape padded by the tolerance: every pair the narrow phase can
    // report (gap <= tolerance) is then a candidate.
    auto padded = std::make_shared<const Shape>(inflate(*shape, toi_.tolerance));
    last_prepared_.emplace(std::move(prepared));
    last_padded_ = std::move(padded);
    last_shape_ = shape;
  }
  if (prepared_.size() == prepared_.capacity()) {
    prepared_.reserve(std::max<size_t>(16, 2 * prepared_.capacity()));
    kinematics_.reserve(prepared_.capacity());
  }
  const BodyId id = bp_->add(last_padded_, motion);  // strong guarantee; nothing below throws
  if (id >= prepared_.size()) {
    prepared_.resize(id + 1);
    kinematics_.resize(prepared_.capacity());  // within capacity: cannot fail after the add
  }
  prepared_[id].emplace(*last_prepared_);
  setKinematics(id);
  return id;
}

size_t ResponseLoop::memoryBytes() const {
  return queue_.memoryBytes() + prepared_.capacity() * sizeof(std::optional<PreparedShape>) +
         reported_.memoryBytes();
}

void ResponseLoop::remove(BodyId id) {
  bp_->remove(id);  // throws for an unknown id
  prepared_[id].reset();
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
  // turn); rotating bodies are left to the narrow phase.
  // The broad phase holds the shape padded by the tolerance: its radius is the reach.
  k.reach = m.isRotating() ? -1.0 : bp_->shape(id).bounding_radius;
}

bool ResponseLoop::mayTouch(BodyId a, BodyId b, double from, double t1) const {
  const Kinematics& ka = kinematics_[a];
  const Kinematics& kb = kinematics_[b];
  if (ka.reach < 0.0 || kb.reach < 0.0) return true;
  // Relative position d(s) = d0 + w s, s in [0, t1 - from]: its least norm against the padded
  // radii, i.e. the radii plus two tolerances (a hit needs a gap <= one; the rounding here is
  // far below a tolerance).
  const Eigen::Vector3d d0 = (kb.position + kb.velocity * (from - kb.t_ref)) - (ka.position + ka.velocity * (from - ka.t_ref));
  const Eigen::Vector3d w = kb.velocity - ka.velocity;
  const double ww = w.squaredNorm();
  const double s = ww > 0.0 ? std::clamp(-d0.dot(w) / ww, 0.0, t1 - from) : 0.0;
  const double reach = ka.reach + kb.reach;
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
  if (!mayTouch(a, b, from, t1)) return;
  const Impact hit = timeOfImpact(*prepared_[a], bp_->motion(a), *prepared_[b], bp_->motion(b), from, t1, toi_);
  if (hit.undecided) ++stats_.undecided;  // not a contact (see Impact::undecided)
  if (!hit.hit || reportedAt(a, b, hit.time)) return;
  queue_.push(a, b, hit);
}

void ResponseLoop::predictBoundary(BodyId id, double from, double t1) {
  if (!boundary_) return;
  const Impact hit = boundary_(id, bp_->motion(id), from, t1);
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
  for (const Pair& p : bp_->pairs()) predict(p.a, p.b, t0, t1);
  stats_.narrow_seconds = since(narrow_start);
  if (boundary_) {
    for (BodyId id = 0; id < prepared_.size(); ++id) {
      if (prepared_[id]) predictBoundary(id, t0, t1);
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
