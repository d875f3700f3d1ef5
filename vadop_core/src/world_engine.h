// The storage and engines behind World (world.h): the bodies' records, the name index, the
// broad phase, the time-slice boxes and the coherence certificates, and the steps of predict
// and firstContactIf over them. World forwards each call here; this class does what World's
// comments say and nothing more (the contracts live in world.h). Internal to vadop_core: the
// library's tests and tools include it from src/.
#pragma once

#include "vadop/broad_phase.h"
#include "vadop/detail/large_array.h"
#include "vadop/distance.h"
#include "vadop/vadop.h"
#include "vadop/world.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace vadop {
namespace detail {
class PairCertificates;
class NameIndex;
}  // namespace detail

class WorldEngine {
 public:
  using Handle = World::Handle;
  using MoverContact = World::MoverContact;
  using Reachable = World::Reachable;
  using PairPredicate = World::PairPredicate;
  static constexpr uint32_t kDefaultGroup = World::kDefaultGroup;
  static constexpr uint32_t kDefaultMask = World::kDefaultMask;

  explicit WorldEngine(const WorldConfig& config);
  // What a moved-from World answers with: no bodies, no broad phase (add and predict throw).
  struct Empty {};
  explicit WorldEngine(Empty);
  ~WorldEngine();
  WorldEngine(const WorldEngine&) = delete;
  WorldEngine& operator=(const WorldEngine&) = delete;

  void add(const std::string& id, const Shape& shape, const Motion& motion, uint64_t user);
  void add(const std::string& id, const PreparedShape& shape, const Motion& motion, uint64_t user);
  void remove(const std::string& id);
  void setMotion(const std::string& id, const Motion& motion);
  Handle handle(const std::string& id) const;
  void setMotion(const Handle& body, const Motion& motion);
  void setPath(const std::string& id, const TimedPath& path);
  void setChain(const std::string& id, const LinkChain& chain);
  void setChain(const Handle& body, std::shared_ptr<const LinkChain> chain);
  const TimedPath* path(const std::string& id) const;
  const LinkChain* chain(const std::string& id) const;
  void setFilter(const std::string& id, uint32_t group, uint32_t mask);
  void setPairFilter(PairPredicate should_test) { pair_filter_ = std::move(should_test); }
  bool contains(const std::string& id) const;
  size_t size() const;
  std::vector<std::string> ids() const;
  const Shape& shape(const std::string& id) const;
  const PreparedShape& prepared(const std::string& id) const;
  const Motion& motion(const std::string& id) const;
  uint64_t key(const std::string& id) const;
  std::vector<Contact> predict(double t0, double horizon);
  std::vector<Contact> predict(double t0, double horizon, const std::vector<std::string>& only);
  Reachable reachable(const std::vector<std::string>& movers, const std::vector<Eigen::Vector3d>& origins,
                      const std::vector<double>& reach, double t0, double horizon);
  std::optional<MoverContact> firstContactIf(const std::vector<std::string>& movers,
                                             const std::vector<Motion>& motions, double t0, double horizon,
                                             const std::function<bool(uint64_t user)>& skip,
                                             const Reachable* among);
  void setStopDuration(const std::string& id, double seconds);
  void setStopDuration(const Handle& body, double seconds);
  std::optional<MoverContact> firstContactAlong(const std::vector<std::string>& movers,
                                                const std::vector<TimedPath>& paths, double t0, double horizon,
                                                const World::PathQuery& query);

  const WorldConfig& config() const { return config_; }
  const BroadPhase& broadPhase() const { return *broad_phase_; }
  size_t lastCandidateCount() const { return last_candidates_; }
  size_t lastSliceCulledCount() const { return last_slice_culled_; }
  size_t lastReusedCount() const { return last_reused_; }
  const std::vector<Contact>& lastUndecided() const { return last_undecided_; }

 private:
  // What a query reads of each body it meets (name, key, filter, chain) fills the first line
  // of a line-aligned record: one memory load per body once the records outgrow the caches.
  struct alignas(64) Record {
    std::string name;
    uint64_t key = 0;
    uint32_t group = kDefaultGroup;  // setFilter
    uint32_t mask = kDefaultMask;
    // setPath / setChain (a path is a chain without joints); the broad phase holds the first
    // piece of its base's path.
    std::shared_ptr<const LinkChain> chain;
    // add's: read by the pair predicate and a query's skip when set, and copied into the
    // contacts (at the start of the second line, beside the prepared shape's start).
    uint64_t user = 0;
    // The shape as given, prepared for the narrow phase (the broad phase holds it padded).
    std::optional<PreparedShape> prepared;
    double stop_duration = std::numeric_limits<double>::infinity();  // setStopDuration
  };
  // The pairs of the path bodies in [t0, t1] (the caller sorts and dedups): each piece's query
  // against the other bodies, and the pairs of two path bodies whose boxes overlap: their
  // pathBoxes, or with `unions` the unions of their part boxes in frame_boxes_ (fillAllPartBoxes
  // ran: tighter, and computed on the threads); with `only`, those involving one of them.
  void pathPairs(double t0, double t1, const std::vector<BodyId>* only, std::vector<Pair>& out, bool unions = false);
  // What the broad phase tests for path body p over [t0, t1]: its shape (nullopt) or, for a
  // link whose joints move, the ball within its reach of the base's origin.
  std::optional<Shape> pathVolume(BodyId p, double t0, double t1) const;
  // A box (lo x y z, hi x y z) holding that volume along every piece of p's base path over
  // [t0, t1] (sweptAlongPath). `tight`, for a link whose joints move: its own box over the
  // window instead (LinkChain::partBoxes, one part) clipped by the ball's (clipToReach), at the
  // cost of two poses: once a predict, not for every query of a gate (pathBoxes).
  // fillPartBoxes takes the link's own boxes over the time slices.
  void pathBox(BodyId p, double t0, double t1, double* box, bool tight) const;
  // The union of `shape`'s swept boxes (SweptBody) along each piece of p's base path.
  void sweptAlongPath(BodyId p, const Shape& shape, double t0, double t1, double* box) const;
  // Intersects a box holding link p over [t0, t1] with sweptAlongPath of `ball`, the ball of its
  // reach (pathVolume), when the box is wider than the ball on some axis.
  void clipToReach(BodyId p, const Shape& ball, double t0, double t1, double* box) const;
  // pathBox of every path body (6 doubles each, in path_bodies_'s order), not tight.
  std::vector<double> pathBoxes(double t0, double t1) const;
  // A candidate pair for the narrow phase and the parts of the window it searches: bit k of
  // `parts` set when the two boxes over part k of config_.time_slices overlap (every part
  // without the cull). Over a part left out the padded shapes are apart (their boxes are), so
  // the narrow phase's contract (time_of_impact.h) still holds over the whole window.
  struct Candidate {
    BodyId a, b;
    uint64_t parts;  // kMaxTimeSlices <= 64
  };
  // Drops from `tests` the pairs whose boxes over the config_.time_slices parts of [t0, t1]
  // (partBoxes) overlap in none of them (WorldConfig::time_slices), and keeps in `parts` those
  // in which they do. A pair with a resting mesh or point set (a sensor's points) keeps a part
  // only where the other's box meets a leaf of the set's tree: the set's own box spans all its
  // points (a room) and would pair it with every body in it.
  // `filled`: fillAllPartBoxes ran for this window (the boxes are there already).
  void cullBySlices(std::vector<Candidate>& tests, double t0, double t1, bool filled);
  // The prepared tree of a body that is a mesh or point set at rest (no path, no velocity), else null.
  const detail::PreparedShapeData* restingTree(BodyId id) const;
  // Clears the bits of `parts` whose box of the other body (part_boxes: one per part) meets no
  // leaf of the resting tree of `tree_body`.
  void cullByTree(BodyId tree_body, const detail::PreparedShapeData& tree, const double* part_boxes,
                  uint64_t& parts) const;
  // The part boxes of every body (slots in id order) and, in frame_boxes_, the union of each
  // body's parts: the broad phase's boxes in a crowded world's full predict (the path bodies'
  // boxes in pathPairs when there are some), so that no body's swept volume is bounded twice
  // (the union is its swept box over [t0, t1], or tighter).
  void fillAllPartBoxes(double t0, double t1);
  // The part boxes of the bodies of `tests` only.
  void fillPartBoxesOfPairs(const std::vector<Candidate>& tests, double t0, double t1);
  // Both of the above: the part boxes of the bodies stamped with predict_count_ (slots in id
  // order unless `slots_assigned`), and with `unions` each body's union in frame_boxes_.
  void fillSlots(double t0, double t1, bool unions, bool slots_assigned = false);
  // The boxes of body `id` over the config_.time_slices parts of [t0, t1] (6 doubles each) into
  // `out`: its padded shape's swept boxes, or pathBox of each part for a body on a path. Bodies
  // are independent: cullBySlices fills them on the threads when there are many.
  void fillPartBoxes(BodyId id, double t0, double t1, double* out) const;
  TimeOfImpact narrow(BodyId a, BodyId b, double t0, double t1) const;
  // narrow() over each run of consecutive parts of c.parts in turn, up to the first contact
  // (or undecided pair); no contact in any: clear over [t0, t1] (time t1).
  TimeOfImpact narrowParts(const Candidate& c, double t0, double t1) const;
  // narrowParts() on every pair of `tests` into `results` (same order), on threads_ threads when
  // there are enough pairs; rethrows the exception of the first pair (by index) that threw.
  void narrowAll(const std::vector<Candidate>& tests, double t0, double t1, std::vector<TimeOfImpact>& results);
  // f(k) for k in [0, n), on threads_ threads when n is large enough; rethrows the exception
  // of the smallest k that threw.
  void parallelFor(size_t n, const std::function<void(size_t)>& f) const;
  // The velocity of body id's material point at x at time t (along its chain or its motion).
  Eigen::Vector3d velocityOfPoint(BodyId id, const Eigen::Vector3d& x, double t) const;
  bool onPath(BodyId id) const { return records_[id].chain != nullptr; }
  // Some body is not on a path: only then can the broad phase find a pair or a partner that
  // the path bodies' own boxes do not (it holds a path body on its base's first piece only).
  bool othersThanPaths() const { return broad_phase_->size() > path_bodies_.size(); }
  const Record& record(const std::string& id, const char* operation) const;
  BodyId bodyId(const std::string& id, const char* operation) const;
  static constexpr BodyId kUnknownBody = ~BodyId{0};
  BodyId findBody(const std::string& id) const;  // or kUnknownBody
  void setMotionOf(BodyId bid, const Motion& motion);
  void setStopDurationOf(BodyId bid, double seconds);
  void setChainOf(BodyId bid, std::shared_ptr<const LinkChain> chain);
  // The body a handle names; throws, naming `operation`, for a stale handle or another World's.
  BodyId handleId(const Handle& body, const char* operation) const;
  struct NameOf;  // the name of a BodyId (in its record), for by_name_
  // Throws InvalidArgument when this World was moved from (no broad phase).
  void requireEngine(const char* operation) const;
  // Throws InvalidArgument (naming add) when `id` is empty or taken, or this World was moved from.
  void requireNewId(const std::string& id) const;
  std::vector<Contact> run(double t0, double horizon, const std::vector<BodyId>* only);
  // t0 + horizon; throws, naming `operation`, for a window that is not finite or out of range.
  double checkedWindow(const char* operation, double t0, double horizon) const;
  // Throws when the body's origin may leave the range of error.h over [t0, t1] (along each
  // piece of its path for a path body): checkMotionReach for one motion over [s, e].
  void checkReach(BodyId id, double t0, double t1) const;
  void checkMotionReach(BodyId id, const Motion& m, double s, double e) const;
  // The candidate pairs of a query: the broad phase's pairs involving one of `only` (sorted),
  // and pathPairs' (sorted, unique); checks the reach of every body they involve.
  void queryPairs(const std::vector<BodyId>& only, double t0, double t1, std::vector<Pair>& out);
  // A full predict's broad phase: updated (and given the part boxes' unions when they are all
  // filled: returns true then). With path bodies its pairs without them and pathPairs' go to
  // `out` (sorted, unique); without, `out` stays empty (the candidates are broad_phase_->pairs()).
  bool allPairs(double t0, double t1, std::vector<Pair>& out);
  // The pair rule, in one place (see the top of world.h): the masks of setFilter, then the
  // predicate of setPairFilter with the caller's keys, that of the body added first first.
  bool shouldTest(const Record& a, const Record& b) const {
    if (!(a.group & b.mask) || !(b.group & a.mask)) return false;
    if (!pair_filter_) return true;
    return a.key < b.key ? pair_filter_(a.user, b.user) : pair_filter_(b.user, a.user);
  }
  // The pairs that pass shouldTest, a = the body added first, every time slice searched.
  std::vector<Candidate> testedPairs(const std::vector<Pair>& pairs) const;
  // The contacts (or with `undecided`, the undecided pairs) of `results`, sorted by (time,
  // a_key, b_key), with their closing speeds (contacts only).
  std::vector<Contact> contactsInOrder(const std::vector<Candidate>& tests, const std::vector<TimeOfImpact>& results,
                                           bool undecided) const;
  // firstContactIf's movers by id, their motions validated (throws naming the mover).
  std::vector<BodyId> moverIds(const std::vector<std::string>& movers, const std::vector<Motion>& motions) const;
  // The bodies the broad phase finds near a mover moving with `motion`, and the path bodies
  // whose boxes (path_boxes: filled on the first call) overlap its swept box.
  void moverPartners(BodyId mover, const Motion& motion, double t0, double t1, std::vector<double>& path_boxes,
                     std::vector<BodyId>& found) const;
  // The narrow phase of mover rm moving with `motion` against `other` as set (a chain's
  // narrow phase when other is on a path: mover_chain is the mover's, made once); a pair
  // touching at t0 that the motions do not press together is no contact (TimeOfImpact{}).
  TimeOfImpact moverImpact(const Record& rm, const Motion& motion, BodyId other, std::optional<LinkChain>& mover_chain,
                     double t0, double t1) const;

  // firstContactAlong's pair: mover rm along `path` against `other`, in its own motion's future
  // and, with query.others_stop, in its braking one; the earlier contact.
  struct Ball {
    Eigen::Vector3d centre;
    double radius;
  };
  // `reach`: a ball the mover stays in over [t0, t1] (bounding radius plus its path's travel).
  std::optional<MoverContact> pathImpact(const Record& rm, BodyId rm_id, size_t mover, const TimedPath& path,
                                         const Ball& reach, BodyId other, const World::PathQuery& query, double t0,
                                         double t1) const;
  // Body `other` braking to standstill from t0 along its motion (its stop duration), and how far
  // the keyframed path lies from the exact braking: made once per body while t0 and the world
  // stay (a gate's scales ask the same others again).
  struct BrakingPath {
    TimedPath path;
    double deviation;
  };
  const BrakingPath& brakingOf(BodyId other, double t0) const;
  mutable std::unordered_map<BodyId, BrakingPath> braking_paths_;
  mutable double braking_t0_ = std::numeric_limits<double>::quiet_NaN();
  mutable uint64_t braking_epoch_ = 0;
  uint64_t epoch_ = 0;  // counts the changes of bodies' motions, paths and stop durations
  // firstContactAlong's partners when the query gives none: reachable() from each path's origin
  // at t0 and how far it travels over the window.
  Reachable pathPartners(const std::vector<std::string>& movers, const std::vector<TimedPath>& paths, double t0,
                         double t1, double deviation);

  WorldConfig config_;
  int threads_ = 1;  // config_.threads resolved
  std::unique_ptr<BroadPhase> broad_phase_;
  detail::LargeArray<Record> records_;  // by BodyId of the broad phase; read at random by queries
  std::unique_ptr<detail::NameIndex> by_name_;  // names live in records_
  std::vector<BodyId> path_bodies_;  // sorted
  uint64_t next_key_ = 0;
  size_t meshes_ = 0;  // bodies whose shape is a mesh or point set: without any, no tree cull
  uint64_t serial_ = 0;  // this World's, unique in the process: the Handle's `world`
  size_t last_candidates_ = 0;
  size_t last_reused_ = 0;
  size_t last_slice_culled_ = 0;
  // cullBySlices' boxes: time_slices boxes (lo x y z, hi x y z) per body, packed in the order
  // the predict whose number is in the body's stamp first asked for them (computed for the
  // bodies of candidate pairs only; slice_fill_ lists those bodies in slot order).
  struct SliceSlot {
    uint64_t stamp = 0;
    size_t index = 0;  // into slice_boxes_, in units of time_slices boxes
  };
  std::vector<SliceSlot> slice_of_;  // by BodyId
  std::vector<double> slice_boxes_;
  size_t slice_used_ = 0;
  std::vector<BodyId> slice_fill_;
  uint64_t predict_count_ = 0;
  std::vector<double> frame_boxes_;  // by BodyId, 6 each (removed bodies' entries unused)
  // The last full predict had as many candidate pairs (after the group filters) as bodies:
  // most bodies need their part boxes, so the next computes them for all, before the broad
  // phase (a part box costs about three swept boxes: not worth it for a sparse world). Kept
  // while there are half as many: the unions of the parts, tighter than the broad phase's own
  // boxes, find fewer pairs (0.4-0.9 of them in the planar fleets), which must not send every
  // other predict back to the looser boxes.
  bool parts_for_all_ = false;
  std::unique_ptr<detail::PairCertificates> certificates_;  // WorldConfig::coherence
  std::vector<Contact> last_undecided_;
  PairPredicate pair_filter_;
};

}  // namespace vadop
