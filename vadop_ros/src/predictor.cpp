#include "vadop_ros/predictor.h"

#include <vadop/error.h>
#include <vadop/joint_chain.h>
#include <vadop/world.h>

#include <optional>

namespace vadop_ros {
namespace {

vadop::WorldConfig worldConfig(const PredictorConfig& c) {
  vadop::WorldConfig w;
  w.broad_phase = c.queries_only ? vadop::BroadPhaseKind::kBrute : vadop::parseBroadPhaseKind(c.broad_phase);
  w.vadop.axes = c.axes;
  w.vadop.phi_deg = c.phi_deg;
  w.toi.max_iterations = c.max_iterations;
  w.threads = c.threads;
  w.time_slices = c.time_slices;
  w.coherence.clearance = c.coherence_clearance;
  w.coherence.lookahead = c.coherence_lookahead;
  return w;
}

}  // namespace

bool sameMotion(const vadop::Motion& a, const vadop::Motion& b) {
  return a.t_ref == b.t_ref && a.position == b.position && a.orientation.coeffs() == b.orientation.coeffs() &&
         a.linear_velocity == b.linear_velocity && a.angular_velocity == b.angular_velocity &&
         a.pivot_offset == b.pivot_offset;
}

struct Predictor::Impl {
  explicit Impl(const PredictorConfig& c) : world(worldConfig(c)) {}
  struct Slot {
    bool in = false;
    std::string id;
    vadop::World::Handle handle;  // setMotion every cycle without the name's lookup
    vadop::Motion motion;
    std::shared_ptr<const vadop::LinkChain> chain;  // null: motion alone
  };
  vadop::World world;
  std::vector<Slot> slots;
  vadop::World::PairPredicate ignored;  // setIgnored's, as the world's pair filter
  bool ignored_on = true;               // enableIgnored
  std::optional<vadop::World::Reachable> reach;  // beginReach .. endReach

  // The world's ids of elements `movers`; throws, naming `operation`, for one not in the world.
  std::vector<std::string> idsOf(const std::vector<size_t>& movers, const char* operation) const {
    std::vector<std::string> ids;
    ids.reserve(movers.size());
    for (size_t i : movers) {
      if (i >= slots.size() || !slots[i].in) {
        throw vadop::InvalidArgument(std::string(operation) + ": element " + std::to_string(i) + " is not in the world");
      }
      ids.push_back(slots[i].id);
    }
    return ids;
  }
};

Predictor::Predictor(const PredictorConfig& config) : impl_(std::make_unique<Impl>(config)) {}
Predictor::~Predictor() = default;

template <class Add>
bool Predictor::enter(size_t i, const std::string& id, const Add& add, const vadop::Motion& motion, std::string& error,
                      uint32_t group, uint32_t mask, const std::shared_ptr<const vadop::LinkChain>& chain) {
  if (i >= impl_->slots.size()) impl_->slots.resize(i + 1);
  Impl::Slot& s = impl_->slots[i];
  try {
    if (!s.in) {
      // Contacts, the pair filter and the queries' skip carry i back (the world's `user`).
      add();
      impl_->world.setFilter(id, group, mask);  // the id is in: does not throw
      s.in = true;
      s.id = id;
      s.handle = impl_->world.handle(id);
      s.motion = motion;
      s.chain = nullptr;
    } else if (!chain && (!sameMotion(s.motion, motion) || s.chain)) {
      impl_->world.setMotion(s.handle, motion);  // ends a chain
      s.motion = motion;
      s.chain = nullptr;
    }
    // A chain replaces the motion (no setMotion first: it would end the chain only for this
    // to start it again, moving the world's list of path bodies twice per link per cycle).
    if (chain) {
      if (chain != s.chain) impl_->world.setChain(s.handle, chain);
      s.motion = motion;
      s.chain = chain;
    }
    return true;
  } catch (const vadop::InvalidArgument& e) {
    error = e.what();
    return false;
  }
}

bool Predictor::set(size_t i, const std::string& id, const vadop::Shape& shape, const vadop::Motion& motion,
                    std::string& error, uint32_t group, uint32_t mask,
                    const std::shared_ptr<const vadop::LinkChain>& chain) {
  return enter(i, id, [&] { impl_->world.add(id, shape, motion, i); }, motion, error, group, mask, chain);
}

bool Predictor::set(size_t i, const std::string& id, const std::shared_ptr<const vadop::PreparedShape>& shape,
                    const vadop::Motion& motion, std::string& error, uint32_t group, uint32_t mask,
                    const std::shared_ptr<const vadop::LinkChain>& chain) {
  return enter(i, id, [&] { impl_->world.add(id, shape, motion, i); }, motion, error, group, mask, chain);
}

void Predictor::setIgnored(std::function<bool(size_t a, size_t b)> ignored) {
  impl_->ignored = nullptr;
  if (ignored) {
    impl_->ignored = [ignored = std::move(ignored)](uint64_t a, uint64_t b) { return !ignored(a, b); };
  }
  impl_->world.setPairFilter(impl_->ignored_on ? impl_->ignored : nullptr);
}

void Predictor::enableIgnored(bool on) {
  if (on == impl_->ignored_on) return;
  impl_->ignored_on = on;
  impl_->world.setPairFilter(on ? impl_->ignored : nullptr);
}

void Predictor::unset(size_t i) {
  if (i >= impl_->slots.size() || !impl_->slots[i].in) return;
  Impl::Slot& s = impl_->slots[i];
  impl_->world.remove(s.id);
  s.in = false;
}

void Predictor::clear() {
  for (size_t i = 0; i < impl_->slots.size(); ++i) unset(i);
}

bool Predictor::contains(size_t i) const { return i < impl_->slots.size() && impl_->slots[i].in; }
const vadop::Motion& Predictor::motion(size_t i) const { return impl_->slots.at(i).motion; }
const std::shared_ptr<const vadop::LinkChain>& Predictor::chain(size_t i) const { return impl_->slots.at(i).chain; }
Eigen::Isometry3d Predictor::poseAt(size_t i, double t) const {
  const Impl::Slot& s = impl_->slots.at(i);
  return s.chain ? s.chain->poseAt(t) : s.motion.poseAt(t);
}
std::vector<double> Predictor::pathTimes(size_t i, double t0, double t1) const {
  std::vector<double> times;
  const Impl::Slot& s = impl_->slots.at(i);
  if (!s.chain) return times;
  if (s.chain->jointsMove(t0, t1)) {
    for (int k = 1; k < 10; ++k) times.push_back(t0 + (t1 - t0) * k / 10.0);
    return times;
  }
  for (const vadop::Keyframe& k : s.chain->base().keyframes()) {
    if (k.time > t0 && k.time < t1) times.push_back(k.time);
  }
  return times;
}
const vadop::Shape& Predictor::shape(size_t i) const { return impl_->world.shape(impl_->slots.at(i).id); }
std::shared_ptr<const vadop::PreparedShape> Predictor::prepared(size_t i) const {
  return impl_->world.prepared(impl_->slots.at(i).id);
}
size_t Predictor::size() const { return impl_->world.size(); }
size_t Predictor::lastCandidateCount() const { return impl_->world.lastCandidateCount(); }
size_t Predictor::lastSliceCulledCount() const { return impl_->world.lastSliceCulledCount(); }
size_t Predictor::lastReusedCount() const { return impl_->world.lastReusedCount(); }
const std::vector<vadop::Contact>& Predictor::lastUndecided() const { return impl_->world.lastUndecided(); }

std::optional<vadop::World::MoverContact> Predictor::firstContact(const std::vector<size_t>& movers,
                                                                  const std::vector<vadop::Motion>& motions, double t0,
                                                                  double horizon,
                                                                  const std::function<bool(uint64_t element)>& skip) {
  const std::vector<std::string> ids = impl_->idsOf(movers, "firstContact");
  return impl_->world.firstContactIf(ids, motions, t0, horizon, skip, impl_->reach ? &*impl_->reach : nullptr);
}

std::optional<vadop::World::MoverContact> Predictor::firstContactAlong(
    const std::vector<size_t>& movers, const std::vector<vadop::TimedPath>& paths, double t0, double horizon,
    const std::function<bool(uint64_t element)>& skip, double deviation, bool others_stop) {
  const std::vector<std::string> ids = impl_->idsOf(movers, "firstContactAlong");
  vadop::World::PathQuery query;
  query.skip = skip;
  query.among = impl_->reach ? &*impl_->reach : nullptr;
  query.deviation = deviation;
  query.others_stop = others_stop;
  return impl_->world.firstContactAlong(ids, paths, t0, horizon, query);
}

void Predictor::setStopDuration(size_t i, double seconds) {
  if (contains(i)) impl_->world.setStopDuration(impl_->slots[i].handle, seconds);
}

void Predictor::beginReach(const std::vector<size_t>& movers, const std::vector<Eigen::Vector3d>& origins,
                           const std::vector<double>& reach, double t0, double horizon) {
  impl_->reach = impl_->world.reachable(impl_->idsOf(movers, "beginReach"), origins, reach, t0, horizon);
}

void Predictor::endReach() { impl_->reach.reset(); }

std::vector<vadop::Contact> Predictor::predict(double t0, double horizon) {
  if (before_predict_for_testing) {
    for (size_t i = 0; i < impl_->slots.size(); ++i) {
      if (impl_->slots[i].in) before_predict_for_testing(i, impl_->slots[i].id);
    }
  }
  // Every body of the world is an element, added with its index as the caller's key.
  return impl_->world.predict(t0, horizon);
}

}  // namespace vadop_ros
