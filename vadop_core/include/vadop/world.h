// The prediction pipeline: named bodies, a broad phase kept up to date incrementally, and the
// narrow phase on every candidate pair.
//
// predict(t0, horizon) runs the broad phase over [t0, t0 + horizon], then timeOfImpact on each
// candidate pair, and returns every pair that touches within the window, sorted by time, then
// by the insertion order of the bodies (a = the body added first, the normal points from a to
// b). A pair already touching at t0 has time t0. The result does not depend on the broad phase
// chosen: each is complete, and each sees the shapes padded by the narrow phase's tolerance,
// so every pair the narrow phase can report (gap <= tolerance) is a candidate for all of them.
//
// Pair filters (as Box2D's shouldCollide and Bullet's broadphase filter callback) leave
// candidate pairs out BEFORE the narrow phase: a pair is tested only when
//   (a.group & b.mask) != 0 && (b.group & a.mask) != 0      (setFilter; default group 1, mask ~0)
// and, when a predicate is set (setPairFilter), should_test(a_key, b_key) is true. Filtered
// pairs cost no narrow-phase call, are not in lastCandidateCount() and never in lastUndecided().
// The filters see each candidate pair once, whatever the broad phase, so the result still does
// not depend on the broad phase (given a predicate that depends only on its arguments).
//
// Bodies on timed paths (setPath: a planned path, keyframes of a trajectory) take part like the
// others: the broad phase's single-body queries find their partners along each piece of the
// path within the window (the broad phase itself holds them at rest; a world of path bodies
// only does not use it), and the narrow phase follows both bodies piece by piece
// (timed_path.h). Their cost grows with their pieces in the window; pairs of two path bodies
// are tested directly (meant for tens of them, not thousands).
// Links of joint chains (setChain: an arm's links moving with their joints on a moving base)
// are path bodies whose narrow phase is joint_chain.h's.
//
// Names are any non-empty strings. Bad input throws vadop::InvalidArgument naming the body and
// leaves the world unchanged (strong guarantee). Not thread-safe.
#pragma once

#include "vadop/broad_phase.h"
#include "vadop/detail/large_array.h"
#include "vadop/distance.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"
#include "vadop/joint_chain.h"
#include "vadop/timed_path.h"
#include "vadop/vadop.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vadop {
namespace detail {
class PairCertificates;
class NameIndex;
}

enum class BroadPhaseKind {
  kVadop,     // VADOP volumes on a grid of swept AABBs (VadopGridBroadPhase), WorldConfig::vadop
  kVadopSap,  // VADOP with sweep and prune on each pool axis (SweepPruneBroadPhase), as in the paper
  kSap,    // sweep and prune of swept AABBs on x, y, z
  kBrute,  // every pair, by swept bounding spheres: ground truth for small scenes
  kGrid,   // the uniform grid of swept AABBs (VadopGridBroadPhase::makeBoxOnly): the plain baseline
};

const char* toString(BroadPhaseKind kind);
// "vadop", "vadop_sap", "sap", "grid" or "brute"; throws vadop::InvalidArgument otherwise.
BroadPhaseKind parseBroadPhaseKind(const std::string& name);

struct WorldConfig {
  BroadPhaseKind broad_phase = BroadPhaseKind::kVadop;
  VadopConfig vadop;  // axes, phi_deg, ...: used (and validated) by kVadop and kVadopSap
  ToiOptions toi;
  // Threads of predict (the broad phase's bodies and cells, the part boxes and the narrow
  // phase's candidate pairs shared out among them; the result is the same for every count):
  // 1 runs it on the caller's thread; 0 means one per hardware
  // thread (std::thread::hardware_concurrency). In [0, kMaxThreads].
  int threads = 1;
  // Temporal coherence of the narrow phase (0: off). With clearance > 0, a pair that predict
  // finds more than `clearance` apart over its window extended by `lookahead` keeps that
  // certificate: later predicts whose window lies within the certified interval answer the pair
  // "no contact" without the narrow phase while both bodies' motions stay close enough to the
  // certificate's -- maxDisplacement (motion.h) of the two summed below clearance -
  // toi.tolerance, so the gap still exceeds the tolerance. Results are those of the narrow
  // phase itself (contacts are always computed afresh; a pair the narrow phase would leave
  // undecided within its budget may instead be certified clear); only bodies moving with one
  // Motion are certified. Costs a wider first test per pair (clearance as its tolerance, over the longer
  // window) and memory per candidate pair; pays when motions change little between predicts
  // (re-stated odometry). clearance: 0 or in (toi.tolerance, 1e5] m; lookahead in [0, 1e7] s.
  struct Coherence {
    double clearance = 0.0;  // m
    double lookahead = 0.0;  // s
  } coherence;
  // Time slices of predict's cull before the narrow phase: a candidate pair of the broad phase
  // goes to the narrow phase only if the two bodies' swept boxes (SweptBody) over one of
  // `time_slices` equal parts of the window overlap, and the narrow phase then searches only
  // the parts where they do. Bodies whose paths cross at different times (most candidates over
  // a 2 s horizon) are dropped; the pairs found are the same for every value (each box bounds
  // its padded body over its part, the parts cover the window) and each result keeps the
  // contract of time_of_impact.h (a contact's time may differ within its band). 1: no cull.
  // A body on a path (or a link of a moving chain) takes the box along its path over each part.
  // Memory: 6 doubles per body and slice. In [1, kMaxTimeSlices].
  int time_slices = 8;
};
constexpr int kMaxTimeSlices = 64;
constexpr int kMaxThreads = 256;

struct WorldImpact {
  std::string a, b;     // a was added before b
  uint64_t a_key = 0;   // insertion-order keys (World::key): a_key < b_key; for ImpactQueue
  uint64_t b_key = 0;
  Impact impact;        // time, contact point, normal from a to b (see time_of_impact.h)
};

class World {
 public:
  // Throws vadop::InvalidArgument for a bad configuration (tolerance; for kVadop axes, phi,
  // ...). Building the VADOP axis pool takes tens of milliseconds: reuse a World rather than
  // building one per query.
  explicit World(const WorldConfig& config = {});
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;
  // A moved-from World holds no bodies: asked by name it answers as an empty one (size 0, an
  // id is unknown), and add or predict throw InvalidArgument; assign a World to it to use it again.
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;

  // Throws when the id is empty or already used, or the shape or motion is invalid.
  void add(const std::string& id, const Shape& shape, const Motion& motion);
  // Throws when the id is unknown.
  void remove(const std::string& id);
  // A new velocity (or pose): takes effect at the next predict (and ends a path). Throws when
  // the id is unknown or the motion invalid.
  void setMotion(const std::string& id, const Motion& motion);
  // A body's handle, for what a caller does to every body every cycle: setMotion by handle
  // skips the name's lookup. Valid until the body is removed (added again under the same id, it
  // has a new handle); setMotion and setChain throw for a stale handle or one of another World.
  struct Handle {
    uint32_t index = ~uint32_t{0};
    uint64_t key = 0;
    uint64_t world = 0;
  };
  // Throws when the id is unknown.
  Handle handle(const std::string& id) const;
  void setMotion(const Handle& body, const Motion& motion);
  // The body follows `path` from the next predict on (every window, whatever its t0), until
  // setMotion. Throws when the id is unknown (nothing changed).
  void setPath(const std::string& id, const TimedPath& path);
  // The body is a link of `chain` (its joints moving over time on the chain's base) from the
  // next predict on, until setMotion. Its partners among the bodies with one motion are found
  // by queries of a ball about the base's origin of the link's bounding radius plus the chain's
  // reach, along each piece of the base's path; among the other path bodies, by the link's own
  // boxes over the window and its time slices (LinkChain::partBoxes): a fleet of thousands of
  // links costs what their neighbours cost. Throws when the id is unknown (nothing changed).
  void setChain(const std::string& id, const LinkChain& chain);
  // The same without copying the chain (it is immutable: the World shares it) and, with a
  // handle, without the name's lookup: for a caller that sets every link every cycle. Throws
  // for a null chain or a handle that names no body of this World (nothing changed).
  void setChain(const Handle& body, std::shared_ptr<const LinkChain> chain);
  // The body's path (for a link of a chain, its base's path), or nullptr when it moves with one
  // Motion.
  const TimedPath* path(const std::string& id) const;
  // The body's chain (a body on a path: a chain without joints), or nullptr.
  const LinkChain* chain(const std::string& id) const;

  // Collision filtering (see the top of this file). A body's group (its category bits) and
  // mask (the groups it is tested against): the pair (a, b) reaches the narrow phase only when
  // (a.group & b.mask) && (b.group & a.mask). add() gives group 1 and mask 0xffffffff (every
  // pair tested); a body removed and added again gets these defaults back. Takes effect at the
  // next predict. Throws when the id is unknown (nothing changed).
  static constexpr uint32_t kDefaultGroup = 1u;
  static constexpr uint32_t kDefaultMask = 0xffffffffu;
  void setFilter(const std::string& id, uint32_t group, uint32_t mask);
  // For rules masks cannot express (per-pair rules, globs): called on each candidate pair that
  // passes the masks, with the insertion-order keys (World::key) a_key < b_key; the pair goes to
  // the narrow phase only when it returns true. Keys rather than names: no string work per
  // pair. Must be a pure function of its arguments for the result to be independent of the
  // broad phase; what it throws propagates out of predict (statistics unchanged). An empty
  // function (the default) tests every pair.
  using PairPredicate = std::function<bool(uint64_t a_key, uint64_t b_key)>;
  void setPairFilter(PairPredicate should_test) { pair_filter_ = std::move(should_test); }

  bool contains(const std::string& id) const;
  size_t size() const;
  // Ids in insertion order.
  std::vector<std::string> ids() const;
  const Shape& shape(const std::string& id) const;
  // The body's motion; for a body on a path, the first piece of its path (at rest at the first
  // keyframe): see path(); for a link of a chain, the first piece of its base's path.
  const Motion& motion(const std::string& id) const;
  // The body's insertion-order key: later adds get larger keys (a body removed and added again
  // gets a new one). These are the keys WorldImpact and ImpactQueue use.
  uint64_t key(const std::string& id) const;

  // Every pair that touches within [t0, t0 + horizon], sorted by (time, a_key, b_key).
  // Throws when t0 or horizon is not finite, horizon < 0, or a body's motion leaves the finite
  // range within the window.
  std::vector<WorldImpact> predict(double t0, double horizon);
  // The same, restricted to the pairs involving at least one of `only` (for example the bodies
  // whose velocity just changed, or a robot's links under a candidate command). Answered by the
  // broad phase's single-body queries (BroadPhase::query), without a full broad-phase pass: the
  // grid engines then cost about the neighbours of `only`, not n (see vadop_grid.h). Throws on
  // unknown ids (nothing changed).
  std::vector<WorldImpact> predict(double t0, double horizon, const std::vector<std::string>& only);

  // "What if": the earliest contact over [t0, t0 + horizon] if the bodies `movers` (a robot's
  // links) moved with `motions` (one each, the same order) instead of their own, against every
  // other body moving as set: the question of a velocity gate about a candidate command. Pairs
  // among the movers are not tested; the pair filters apply as in predict, and `skip` (when
  // set) drops the other bodies whose key it accepts (a gate's ignore list). Answered by the
  // broad phase's queries; the world is not changed. nullopt: no contact (an undecided pair
  // counts as a contact at the time it is certified clear to). A pair already touching at t0
  // (gap within the tolerance) is a contact only when the motions press it together there
  // (closing speed > 0 at the contact point along its normal): moving apart from, or sliding
  // along, what a body touches is not blocked; the pair is then not tested further in this
  // window (a later call, from a later t0, tests it again). Throws on unknown or
  // repeated movers, a size mismatch, an invalid motion or window (nothing changed).
  struct MoverContact {
    size_t mover = 0;      // index into movers
    std::string other;     // the body touched
    uint64_t other_key = 0;
    Impact impact;         // normal from the mover to the other
    // The narrow phase could not decide this pair past impact.time (Impact::undecided): for a
    // gate, a contact there (it cannot certify the command beyond).
    bool undecided = false;
  };
  // The bodies a family of candidate motions may reach (a gate's scales of one command), found
  // with one query per mover instead of one per motion: every body whose swept volume over
  // [t0, t0 + horizon] may meet the ball about `origins[i]` (the mover's origin at t0) of the
  // mover's bounding radius plus `reach[i]` (a bound on how far its origin travels over the
  // window under any of the motions). Movers are left out. Valid until the world changes
  // (opaque: pass it back to firstContactIf). Throws as firstContactIf, and for a reach or
  // origin that is not finite or a reach < 0.
  struct Reachable {
    std::vector<BodyId> ids;  // sorted
  };
  Reachable reachable(const std::vector<std::string>& movers, const std::vector<Eigen::Vector3d>& origins,
                      const std::vector<double>& reach, double t0, double horizon);
  // `among` (optional): test only those bodies (from reachable() with a bound that holds for
  // `motions`), instead of querying the broad phase for each mover.
  std::optional<MoverContact> firstContactIf(const std::vector<std::string>& movers,
                                             const std::vector<Motion>& motions, double t0, double horizon,
                                             const std::function<bool(uint64_t key)>& skip = {},
                                             const Reachable* among = nullptr);

  const WorldConfig& config() const { return config_; }
  const BroadPhase& broadPhase() const { return *broad_phase_; }
  // Narrow-phase calls made by the last predict: its candidate pairs after any `only` filter
  // and after the pair filters (setFilter, setPairFilter); filtered pairs are not counted.
  size_t lastCandidateCount() const { return last_candidates_; }
  // Pairs of the last predict that the broad phase found and the time-slice cull
  // (WorldConfig::time_slices) dropped before the narrow phase (not counted above).
  size_t lastSliceCulledCount() const { return last_slice_culled_; }
  // Of those, the pairs answered by a certificate of WorldConfig::coherence (no narrow phase).
  size_t lastReusedCount() const { return last_reused_; }
  // The pairs of the last predict that the narrow phase could not decide within its budget
  // (Impact::undecided: clear up to impact.time, unknown after), in the order of predict's
  // result. Not contacts: predict does not return them. The same for every broad phase.
  const std::vector<WorldImpact>& lastUndecided() const { return last_undecided_; }

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
    // The shape as given, prepared for the narrow phase (the broad phase holds it padded).
    std::optional<PreparedShape> prepared;
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
  // in which they do.
  // `filled`: fillAllPartBoxes ran for this window (the boxes are there already).
  void cullBySlices(std::vector<Candidate>& tests, double t0, double t1, bool filled);
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
  Impact narrow(BodyId a, BodyId b, double t0, double t1) const;
  // narrow() over each run of consecutive parts of c.parts in turn, up to the first contact
  // (or undecided pair); no contact in any: clear over [t0, t1] (time t1).
  Impact narrowParts(const Candidate& c, double t0, double t1) const;
  // narrowParts() on every pair of `tests` into `results` (same order), on threads_ threads when
  // there are enough pairs; rethrows the exception of the first pair (by index) that threw.
  void narrowAll(const std::vector<Candidate>& tests, double t0, double t1, std::vector<Impact>& results);
  // f(k) for k in [0, n), on threads_ threads when n is large enough; rethrows the exception
  // of the smallest k that threw.
  void parallelFor(size_t n, const std::function<void(size_t)>& f) const;
  bool onPath(BodyId id) const { return records_[id].chain != nullptr; }
  // Some body is not on a path: only then can the broad phase find a pair or a partner that
  // the path bodies' own boxes do not (it holds a path body on its base's first piece only).
  bool othersThanPaths() const { return broad_phase_->size() > path_bodies_.size(); }
  const Record& record(const std::string& id, const char* operation) const;
  BodyId bodyId(const std::string& id, const char* operation) const;
  static constexpr BodyId kUnknownBody = ~BodyId{0};
  BodyId findBody(const std::string& id) const;  // or kUnknownBody
  void setMotionOf(BodyId bid, const Motion& motion);
  void setChainOf(BodyId bid, std::shared_ptr<const LinkChain> chain);
  // The body a handle names; throws, naming `operation`, for a stale handle or another World's.
  BodyId handleId(const Handle& body, const char* operation) const;
  struct NameOf;  // the name of a BodyId (in its record), for by_name_
  // Throws InvalidArgument when this World was moved from (no broad phase).
  void requireEngine(const char* operation) const;
  std::vector<WorldImpact> run(double t0, double horizon, const std::vector<BodyId>* only);
  // t0 + horizon; throws, naming `operation`, for a window that is not finite or out of range.
  double checkedWindow(const char* operation, double t0, double horizon) const;
  // Throws when the body's origin may leave the range of limits.h over [t0, t1] (along each
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
  // The pair rule, in one place (see the top of this file): the masks of setFilter, then the
  // predicate of setPairFilter with the keys in insertion order.
  bool shouldTest(const Record& a, const Record& b) const {
    if (!(a.group & b.mask) || !(b.group & a.mask)) return false;
    return !pair_filter_ || pair_filter_(std::min(a.key, b.key), std::max(a.key, b.key));
  }
  // The pairs that pass shouldTest, a = the body added first, every time slice searched.
  std::vector<Candidate> testedPairs(const std::vector<Pair>& pairs) const;
  // The contacts (or with `undecided`, the undecided pairs) of `results`, sorted by (time,
  // a_key, b_key).
  std::vector<WorldImpact> contactsInOrder(const std::vector<Candidate>& tests, const std::vector<Impact>& results,
                                           bool undecided) const;
  // firstContactIf's movers by id, their motions validated (throws naming the mover).
  std::vector<BodyId> moverIds(const std::vector<std::string>& movers, const std::vector<Motion>& motions) const;
  // The bodies the broad phase finds near a mover moving with `motion`, and the path bodies
  // whose boxes (path_boxes: filled on the first call) overlap its swept box.
  void moverPartners(BodyId mover, const Motion& motion, double t0, double t1, std::vector<double>& path_boxes,
                     std::vector<BodyId>& found) const;
  // The narrow phase of mover rm moving with `motion` against `other` as set (a chain's
  // narrow phase when other is on a path: mover_chain is the mover's, made once); a pair
  // touching at t0 that the motions do not press together is no contact (Impact{}).
  Impact moverImpact(const Record& rm, const Motion& motion, BodyId other, std::optional<LinkChain>& mover_chain,
                     double t0, double t1) const;

  WorldConfig config_;
  int threads_ = 1;  // config_.threads resolved
  std::unique_ptr<BroadPhase> broad_phase_;
  detail::LargeArray<Record> records_;  // by BodyId of the broad phase; read at random by queries
  std::unique_ptr<detail::NameIndex> by_name_;  // names live in records_
  std::vector<BodyId> path_bodies_;  // sorted
  uint64_t next_key_ = 0;
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
  std::vector<WorldImpact> last_undecided_;
  PairPredicate pair_filter_;
};

}  // namespace vadop
