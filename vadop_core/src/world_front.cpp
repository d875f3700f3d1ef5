// World, the front door of world.h: each call forwarded to its WorldEngine (world_engine.h),
// which holds the bodies and the engines. One indirection a call, none per pair or body.
#include "vadop/world.h"

#include "vadop/error.h"

#include "world_engine.h"

namespace vadop {

std::shared_ptr<const PreparedShape> prepareShape(const Shape& shape, int threads) {
  return std::make_shared<const PreparedShape>(shape, threads);
}

World::World(const WorldConfig& config) : engine_(std::make_unique<WorldEngine>(config)) {}
World::~World() = default;
// A moved-from World holds no engine; engine() then stands in an empty one (world.h: it answers
// as an empty World, and add or predict throw).
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

WorldEngine& World::engine() {
  if (!engine_) engine_ = std::make_unique<WorldEngine>(WorldEngine::Empty{});
  return *engine_;
}

const WorldEngine& World::engine() const {
  static const WorldEngine empty{WorldEngine::Empty{}};
  return engine_ ? *engine_ : empty;
}

void World::add(const std::string& id, const Shape& shape, const Motion& motion, uint64_t user) {
  engine().add(id, shape, motion, user);
}
void World::add(const std::string& id, const std::shared_ptr<const PreparedShape>& shape, const Motion& motion,
                uint64_t user) {
  if (!shape) throw InvalidArgument("add body \"" + id + "\": no prepared shape (null)");
  engine().add(id, *shape, motion, user);
}
void World::remove(const std::string& id) { engine().remove(id); }
void World::setMotion(const std::string& id, const Motion& motion) { engine().setMotion(id, motion); }
World::Handle World::handle(const std::string& id) const { return engine().handle(id); }
void World::setMotion(const Handle& body, const Motion& motion) { engine().setMotion(body, motion); }
void World::setPath(const std::string& id, const TimedPath& path) { engine().setPath(id, path); }
void World::setChain(const std::string& id, const LinkChain& chain) { engine().setChain(id, chain); }
void World::setChain(const Handle& body, std::shared_ptr<const LinkChain> chain) {
  engine().setChain(body, std::move(chain));
}
const TimedPath* World::path(const std::string& id) const { return engine().path(id); }
const LinkChain* World::chain(const std::string& id) const { return engine().chain(id); }
void World::setFilter(const std::string& id, uint32_t group, uint32_t mask) { engine().setFilter(id, group, mask); }
void World::setPairFilter(PairPredicate should_test) { engine().setPairFilter(std::move(should_test)); }

bool World::contains(const std::string& id) const { return engine().contains(id); }
size_t World::size() const { return engine().size(); }
std::vector<std::string> World::ids() const { return engine().ids(); }
const Shape& World::shape(const std::string& id) const { return engine().shape(id); }
std::shared_ptr<const PreparedShape> World::prepared(const std::string& id) const {
  return std::make_shared<const PreparedShape>(engine().prepared(id));  // shares the prepared data
}
const Motion& World::motion(const std::string& id) const { return engine().motion(id); }
uint64_t World::key(const std::string& id) const { return engine().key(id); }

std::vector<Contact> World::predict(double t0, double horizon) { return engine().predict(t0, horizon); }
std::vector<Contact> World::predict(double t0, double horizon, const std::vector<std::string>& only) {
  return engine().predict(t0, horizon, only);
}

World::Reachable World::reachable(const std::vector<std::string>& movers, const std::vector<Eigen::Vector3d>& origins,
                                  const std::vector<double>& reach, double t0, double horizon) {
  return engine().reachable(movers, origins, reach, t0, horizon);
}

std::optional<World::MoverContact> World::firstContactIf(const std::vector<std::string>& movers,
                                                         const std::vector<Motion>& motions, double t0,
                                                         double horizon, const std::function<bool(uint64_t user)>& skip,
                                                         const Reachable* among) {
  return engine().firstContactIf(movers, motions, t0, horizon, skip, among);
}

void World::setStopDuration(const std::string& id, double seconds) { engine().setStopDuration(id, seconds); }
void World::setStopDuration(const Handle& body, double seconds) { engine().setStopDuration(body, seconds); }

std::optional<World::MoverContact> World::firstContactAlong(const std::vector<std::string>& movers,
                                                            const std::vector<TimedPath>& paths, double t0,
                                                            double horizon, const PathQuery& query) {
  return engine().firstContactAlong(movers, paths, t0, horizon, query);
}

std::optional<World::MoverContact> World::firstContactAlong(const std::vector<std::string>& movers,
                                                            const std::vector<TimedPath>& paths, double t0,
                                                            double horizon) {
  return engine().firstContactAlong(movers, paths, t0, horizon, PathQuery{});
}

const WorldConfig& World::config() const { return engine().config(); }
size_t World::lastCandidateCount() const { return engine().lastCandidateCount(); }
size_t World::lastSliceCulledCount() const { return engine().lastSliceCulledCount(); }
size_t World::lastReusedCount() const { return engine().lastReusedCount(); }
const std::vector<Contact>& World::lastUndecided() const { return engine().lastUndecided(); }

}  // namespace vadop
