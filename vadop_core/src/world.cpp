#include "world_engine.h"

#include "mesh_bvh.h"
#include "name_index.h"
#include "pressed_together.h"
#include "pair_certificates.h"

#include "vadop/detail/parallel_for.h"
#include "vadop/error.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>

namespace vadop {
namespace {

// Boxes as lo x y z, hi x y z; touching counts.
bool boxesOverlap(const double* a, const double* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

// The id in double quotes, with quotes, backslashes and control characters escaped, so that a
// message always stays on one line.
std::string quoted(const std::string& id) {
  std::string out = "\"";
  for (const char c : id) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::unique_ptr<BroadPhase> makeBroadPhase(const WorldConfig& c) {
  switch (c.broad_phase) {
    case BroadPhaseKind::kVadop: return std::make_unique<VadopGridBroadPhase>(c.vadop);  // validates
    case BroadPhaseKind::kVadopSap: return std::make_unique<SweepPruneBroadPhase>(c.vadop);
    case BroadPhaseKind::kSap: return SweepPruneBroadPhase::makeEveryAxis(3);
    case BroadPhaseKind::kBrute: return std::make_unique<BruteForceBroadPhase>();
    case BroadPhaseKind::kGrid: return VadopGridBroadPhase::makeBoxOnly();
  }
  throw InvalidArgument("World: unknown broad phase kind " + std::to_string(static_cast<int>(c.broad_phase)));
}

}  // namespace

const char* toString(BroadPhaseKind kind) {
  switch (kind) {
    case BroadPhaseKind::kVadop: return "vadop";
    case BroadPhaseKind::kVadopSap: return "vadop_sap";
    case BroadPhaseKind::kSap: return "sap";
    case BroadPhaseKind::kBrute: return "brute";
    case BroadPhaseKind::kGrid: return "grid";
  }
  return "unknown";
}

BroadPhaseKind parseBroadPhaseKind(const std::string& name) {
  if (name == "vadop") return BroadPhaseKind::kVadop;
  if (name == "vadop_sap") return BroadPhaseKind::kVadopSap;
  if (name == "sap") return BroadPhaseKind::kSap;
  if (name == "brute") return BroadPhaseKind::kBrute;
  if (name == "grid") return BroadPhaseKind::kGrid;
  throw InvalidArgument("unknown broad phase " + quoted(name) + " (expected vadop, vadop_sap, sap, grid or brute)");
}

WorldEngine::WorldEngine(const WorldConfig& config) : config_(config), by_name_(std::make_unique<detail::NameIndex>()) {
  static std::atomic<uint64_t> worlds{0};
  serial_ = ++worlds;
  const ToiOptions& o = config.toi;
  if (!(std::isfinite(o.tolerance) && o.tolerance > 0.0)) {
    throw InvalidArgument("World: toi.tolerance must be finite and > 0, got " + formatNumber(o.tolerance));
  }
  if (o.max_iterations <= 0) {
    throw InvalidArgument("World: toi.max_iterations must be > 0, got " + std::to_string(o.max_iterations));
  }
  if (config.threads < 0 || config.threads > kMaxThreads) {
    throw InvalidArgument("World: threads must be in [0, " + std::to_string(kMaxThreads) + "] (0: one per hardware "
                          "thread), got " + std::to_string(config.threads));
  }
  if (config.time_slices < 1 || config.time_slices > kMaxTimeSlices) {
    throw InvalidArgument("World: time_slices must be in [1, " + std::to_string(kMaxTimeSlices) + "] (1: no cull), got " +
                          std::to_string(config.time_slices));
  }
  const WorldConfig::Coherence& co = config.coherence;
  if (!(std::isfinite(co.clearance) && co.clearance >= 0.0 && co.clearance <= kMaxSize) ||
      (co.clearance > 0.0 && co.clearance <= o.tolerance)) {
    throw InvalidArgument("World: coherence.clearance must be 0 (off) or in (toi.tolerance = " +
                          formatNumber(o.tolerance) + ", " + formatNumber(kMaxSize) + "] m, got " +
                          formatNumber(co.clearance));
  }
  if (!(std::isfinite(co.lookahead) && co.lookahead >= 0.0 && co.lookahead <= kMaxTime)) {
    throw InvalidArgument("World: coherence.lookahead must be in [0, " + formatNumber(kMaxTime) + "] s, got " +
                          formatNumber(co.lookahead));
  }
  if (co.clearance > 0.0) {
    certificates_ = std::make_unique<detail::PairCertificates>();
    certificates_->configure(co.clearance, o.tolerance);
  }
  threads_ = detail::threadCount(config.threads);
  broad_phase_ = makeBroadPhase(config);
  broad_phase_->setThreads(threads_);
}

// by_name_ keeps no names: they live in the records.
struct WorldEngine::NameOf {
  const detail::LargeArray<Record>& records;
  const std::string& operator()(BodyId b) const { return records[b].name; }
};

WorldEngine::WorldEngine(Empty) {}
WorldEngine::~WorldEngine() = default;

void WorldEngine::requireEngine(const char* operation) const {
  if (!broad_phase_) throw InvalidArgument(std::string(operation) + ": this World was moved from");
}

void WorldEngine::requireNewId(const std::string& id) const {
  requireEngine("add");
  if (id.empty()) throw InvalidArgument("add: the body id must not be empty");
  if (findBody(id) != kUnknownBody) {
    throw InvalidArgument("add body " + quoted(id) + ": a body with this id already exists");
  }
}

void WorldEngine::add(const std::string& id, const Shape& shape, const Motion& motion, uint64_t user) {
  requireNewId(id);  // before the shape is prepared (a large mesh's tree)
  validateShape(shape, "add body " + quoted(id) + ": shape");
  add(id, PreparedShape(shape), motion, user);
}

void WorldEngine::add(const std::string& id, const PreparedShape& prepared, const Motion& motion, uint64_t user) {
  ++epoch_;  // the others' braking paths (brakingOf) are made again
  requireNewId(id);
  validateMotion(motion, "add body " + quoted(id) + ": motion");  // the shape was validated when prepared
  const Shape& shape = prepared.shape();

  // Everything that can fail happens before the first change (strong guarantee).
  Record rec;
  rec.name = id;
  rec.key = next_key_;
  rec.user = user;
  rec.prepared.emplace(prepared);  // shares the prepared data
  // Padded by the narrow phase's tolerance: every pair the narrow phase can report as touching
  // (gap <= tolerance) then has intersecting swept volumes, hence is a candidate for every
  // (complete) broad phase, and the result does not depend on the broad phase chosen.
  const Shape padded = inflate(shape, config_.toi.tolerance);
  // Room for one more record and one more name, grown geometrically (reserve(size + 1) would
  // reallocate on every add): the insertions below then cannot allocate or rehash.
  if (records_.size() == records_.capacity()) records_.reserve(std::max<size_t>(16, 2 * records_.capacity()));
  by_name_->reserve(by_name_->size() + 1);

  const BodyId bid = broad_phase_->add(padded, motion);  // strong guarantee
  // From here on nothing throws.
  if (bid == records_.size()) {
    records_.push_back(std::move(rec));  // capacity reserved; Record moves without throwing
  } else {
    records_[bid] = std::move(rec);
  }
  by_name_->insert(id, bid);
  ++next_key_;
  if (records_[bid].prepared->data().kind == detail::CoreKind::kMesh) ++meshes_;
}

void WorldEngine::remove(const std::string& id) {
  ++epoch_;  // the others' braking paths (brakingOf) are made again
  const BodyId bid = bodyId(id, "remove");
  broad_phase_->remove(bid);  // strong guarantee; nothing below throws
  by_name_->erase(id, NameOf{records_});
  if (records_[bid].chain) path_bodies_.erase(std::lower_bound(path_bodies_.begin(), path_bodies_.end(), bid));
  if (records_[bid].prepared->data().kind == detail::CoreKind::kMesh) --meshes_;
  records_[bid] = Record{};
}

void WorldEngine::setMotion(const std::string& id, const Motion& motion) { setMotionOf(bodyId(id, "setMotion"), motion); }

WorldEngine::Handle WorldEngine::handle(const std::string& id) const {
  const BodyId bid = bodyId(id, "handle");
  return Handle{static_cast<uint32_t>(bid), records_[bid].key, serial_};
}

void WorldEngine::setMotion(const Handle& body, const Motion& motion) { setMotionOf(handleId(body, "setMotion"), motion); }

void WorldEngine::setStopDuration(const std::string& id, double seconds) {
  setStopDurationOf(bodyId(id, "setStopDuration"), seconds);
}

void WorldEngine::setStopDuration(const Handle& body, double seconds) {
  setStopDurationOf(handleId(body, "setStopDuration"), seconds);
}

void WorldEngine::setStopDurationOf(BodyId bid, double seconds) {
  ++epoch_;  // the others' braking paths (brakingOf) are made again
  if (std::isnan(seconds) || seconds < 0.0) {
    throw InvalidArgument("setStopDuration body " + quoted(records_[bid].name) +
                          ": the duration must be >= 0 (+infinity: never), got " + formatNumber(seconds));
  }
  records_[bid].stop_duration = seconds;
}

BodyId WorldEngine::handleId(const Handle& body, const char* operation) const {
  if (body.world != serial_ || body.index >= records_.size() || !records_[body.index].prepared ||
      records_[body.index].key != body.key) {
    throw InvalidArgument(std::string(operation) + ": the handle (key " + std::to_string(body.key) +
                          ") names no body of this World: removed, or another World's");
  }
  return body.index;
}

void WorldEngine::setMotionOf(BodyId bid, const Motion& motion) {
  ++epoch_;  // the others' braking paths (brakingOf) are made again
  // The message is built only for a motion the quick test refuses (setMotion runs per body per cycle).
  if (!isValidMotion(motion)) validateMotion(motion, "setMotion body " + quoted(records_[bid].name) + ": motion");
  broad_phase_->setMotion(bid, motion);  // strong guarantee; nothing below throws
  if (records_[bid].chain) {
    path_bodies_.erase(std::lower_bound(path_bodies_.begin(), path_bodies_.end(), bid));
    records_[bid].chain.reset();
  }
}

void WorldEngine::setPath(const std::string& id, const TimedPath& path) {
  bodyId(id, "setPath");
  setChain(id, LinkChain(path));
}

void WorldEngine::setChain(const std::string& id, const LinkChain& chain) {
  setChainOf(bodyId(id, "setChain"), std::make_shared<const LinkChain>(chain));
}

void WorldEngine::setChain(const Handle& body, std::shared_ptr<const LinkChain> chain) {
  const BodyId bid = handleId(body, "setChain");
  if (!chain) throw InvalidArgument("setChain: body " + quoted(records_[bid].name) + ": no chain (null)");
  setChainOf(bid, std::move(chain));
}

void WorldEngine::setChainOf(BodyId bid, std::shared_ptr<const LinkChain> chain) {
  ++epoch_;  // the others' braking paths (brakingOf) are made again
  path_bodies_.reserve(path_bodies_.size() + 1);
  broad_phase_->setMotion(bid, chain->base().motion(0));  // strong guarantee; nothing below throws
  if (!records_[bid].chain) path_bodies_.insert(std::lower_bound(path_bodies_.begin(), path_bodies_.end(), bid), bid);
  records_[bid].chain = std::move(chain);
}

const TimedPath* WorldEngine::path(const std::string& id) const {
  const Record& r = record(id, "path");
  return r.chain ? &r.chain->base() : nullptr;
}

const LinkChain* WorldEngine::chain(const std::string& id) const { return record(id, "chain").chain.get(); }

void WorldEngine::setFilter(const std::string& id, uint32_t group, uint32_t mask) {
  Record& r = records_[bodyId(id, "setFilter")];
  r.group = group;
  r.mask = mask;
}

std::vector<std::string> WorldEngine::ids() const {
  if (!by_name_) return {};  // moved from
  std::vector<const Record*> alive;
  alive.reserve(by_name_->size());
  by_name_->forEach([&](BodyId b) { alive.push_back(&records_[b]); });
  std::sort(alive.begin(), alive.end(), [](const Record* x, const Record* y) { return x->key < y->key; });
  std::vector<std::string> out;
  out.reserve(alive.size());
  for (const Record* r : alive) out.push_back(r->name);
  return out;
}

bool WorldEngine::contains(const std::string& id) const { return findBody(id) != kUnknownBody; }

size_t WorldEngine::size() const { return by_name_ ? by_name_->size() : 0; }

BodyId WorldEngine::findBody(const std::string& id) const {
  static_assert(detail::NameIndex::kNone == kUnknownBody, "one value for no body");
  if (!by_name_) return kUnknownBody;  // moved from
  return by_name_->find(id, NameOf{records_});
}

BodyId WorldEngine::bodyId(const std::string& id, const char* operation) const {
  const BodyId b = findBody(id);
  if (b == kUnknownBody) throw InvalidArgument(std::string(operation) + ": unknown body " + quoted(id));
  return b;
}

const WorldEngine::Record& WorldEngine::record(const std::string& id, const char* operation) const {
  return records_[bodyId(id, operation)];
}

const Shape& WorldEngine::shape(const std::string& id) const { return record(id, "shape").prepared->shape(); }
const PreparedShape& WorldEngine::prepared(const std::string& id) const { return *record(id, "prepared").prepared; }

const Motion& WorldEngine::motion(const std::string& id) const {
  const BodyId b = bodyId(id, "motion");  // first: a moved-from World has no broad phase
  return broad_phase_->motion(b);
}

uint64_t WorldEngine::key(const std::string& id) const { return record(id, "key").key; }

std::vector<Contact> WorldEngine::predict(double t0, double horizon) { return run(t0, horizon, nullptr); }

std::vector<Contact> WorldEngine::predict(double t0, double horizon, const std::vector<std::string>& only) {
  std::vector<BodyId> ids;
  ids.reserve(only.size());
  for (const std::string& id : only) ids.push_back(bodyId(id, "predict"));
  for (BodyId id : ids) broad_phase_->prefetch(id);  // the query's loads of several bodies overlap
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return run(t0, horizon, &ids);
}

std::vector<Contact> WorldEngine::run(double t0, double horizon, const std::vector<BodyId>* only) {
  requireEngine("predict");
  const double t1 = checkedWindow("predict", t0, horizon);
  const detail::ParallelBatch batch;  // the calls below follow each other closely
  // The candidate pairs: the whole broad phase, or the queries of `only`.
  std::vector<Pair> queried;
  bool all_parts = false;
  if (only) {
    queryPairs(*only, t0, t1, queried);
  } else {
    // In id order (a removed body's record holds no shape): the motions are read as stored.
    for (BodyId id = 0; id < records_.size(); ++id) {
      if (records_[id].prepared) checkReach(id, t0, t1);
    }
    all_parts = allPairs(t0, t1, queried);
  }
  std::vector<Candidate> tests = testedPairs(only || !path_bodies_.empty() ? queried : broad_phase_->pairs());
  const size_t found = tests.size();
  cullBySlices(tests, t0, t1, all_parts);
  if (!only) parts_for_all_ = (all_parts ? 2 * found : found) >= records_.size();
  std::vector<TimeOfImpact> results;
  if (certificates_ && !only) certificates_->beginPass();
  narrowAll(tests, t0, t1, results);
  if (certificates_ && !only) certificates_->endPass();
  std::vector<Contact> out = contactsInOrder(tests, results, false);
  std::vector<Contact> undecided = contactsInOrder(tests, results, true);
  // Nothing above throws once the narrow phase has run: the statistics change together.
  last_candidates_ = tests.size();
  last_slice_culled_ = found - tests.size();
  last_undecided_ = std::move(undecided);
  return out;
}

double WorldEngine::checkedWindow(const char* operation, double t0, double horizon) const {
  const std::string op = operation;
  if (!std::isfinite(t0)) throw InvalidArgument(op + ": t0 must be finite, got " + formatNumber(t0));
  if (!std::isfinite(horizon) || horizon < 0.0) {
    throw InvalidArgument(op + ": horizon must be finite and >= 0, got " + formatNumber(horizon));
  }
  const double t1 = t0 + horizon;
  // The range of error.h for the window's times (the bodies' positions: checkReach).
  for (const auto& [field, value] : {std::pair<std::string, double>{op + ": t0", t0}, {op + ": t0 + horizon", t1}}) {
    const std::string error = rangeError(value, kMaxTime, field, "s");
    if (!error.empty()) throw InvalidArgument(error);
  }
  return t1;
}

// A cheap bound of each coordinate of the body's origin over [s, e]: the pivot moves in a
// straight line (its coordinates are largest at an end) and the origin stays within
// |pivot_offset| of it. Motions are within range (validateMotion), so nothing overflows.
void WorldEngine::checkMotionReach(BodyId id, const Motion& m, double s, double e) const {
  const Eigen::Vector3d c0 = m.centreAt(s), c1 = m.centreAt(e);
  const double arm = m.pivotArm();
  for (int k = 0; k < 3; ++k) {
    const double reach = std::max(std::abs(c0[k]), std::abs(c1[k])) + arm;
    if (reach <= kMaxReach) continue;  // the message (two formatted numbers) only on failure
    const std::string error = rangeError(reach, kMaxReach,
                                         "position[" + std::to_string(k) + "] over [" + formatNumber(s) + ", " +
                                             formatNumber(e) + "] (bound)",
                                         "m");
    if (!error.empty()) throw InvalidArgument("predict: body " + quoted(records_[id].name) + ": " + error);
  }
}

void WorldEngine::checkReach(BodyId id, double t0, double t1) const {
  // records_ read only when some body is on a path: a query's hot path reads no more than the
  // broad phase's motion.
  const TimedPath* path = !path_bodies_.empty() && records_[id].chain ? &records_[id].chain->base() : nullptr;
  if (!path) return checkMotionReach(id, broad_phase_->motion(id), t0, t1);
  path->forEachPiece(t0, t1, [&](size_t k, double s, double e) { checkMotionReach(id, path->motion(k), s, e); });
}

void WorldEngine::queryPairs(const std::vector<BodyId>& only, double t0, double t1, std::vector<Pair>& out) {
  const bool paths = !path_bodies_.empty();
  // `only` is sorted: membership by binary search, no O(n) mask per query.
  auto in_only = [&only](BodyId id) { return std::binary_search(only.begin(), only.end(), id); };
  std::vector<BodyId> found;
  for (BodyId id : only) checkReach(id, t0, t1);
  for (BodyId id : only) {
    if (paths && onPath(id)) continue;  // from pathPairs
    broad_phase_->query(id, t0, t1, found);
    for (BodyId other : found) {
      if (other < id && in_only(other)) continue;  // a pair of two of them once: from the smaller id
      if (paths && onPath(other)) continue;  // the broad phase holds it at rest: from pathPairs
      if (!in_only(other)) checkReach(other, t0, t1);
      out.push_back(makePair(id, other));
    }
  }
  const size_t direct = out.size();
  if (paths) pathPairs(t0, t1, &only, out);
  for (size_t i = direct; i < out.size(); ++i) {
    for (BodyId id : {out[i].a, out[i].b}) {
      if (!in_only(id)) checkReach(id, t0, t1);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

bool WorldEngine::allPairs(double t0, double t1, std::vector<Pair>& out) {
  const bool paths = !path_bodies_.empty();
  // A crowded world: every body's part boxes first, their unions the broad phase's boxes, and
  // the path bodies' boxes in pathPairs (the broad phase holds those at rest: with paths it
  // computes the others' boxes itself).
  const bool all_parts = parts_for_all_ && config_.time_slices > 1 && t1 > t0;
  if (all_parts) {
    fillAllPartBoxes(t0, t1);
    if (!paths) broad_phase_->setFrameBoxes(frame_boxes_.data());
  }
  // Every body on a path (a fleet of arms on joint states): the broad phase would find only
  // pairs of path bodies, all dropped, so it is not updated (no query of this world asks it
  // then: othersThanPaths). Without path bodies it always is: its pairs are the candidates
  // (left in the broad phase, `out` stays empty).
  const bool broad = !paths || othersThanPaths();
  if (broad) broad_phase_->update(t0, t1);
  if (!paths) return all_parts;
  // The broad phase's pairs without the path bodies (it holds them at rest), and theirs.
  if (broad) {
    for (const Pair& p : broad_phase_->pairs()) {
      if (!onPath(p.a) && !onPath(p.b)) out.push_back(p);
    }
  }
  pathPairs(t0, t1, nullptr, out, all_parts);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return all_parts;
}

std::vector<WorldEngine::Candidate> WorldEngine::testedPairs(const std::vector<Pair>& pairs) const {
  // On this thread: the predicate is the caller's.
  std::vector<Candidate> tests;
  const uint64_t every_part = config_.time_slices == 64 ? ~uint64_t{0} : (uint64_t{1} << config_.time_slices) - 1;
  for (const Pair& p : pairs) {
    BodyId ia = p.a, ib = p.b;
    if (records_[ib].key < records_[ia].key) std::swap(ia, ib);  // a = the body added first
    if (!shouldTest(records_[ia], records_[ib])) continue;
    tests.push_back({ia, ib, every_part});
  }
  return tests;
}

std::vector<Contact> WorldEngine::contactsInOrder(const std::vector<Candidate>& tests, const std::vector<TimeOfImpact>& results,
                                                bool undecided) const {
  // The order is found on small records and each Contact is built once, in place
  // (thousands a cycle in a fleet).
  struct Found {
    double time;
    uint64_t a_key, b_key;
    uint32_t test;
    bool operator<(const Found& o) const {
      if (time != o.time) return time < o.time;
      if (a_key != o.a_key) return a_key < o.a_key;
      return b_key < o.b_key;
    }
  };
  std::vector<Found> order;
  for (size_t k = 0; k < tests.size(); ++k) {
    const TimeOfImpact& hit = results[k];
    if (undecided ? hit.hit || !hit.undecided : !hit.hit) continue;
    order.push_back({hit.time, records_[tests[k].a].key, records_[tests[k].b].key, static_cast<uint32_t>(k)});
  }
  std::sort(order.begin(), order.end());
  std::vector<Contact> list(order.size());
  // Thousands of contacts a cycle in a large fleet (two names and two point velocities each):
  // on the threads, each entry by one.
  constexpr size_t kContactsPerThread = 128, kContactChunk = 32;
  detail::parallelFor(threads_, order.size(), kContactsPerThread, kContactChunk, [&](size_t i) {
    const Candidate& c = tests[order[i].test];
    Contact& w = list[i];
    w.a = records_[c.a].name;
    w.b = records_[c.b].name;
    w.a_key = order[i].a_key;
    w.b_key = order[i].b_key;
    w.impact = results[order[i].test];
    w.a_user = records_[c.a].user;
    w.b_user = records_[c.b].user;
    if (!undecided) {
      w.closing_speed = (velocityOfPoint(c.a, w.impact.point, w.impact.time) -
                         velocityOfPoint(c.b, w.impact.point, w.impact.time))
                            .dot(w.impact.normal);
    }
  });
  return list;
}

Eigen::Vector3d WorldEngine::velocityOfPoint(BodyId id, const Eigen::Vector3d& x, double t) const {
  const LinkChain* chain = records_[id].chain.get();
  return chain ? chain->velocityOfPoint(x, t) : broad_phase_->motion(id).velocityOfPoint(x, t);
}

std::optional<Shape> WorldEngine::pathVolume(BodyId p, double t0, double t1) const {
  // A link whose joints move is found within its reach of the base's origin: a ball about the
  // base's origin moving with each piece of the base's path.
  const LinkChain& chain = *records_[p].chain;
  if (chain.joints().empty()) return std::nullopt;
  return makeSphere(broad_phase_->shape(p).bounding_radius + chain.reach(t0, t1));
}

void WorldEngine::pathBox(BodyId p, double t0, double t1, double* box, bool tight) const {
  const std::optional<Shape> ball = pathVolume(p, t0, t1);
  if (!ball || !tight) return sweptAlongPath(p, ball ? *ball : broad_phase_->shape(p), t0, t1, box);
  records_[p].chain->partBoxes(broad_phase_->shape(p), t0, t1, 1, box);
  clipToReach(p, *ball, t0, t1, box);
}

void WorldEngine::sweptAlongPath(BodyId p, const Shape& shape, double t0, double t1, double* box) const {
  const TimedPath& path = records_[p].chain->base();
  for (int k = 0; k < 3; ++k) {
    box[k] = std::numeric_limits<double>::infinity();
    box[3 + k] = -std::numeric_limits<double>::infinity();
  }
  path.forEachPiece(t0, t1, [&](size_t k, double s, double e) {
    double piece[6];
    SweptBody(shape, path.motion(k), s, e).box(piece);
    for (int c = 0; c < 3; ++c) {
      box[c] = std::min(box[c], piece[c]);
      box[3 + c] = std::max(box[3 + c], piece[3 + c]);
    }
  });
}

void WorldEngine::clipToReach(BodyId p, const Shape& ball, double t0, double t1, double* box) const {
  // Both boxes hold the link; the ball's, at least its diameter wide, can cut the link's only
  // where that is wider (a long window): computed then only.
  const double diameter = 2.0 * ball.bounding_radius;
  if (box[3] - box[0] <= diameter && box[4] - box[1] <= diameter && box[5] - box[2] <= diameter) return;
  double reach[6];
  sweptAlongPath(p, ball, t0, t1, reach);
  for (int c = 0; c < 3; ++c) {
    box[c] = std::max(box[c], reach[c]);
    box[3 + c] = std::min(box[3 + c], reach[3 + c]);
  }
}

std::vector<double> WorldEngine::pathBoxes(double t0, double t1) const {
  std::vector<double> boxes(6 * path_bodies_.size());
  for (size_t k = 0; k < path_bodies_.size(); ++k) pathBox(path_bodies_[k], t0, t1, &boxes[6 * k], false);
  return boxes;
}

void WorldEngine::pathPairs(double t0, double t1, const std::vector<BodyId>* only, std::vector<Pair>& out, bool unions) {
  auto in_only = [only](BodyId id) { return !only || std::binary_search(only->begin(), only->end(), id); };
  std::vector<BodyId> found;
  const size_t n = path_bodies_.size();
  // Two path bodies are paired when their boxes over the window overlap (cullBySlices then
  // tests their boxes over its parts, as for every pair). The broad phase is queried for the
  // other bodies only: none when every body is on a path (a fleet of robots on joint states).
  const bool others = broad_phase_->size() > n;
  constexpr size_t stride = 6;
  std::vector<double> boxes(stride * n);
  for (size_t i = 0; i < n; ++i) {
    const BodyId p = path_bodies_[i];
    if (unions) {
      std::copy_n(&frame_boxes_[stride * p], stride, &boxes[stride * i]);
    } else {
      pathBox(p, t0, t1, &boxes[stride * i], true);
    }
    if (!others) continue;
    const TimedPath& path = records_[p].chain->base();
    const bool p_only = in_only(p);
    const std::optional<Shape> ball = pathVolume(p, t0, t1);
    path.forEachPiece(t0, t1, [&](size_t k, double s, double e) {
      // The broad phase holds p's shape padded; p itself (at rest there) is found too: skipped.
      broad_phase_->query(ball ? *ball : broad_phase_->shape(p), path.motion(k), s, e, found);
      for (BodyId other : found) {
        if (!onPath(other) && (p_only || in_only(other))) out.push_back(makePair(p, other));
      }
    });
  }
  // Sweep and prune on x: a fleet of arms or of robots on plans is not O(n^2).
  std::vector<uint32_t> order(n);
  for (uint32_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return boxes[stride * a] < boxes[stride * b]; });
  for (size_t a = 0; a < n; ++a) {
    const double* box_a = &boxes[stride * order[a]];
    for (size_t b = a + 1; b < n && boxes[stride * order[b]] <= box_a[3]; ++b) {
      const double* box_b = &boxes[stride * order[b]];
      if (!boxesOverlap(box_a, box_b)) continue;
      const BodyId pa = path_bodies_[order[a]], pb = path_bodies_[order[b]];
      if (in_only(pa) || in_only(pb)) out.push_back(makePair(pa, pb));
    }
  }
}

void WorldEngine::parallelFor(size_t n, const std::function<void(size_t)>& f) const {
  // Below this many pairs per thread, starting threads costs more than it saves; pairs are
  // taken a few at a time: narrow-phase costs vary by orders of magnitude.
  constexpr size_t kPairsPerThread = 32;
  constexpr size_t kChunk = 8;
  detail::parallelFor(threads_, n, kPairsPerThread, kChunk, f);
}

TimeOfImpact WorldEngine::narrowParts(const Candidate& c, double t0, double t1) const {
  const int parts = config_.time_slices;
  TimeOfImpact r;
  for (int k = 0; k < parts; ++k) {
    if (!(c.parts >> k & 1)) continue;
    int last = k;
    while (last + 1 < parts && (c.parts >> (last + 1) & 1)) ++last;
    // Over the parts before k the gap exceeds the tolerance (their boxes are apart), so a
    // contact at the run's start is no contact at the window's.
    r = narrow(c.a, c.b, k == 0 ? t0 : SweptBody::partEnd(t0, t1, k - 1, parts), SweptBody::partEnd(t0, t1, last, parts));
    if (r.hit || r.undecided) return r;
    k = last;
  }
  r.time = t1;
  return r;
}

void WorldEngine::narrowAll(const std::vector<Candidate>& tests, double t0, double t1, std::vector<TimeOfImpact>& results) {
  results.assign(tests.size(), TimeOfImpact{});
  last_reused_ = 0;
  if (!certificates_) {
    parallelFor(tests.size(), [&](size_t k) { results[k] = narrowParts(tests[k], t0, t1); });
    return;
  }
  // Lookups on this thread; the narrow phase of the rest (certifying where worth trying) on the
  // threads; the certificates stored back here, in order.
  using Certificates = detail::PairCertificates;
  auto body = [&](BodyId id) {
    return Certificates::Body{records_[id].key, &broad_phase_->motion(id), records_[id].prepared->shape().bounding_radius};
  };
  struct Job {
    size_t k;
    bool certify;
    // Filled by the narrow phase when certify: the gap exceeds the clearance over [t0, until)
    // (and at until when closed: no contact over the whole extended window); clear when that
    // covers [t0, t1].
    double until = 0.0;
    bool closed = false;
    bool clear = false;
  };
  std::vector<Job> jobs;
  for (size_t k = 0; k < tests.size(); ++k) {
    const BodyId a = tests[k].a, b = tests[k].b;
    if (records_[a].chain || records_[b].chain) {
      jobs.push_back({k, false});
      continue;
    }
    switch (certificates_->lookup(body(a), body(b), t0, t1)) {
      case Certificates::Verdict::kClear:
        results[k].time = t1;  // no contact: hit == false
        ++last_reused_;
        break;
      case Certificates::Verdict::kNear: jobs.push_back({k, false}); break;
      case Certificates::Verdict::kUnknown: jobs.push_back({k, true}); break;
    }
  }
  const double clearance = certificates_->clearance();
  const double t_end = t1 + config_.coherence.lookahead;
  parallelFor(jobs.size(), [&](size_t i) {
    Job& job = jobs[i];
    const BodyId a = tests[job.k].a, b = tests[job.k].b;
    if (job.certify) {
      // "No contact" for a tolerance of 2 x clearance certifies a gap > clearance (the contract
      // of time_of_impact.h) up to its time, or over the whole window without a hit.
      ToiOptions wide = config_.toi;
      wide.tolerance = 2.0 * clearance;
      const TimeOfImpact c = timeOfImpact(*records_[a].prepared, broad_phase_->motion(a), *records_[b].prepared,
                                    broad_phase_->motion(b), t0, t_end, wide);
      job.closed = !c.hit && !c.undecided;
      job.until = job.closed ? t_end : c.time;
      job.clear = job.closed || job.until > t1;
      if (job.clear) {
        results[job.k].time = t1;  // no contact: hit == false
        return;
      }
    }
    results[job.k] = narrowParts(tests[job.k], t0, t1);
  });
  for (const Job& job : jobs) {
    const BodyId a = tests[job.k].a, b = tests[job.k].b;
    if (records_[a].chain || records_[b].chain) continue;
    const TimeOfImpact& r = results[job.k];
    if (!job.certify) {
      if (r.hit || r.undecided) certificates_->markNear(body(a), body(b));  // still touching: wait again
    } else if (job.clear) {
      certificates_->certify(body(a), body(b), t0, job.until, job.closed);
    } else {
      certificates_->markNear(body(a), body(b));
    }
  }
}

namespace {
// A body's part boxes cost about half a microsecond: a thread pays from a few hundred bodies
// on, and bodies are taken many at a time (in eights, the takes themselves cost a fifth of the
// fill at 10,000 bodies on two cores).
constexpr size_t kBodiesPerThread = 256;
constexpr size_t kBodyChunk = 128;
}  // namespace

void WorldEngine::fillAllPartBoxes(double t0, double t1) {
  ++predict_count_;
  if (slice_of_.size() < records_.size()) slice_of_.resize(records_.size());
  for (BodyId id = 0; id < records_.size(); ++id) {
    if (records_[id].prepared) slice_of_[id].stamp = predict_count_;
  }
  frame_boxes_.resize(6 * records_.size());
  fillSlots(t0, t1, true);
}

void WorldEngine::fillPartBoxesOfPairs(const std::vector<Candidate>& tests, double t0, double t1) {
  ++predict_count_;
  if (slice_of_.size() < records_.size()) slice_of_.resize(records_.size());
  // Slots in first-use order: a query touches a few bodies, whose boxes then share a few hot
  // lines instead of lying far apart in an array indexed by id.
  slice_used_ = 0;
  slice_fill_.clear();
  auto assignSlot = [&](BodyId id) {
    SliceSlot& s = slice_of_[id];
    if (s.stamp == predict_count_) return;
    s.stamp = predict_count_;
    s.index = slice_used_++;
    slice_fill_.push_back(id);
  };
  for (const Candidate& pair : tests) {
    assignSlot(pair.a);
    assignSlot(pair.b);
  }
  // Most bodies take part (a full predict of a crowded world): slots in id order instead, so
  // that the bodies' motions and shapes are read in the order they are stored (in first-use
  // order every body cost a few cache misses: half the cull's time at 10,000 bodies).
  fillSlots(t0, t1, false, 4 * slice_used_ < records_.size());
}

void WorldEngine::fillSlots(double t0, double t1, bool unions, bool slots_assigned) {
  const int slices = config_.time_slices;
  const size_t stride = 6 * static_cast<size_t>(slices);
  if (!slots_assigned) {
    slice_used_ = 0;
    slice_fill_.clear();
    for (BodyId id = 0; id < records_.size(); ++id) {
      SliceSlot& s = slice_of_[id];
      if (s.stamp != predict_count_) continue;
      s.index = slice_used_++;
      slice_fill_.push_back(id);
    }
  }
  if (slice_boxes_.size() < slice_used_ * stride) slice_boxes_.resize(slice_used_ * stride);
  detail::parallelFor(threads_, slice_fill_.size(), kBodiesPerThread, kBodyChunk, [&](size_t i) {
    const BodyId id = slice_fill_[i];
    double* parts = &slice_boxes_[slice_of_[id].index * stride];
    fillPartBoxes(id, t0, t1, parts);
    if (!unions) return;
    double* box = &frame_boxes_[6 * static_cast<size_t>(id)];
    std::copy_n(parts, 6, box);
    for (const double* part = parts + 6; part < parts + stride; part += 6) {
      for (int c = 0; c < 3; ++c) {
        box[c] = std::min(box[c], part[c]);
        box[3 + c] = std::max(box[3 + c], part[3 + c]);
      }
    }
  });
}

void WorldEngine::cullBySlices(std::vector<Candidate>& tests, double t0, double t1, bool filled) {
  const int slices = config_.time_slices;
  if (slices <= 1 || tests.empty() || !(t1 > t0)) return;
  const size_t stride = 6 * static_cast<size_t>(slices);
  if (!filled) fillPartBoxesOfPairs(tests, t0, t1);
  // A pair's test is a few box comparisons: many to a thread, many at a time. With a mesh in
  // the world, a pair with a resting one (a sensor's points) also descends its tree, some 50
  // times the comparisons, and every body is a candidate of a room-wide point set: the pairs go
  // to the threads from far fewer (any mesh counts: a moving one only costs the threads' start).
  const bool meshes = meshes_ > 0;
  const size_t pairs_per_thread = meshes ? 256 : 4096;
  const size_t pair_chunk = meshes ? 64 : 1024;
  detail::parallelFor(threads_, tests.size(), pairs_per_thread, pair_chunk, [&](size_t i) {
    Candidate& pair = tests[i];
    const double* a = &slice_boxes_[slice_of_[pair.a].index * stride];
    const double* b = &slice_boxes_[slice_of_[pair.b].index * stride];
    pair.parts = 0;
    for (int k = 0; k < slices; ++k) pair.parts |= uint64_t{boxesOverlap(a + 6 * k, b + 6 * k)} << k;
    if (pair.parts == 0 || !meshes) return;
    if (const detail::PreparedShapeData* tree = restingTree(pair.a)) cullByTree(pair.a, *tree, b, pair.parts);
    if (pair.parts == 0) return;
    if (const detail::PreparedShapeData* tree = restingTree(pair.b)) cullByTree(pair.b, *tree, a, pair.parts);
  });
  tests.erase(std::remove_if(tests.begin(), tests.end(), [](const Candidate& c) { return c.parts == 0; }), tests.end());
}

const detail::PreparedShapeData* WorldEngine::restingTree(BodyId id) const {
  // Asked of every body each prediction (its part boxes, its pairs' cull): the cheap answers
  // first, the shape's data (a load of its own) only for a body at rest in a world with meshes.
  if (meshes_ == 0) return nullptr;
  const Motion& m = broad_phase_->motion(id);
  if (!m.linear_velocity.isZero(0.0) || !m.angular_velocity.isZero(0.0)) return nullptr;
  const Record& r = records_[id];
  if (r.chain || !r.prepared || r.prepared->data().kind != detail::CoreKind::kMesh) return nullptr;
  return &r.prepared->data();
}

void WorldEngine::cullByTree(BodyId tree_body, const detail::PreparedShapeData& tree, const double* part_boxes,
                             uint64_t& parts) const {
  const Motion& m = broad_phase_->motion(tree_body);
  const Eigen::Matrix3d R = m.orientation.toRotationMatrix();
  // The narrow phase reports a pair whose gap reaches its tolerance: a leaf that close to a
  // box is kept.
  const double slack = config_.toi.tolerance;
  parts = detail::partsMeetingTree(tree, R, m.position, part_boxes, parts, slack);
}

void WorldEngine::fillPartBoxes(BodyId id, double t0, double t1, double* out) const {
  const int slices = config_.time_slices;
  // Each part's box bounds the padded shape over [s, e] (SweptBody is conservative in floating
  // point; a path body's pathBox is the union of SweptBody boxes along its pieces);
  // consecutive parts share their end times, so together they cover [t0, t1].
  if (const detail::PreparedShapeData* tree = restingTree(id)) {
    // A resting mesh (a sensor's points): every part's box is its tree's root box, turned into
    // the fixed frame as the cull turns its nodes, grown by the narrow phase's tolerance as the
    // broad phase's shape of every body is (add): SweptBody would take that shape's support
    // along each axis over every vertex, for every prediction.
    const Motion& m = broad_phase_->motion(id);
    const Eigen::Matrix3d R = m.orientation.toRotationMatrix();
    double box[6];
    detail::turnedNodeBox(tree->node_boxes[tree->root], R, R.cwiseAbs(), m.position, config_.toi.tolerance, box);
    for (int a = 0; a < 3; ++a) {
      // The roundings of the box's centre and half extents and of the turn: ulps of them.
      const double widen = 1e-12 * (1.0 + std::abs(box[a]) + std::abs(box[3 + a]));
      box[a] -= widen;
      box[3 + a] += widen;
    }
    for (int k = 0; k < slices; ++k) std::copy_n(box, 6, out + 6 * k);
    return;
  }
  if (!onPath(id)) {
    SweptBody::partBoxes(broad_phase_->shape(id), broad_phase_->motion(id), t0, t1, slices, out);
    return;
  }
  // A link whose joints move: its boxes over the parts in one pass (LinkChain::partBoxes).
  const std::optional<Shape> ball = pathVolume(id, t0, t1);
  if (ball) records_[id].chain->partBoxes(broad_phase_->shape(id), t0, t1, slices, out);
  double s = t0;
  for (int k = 0; k < slices; ++k) {
    const double e = SweptBody::partEnd(t0, t1, k, slices);
    if (ball) {
      clipToReach(id, *ball, s, e, out + 6 * k);
    } else {
      sweptAlongPath(id, broad_phase_->shape(id), s, e, out + 6 * k);
    }
    s = e;
  }
}

TimeOfImpact WorldEngine::narrow(BodyId a, BodyId b, double t0, double t1) const {
  const Record& ra = records_[a];
  const Record& rb = records_[b];
  if (!ra.chain && !rb.chain) {
    return timeOfImpact(*ra.prepared, broad_phase_->motion(a), *rb.prepared, broad_phase_->motion(b), t0, t1, config_.toi);
  }
  std::optional<LinkChain> twist;  // the side with one Motion, as a chain of one piece
  const LinkChain& ca = ra.chain ? *ra.chain : twist.emplace(TimedPath(broad_phase_->motion(a)));
  const LinkChain& cb = rb.chain ? *rb.chain : twist.emplace(TimedPath(broad_phase_->motion(b)));
  if (ca.joints().empty() && cb.joints().empty()) {
    return timeOfImpact(*ra.prepared, ca.base(), *rb.prepared, cb.base(), t0, t1, config_.toi);
  }
  return timeOfImpact(*ra.prepared, ca, *rb.prepared, cb, t0, t1, config_.toi);
}

WorldEngine::Reachable WorldEngine::reachable(const std::vector<std::string>& movers, const std::vector<Eigen::Vector3d>& origins,
                                  const std::vector<double>& reach, double t0, double horizon) {
  const char* op = "reachable";
  if (movers.size() != origins.size() || movers.size() != reach.size()) {
    throw InvalidArgument(std::string(op) + ": " + std::to_string(movers.size()) + " movers but " +
                          std::to_string(origins.size()) + " origins and " + std::to_string(reach.size()) +
                          " reaches");
  }
  if (!std::isfinite(t0) || !std::isfinite(horizon) || horizon < 0.0) {
    throw InvalidArgument(std::string(op) + ": need finite t0 and horizon >= 0, got " + formatNumber(t0) + ", " +
                          formatNumber(horizon));
  }
  std::vector<BodyId> ids;
  for (const std::string& m : movers) ids.push_back(bodyId(m, op));
  Reachable out;
  std::vector<BodyId> found;
  // The broad phase holds the path bodies at rest: those whose boxes over the window (pathBox)
  // overlap a mover's ball may be reached.
  const std::vector<double> path_boxes = pathBoxes(t0, t0 + horizon);
  for (size_t i = 0; i < ids.size(); ++i) {
    if (!origins[i].allFinite() || !std::isfinite(reach[i]) || reach[i] < 0.0) {
      throw InvalidArgument(std::string(op) + ": origin and reach of " + quoted(movers[i]) +
                            " must be finite (reach >= 0), got reach " + formatNumber(reach[i]));
    }
    const Shape ball = makeSphere(broad_phase_->shape(ids[i]).bounding_radius + reach[i]);
    const Motion still = makeMotion(origins[i], Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
                                    Eigen::Vector3d::Zero(), t0);
    if (othersThanPaths()) {
      broad_phase_->query(ball, still, t0, t0 + horizon, found);
      out.ids.insert(out.ids.end(), found.begin(), found.end());
    }
    double box[6];
    SweptBody(ball, still, t0, t0 + horizon).box(box);
    for (size_t k = 0; k < path_bodies_.size(); ++k) {
      if (boxesOverlap(&path_boxes[6 * k], box)) out.ids.push_back(path_bodies_[k]);
    }
  }
  std::sort(out.ids.begin(), out.ids.end());
  out.ids.erase(std::unique(out.ids.begin(), out.ids.end()), out.ids.end());
  std::vector<BodyId> sorted_movers = ids;
  std::sort(sorted_movers.begin(), sorted_movers.end());
  out.ids.erase(std::remove_if(out.ids.begin(), out.ids.end(),
                               [&](BodyId b) { return std::binary_search(sorted_movers.begin(), sorted_movers.end(), b); }),
                out.ids.end());
  return out;
}

std::optional<WorldEngine::MoverContact> WorldEngine::firstContactIf(const std::vector<std::string>& movers,
                                                         const std::vector<Motion>& motions, double t0,
                                                         double horizon,
                                                         const std::function<bool(uint64_t user)>& skip,
                                                         const Reachable* among) {
  const char* op = "firstContactIf";
  if (movers.size() != motions.size()) {
    throw InvalidArgument(std::string(op) + ": " + std::to_string(movers.size()) + " movers but " +
                          std::to_string(motions.size()) + " motions");
  }
  double t1 = checkedWindow(op, t0, horizon);
  const std::vector<BodyId> ids = moverIds(movers, motions);
  std::vector<BodyId> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw InvalidArgument(std::string(op) + ": a mover is listed twice");
  }
  std::optional<MoverContact> best;
  std::vector<BodyId> found;
  std::vector<double> path_boxes;  // 6 per path body over [t0, t0 + horizon], when needed
  for (size_t i = 0; i < ids.size(); ++i) {
    const Record& rm = records_[ids[i]];
    std::optional<LinkChain> mover_chain;  // made for the first path body met
    if (among) {
      found.clear();
      for (BodyId b : among->ids) {
        if (broad_phase_->contains(b)) found.push_back(b);
      }
    } else {
      moverPartners(ids[i], motions[i], t0, t1, path_boxes, found);
    }
    for (BodyId other : found) {
      if (std::binary_search(sorted.begin(), sorted.end(), other)) continue;
      const Record& ro = records_[other];
      if (!shouldTest(rm, ro)) continue;
      if (skip && skip(ro.user)) continue;
      // Only the first contact matters: later windows shrink to the best time so far.
      const TimeOfImpact hit = moverImpact(rm, motions[i], other, mover_chain, t0, t1);
      if (!hit.hit && !hit.undecided) continue;
      if (!best || hit.time < best->impact.time) {
        best = MoverContact{i, ro.name, ro.key, ro.user, hit, hit.undecided};
        t1 = hit.time;
      }
    }
  }
  return best;
}

std::vector<BodyId> WorldEngine::moverIds(const std::vector<std::string>& movers, const std::vector<Motion>& motions) const {
  const char* op = "firstContactIf";
  std::vector<BodyId> ids;
  ids.reserve(movers.size());
  for (size_t i = 0; i < movers.size(); ++i) {
    ids.push_back(bodyId(movers[i], op));
    if (!isValidMotion(motions[i])) validateMotion(motions[i], std::string(op) + ": motion of " + quoted(movers[i]));
  }
  return ids;
}

void WorldEngine::moverPartners(BodyId mover, const Motion& motion, double t0, double t1, std::vector<double>& path_boxes,
                          std::vector<BodyId>& found) const {
  // The broad phase holds the mover's shape padded by the tolerance, as for its own queries.
  found.clear();
  if (othersThanPaths()) broad_phase_->query(broad_phase_->shape(mover), motion, t0, t1, found);
  if (path_bodies_.empty()) return;
  // The broad phase holds the path bodies at rest: those whose boxes over the window (pathBox,
  // computed once a call, into path_boxes) overlap the mover's swept box are candidates.
  found.erase(std::remove_if(found.begin(), found.end(), [this](BodyId b) { return onPath(b); }), found.end());
  if (path_boxes.empty()) path_boxes = pathBoxes(t0, t1);
  double box[6];
  SweptBody(broad_phase_->shape(mover), motion, t0, t1).box(box);
  for (size_t k = 0; k < path_bodies_.size(); ++k) {
    if (boxesOverlap(&path_boxes[6 * k], box)) found.push_back(path_bodies_[k]);
  }
}

TimeOfImpact WorldEngine::moverImpact(const Record& rm, const Motion& motion, BodyId other, std::optional<LinkChain>& mover_chain,
                          double t0, double t1) const {
  const Record& ro = records_[other];
  const LinkChain* oc = ro.chain.get();
  const LinkChain* mc = oc ? (mover_chain ? &*mover_chain : &mover_chain.emplace(TimedPath(motion))) : nullptr;
  TimeOfImpact hit = !oc ? timeOfImpact(*rm.prepared, motion, *ro.prepared, broad_phase_->motion(other), t0, t1, config_.toi)
               : oc->joints().empty()
                   ? timeOfImpact(*rm.prepared, mc->base(), *ro.prepared, oc->base(), t0, t1, config_.toi)
                   : timeOfImpact(*rm.prepared, *mc, *ro.prepared, *oc, t0, t1, config_.toi);
  // Separating or sliding: not blocked (no contact).
  if (hit.hit && hit.initially_touching) {
    const bool pressed = oc ? pressedTogether(hit, *rm.prepared, motion, *ro.prepared, *oc, t0, t1, config_.toi.tolerance)
                            : pressedTogether(hit, *rm.prepared, motion, *ro.prepared, broad_phase_->motion(other), t0,
                                              t1, config_.toi.tolerance);
    if (!pressed) return TimeOfImpact{};
  }
  return hit;
}

}  // namespace vadop
