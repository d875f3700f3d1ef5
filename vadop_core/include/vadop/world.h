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
// and, when a predicate is set (setPairFilter), should_test(a_user, b_user) is true (the
// caller's keys given to add, a = the body added first): the caller decides on its own keys,
// with no table from the World's keys or ids back to its objects. Filtered
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
//
// This header is the front door only: the broad phases, the narrow phase's prepared shapes and
// the World's storage (WorldEngine) are internal to vadop_core (src/), behind a pointer.
//
// Also here, the gate's scale search (searchGateScale), the question a velocity gate asks of
// World::firstContactIf over the scales of a command.
#pragma once

#include "vadop/joint_chain.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"
#include "vadop/timed_path.h"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vadop {

class WorldEngine;  // the storage and engines behind World (internal: vadop_core/src)

// Rule for bodies that barely move, whose velocity direction is noise: aligning to it
// would churn their axis sets every frame for no gain (their projections do not move).
enum class SlowAxisRule {
  kFixedZone,  // the zone orthogonal to VadopConfig::slow_direction: as cheap as a moving body
  kAllAxes,    // every pool axis: the tightest volume, m slots per body
};

struct VadopConfig {
  // Pool size m and zone half-width phi (0 selects the pool's covering radius rho, the
  // paper's choice). phi = rho makes two bodies share only the few axes near v1 x v2, so
  // pruning is nearly one-dimensional; a wider zone prunes far better for a little more
  // sorting. 32 axes and 25 degrees balance the two on the paper's scene (README, figures).
  int axes = 32;
  double phi_deg = 25.0;
  // A body is slow when |v| (t1 - t0) < slow_fraction * bounding radius.
  double slow_fraction = 0.05;
  SlowAxisRule slow_rule = SlowAxisRule::kFixedZone;
  Eigen::Vector3d slow_direction = Eigen::Vector3d::UnitZ();
  // A body's axes are chosen with phi + hysteresis / 2 and kept while they still hold the
  // whole phi zone and lie within phi + hysteresis: a turning body changes lists only every
  // hysteresis / 2 of turn (each change re-queries its pairs), at the price of a few more axes.
  // Measured: 20 degrees takes the 1,000-body monitor cycle (turning robots) from 13.6 to
  // 10.9 ms; bodies whose direction jumps (bounces) pay for the wider fresh zone instead.
  double hysteresis_deg = 20.0;
};


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

// A contact between two bodies of a World (predict, lastUndecided): the one type of the
// library's answers about pairs. It names the two bodies three ways: their ids, their
// insertion-order keys (World::key: the order of the result) and the caller's own keys given
// to add() (`user`: e.g. an index into the caller's tables, so that a caller needs no table
// from ids or keys back to its own objects).
struct Contact {
  std::string a, b;     // a was added before b
  uint64_t a_key = 0;   // insertion-order keys (World::key): a_key < b_key
  uint64_t b_key = 0;
  TimeOfImpact impact;  // time, contact point, normal from a to b (see time_of_impact.h)
  uint64_t a_user = 0;  // the caller's keys of a and b (add's `user`)
  uint64_t b_user = 0;
  // (v_a - v_b) . normal: the velocities of the material points of a and b at impact.point, at
  // impact.time, each along its own motion, path or chain (> 0: pressing together). Not set
  // (0) for the undecided pairs of lastUndecided.
  double closing_speed = 0.0;
};

// A shape prepared for the narrow phase (validated; a mesh's or point set's bounding-volume
// tree built: 1 to 2 ms for 10,000 points on one core), immutable and shareable by any number
// of Worlds and threads. A tree of 4,096 triangles or points or more is built on up to
// `threads` threads (0: one per hardware thread; the same tree on any count). Throws
// InvalidArgument as validateShape.
std::shared_ptr<const PreparedShape> prepareShape(const Shape& shape, int threads = 1);

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

  // Throws when the id is empty or already used, or the shape or motion is invalid. `user`: the
  // caller's key of the body, returned in every Contact and MoverContact that involves it (the
  // World does not read it; several bodies may share one).
  void add(const std::string& id, const Shape& shape, const Motion& motion, uint64_t user = 0);
  // The same with the shape prepared beforehand (prepareShape(), or another World's prepared()):
  // the narrow phase's data (a mesh's or point set's tree) is shared, not built again. A large
  // shape entering two Worlds (a sensor's points in a monitor's cycle and in its gates') is
  // prepared once, and where the caller chooses (a sensor's message callback, not the cycle).
  void add(const std::string& id, const std::shared_ptr<const PreparedShape>& shape, const Motion& motion,
           uint64_t user = 0);
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
  // passes the masks (in predict and in the gate queries firstContactIf, firstContactAlong),
  // with the two bodies' caller's keys (add's `user`), a_user of the body added first (the
  // smaller World::key); the pair goes to the narrow phase only when it returns true. Keys
  // rather than names: no string work per pair. Must be a pure function of its arguments for
  // the result to be independent of the broad phase; what it throws propagates out of predict
  // (statistics unchanged). An empty function (the default) tests every pair.
  using PairPredicate = std::function<bool(uint64_t a_user, uint64_t b_user)>;
  void setPairFilter(PairPredicate should_test);

  bool contains(const std::string& id) const;
  size_t size() const;
  // Ids in insertion order.
  std::vector<std::string> ids() const;
  const Shape& shape(const std::string& id) const;
  // The body's shape as prepared for the narrow phase (immutable; add() into another World
  // shares it). Throws when the id is unknown.
  std::shared_ptr<const PreparedShape> prepared(const std::string& id) const;
  // The body's motion; for a body on a path, the first piece of its path (at rest at the first
  // keyframe): see path(); for a link of a chain, the first piece of its base's path.
  const Motion& motion(const std::string& id) const;
  // The body's insertion-order key: later adds get larger keys (a body removed and added again
  // gets a new one). These are the keys of Contact (a_key, b_key) and its order.
  uint64_t key(const std::string& id) const;

  // Every pair that touches within [t0, t0 + horizon], sorted by (time, a_key, b_key).
  // Throws when t0 or horizon is not finite, horizon < 0, or a body's motion leaves the finite
  // range within the window.
  std::vector<Contact> predict(double t0, double horizon);
  // The same, restricted to the pairs involving at least one of `only` (for example the bodies
  // whose velocity just changed, or a robot's links under a candidate command). Answered by the
  // broad phase's single-body queries (BroadPhase::query), without a full broad-phase pass: the
  // grid engines then cost about the neighbours of `only`, not n (see vadop_grid.h). Throws on
  // unknown ids (nothing changed).
  std::vector<Contact> predict(double t0, double horizon, const std::vector<std::string>& only);

  // "What if": the earliest contact over [t0, t0 + horizon] if the bodies `movers` (a robot's
  // links) moved with `motions` (one each, the same order) instead of their own, against every
  // other body moving as set: the question of a velocity gate about a candidate command. Pairs
  // among the movers are not tested; the pair filters apply as in predict, and `skip` (when
  // set) drops the other bodies whose caller's key (add's `user`) it accepts (a gate's ignore
  // list). Answered by the broad phase's queries; the world is not changed. nullopt: no
  // contact (an undecided pair counts as a contact at the time it is certified clear to). A pair
  // already touching at t0 (gap within the tolerance) is a contact only when the motions press
  // it together there (closing speed > 0 at the contact point along its normal) or dig in over
  // the window (the gap, sampled at four times, deeper than at t0: a box turning in place
  // against a wall): moving apart from, or sliding along, what a body touches is not blocked;
  // the pair is then not tested further in this window (a later call, from a later t0, tests it
  // again). Throws on unknown or repeated movers, a size mismatch, an invalid motion or window
  // (nothing changed).
  struct MoverContact {
    size_t mover = 0;      // index into movers
    std::string other;     // the body touched
    uint64_t other_key = 0;
    uint64_t other_user = 0;  // its caller's key (add's `user`)
    TimeOfImpact impact;         // normal from the mover to the other
    // The narrow phase could not decide this pair past impact.time (TimeOfImpact::undecided): for a
    // gate, a contact there (it cannot certify the command beyond).
    bool undecided = false;
    // Found in the future in which the other body brakes (firstContactAlong's others_stop), not
    // in its own motion's.
    bool others_stopping = false;
  };
  // The bodies a family of candidate motions may reach (a gate's scales of one command), found
  // with one query per mover instead of one per motion: every body whose swept volume over
  // [t0, t0 + horizon] may meet the ball about `origins[i]` (the mover's origin at t0) of the
  // mover's bounding radius plus `reach[i]` (a bound on how far its origin travels over the
  // window under any of the motions). Movers are left out. Valid until the world changes
  // (opaque: pass it back to firstContactIf). Throws as firstContactIf, and for a reach or
  // origin that is not finite or a reach < 0.
  struct Reachable {
    std::vector<uint32_t> ids;  // the bodies' internal ids, sorted
  };
  Reachable reachable(const std::vector<std::string>& movers, const std::vector<Eigen::Vector3d>& origins,
                      const std::vector<double>& reach, double t0, double horizon);
  // `among` (optional): test only those bodies (from reachable() with a bound that holds for
  // `motions`), instead of querying the broad phase for each mover.
  std::optional<MoverContact> firstContactIf(const std::vector<std::string>& movers,
                                             const std::vector<Motion>& motions, double t0, double horizon,
                                             const std::function<bool(uint64_t user)>& skip = {},
                                             const Reachable* among = nullptr);

  // How long the body takes to brake to standstill from its motion (s, >= 0; 0: it stops at
  // once), for the future of firstContactAlong's others_stop. +infinity (what add gives): it is
  // not known to stop; that future moves it as set. Throws when the id or handle is unknown or
  // the duration is NaN or < 0 (nothing changed).
  void setStopDuration(const std::string& id, double seconds);
  void setStopDuration(const Handle& body, double seconds);

  // firstContactIf for movers on paths (a velocity gate's manoeuvre: the last command held, the
  // candidate, then braking: appendKeyframes, appendBrakingKeyframes): the earliest contact over
  // [t0, t0 + horizon] if the bodies `movers` followed `paths` (one each) instead of their own
  // motions. The same rules as firstContactIf, with a pair that touches at the start of any
  // stretch of the window where both keep one piece (not only at t0) a contact only when the
  // pieces press it together there: a body standing against a wall during its reaction time and
  // then commanded away from it is not blocked, one commanded into it is.
  struct PathQuery {
    std::function<bool(uint64_t user)> skip;  // as firstContactIf's: by the others' `user`
    const Reachable* among = nullptr;        // as firstContactIf's; null: found from the paths
    // How far (m) the movers' paths may lie from the motions they stand for (the bound that
    // appendBrakingKeyframes returns): the pairs are tested with a tolerance of twice that plus
    // the others' own bound (and at least WorldConfig::toi's), so that a clear verdict holds for
    // the exact motions; a contact may then be reported up to that gap early.
    double deviation = 0.0;
    // Also the future in which every other body with a stop duration (setStopDuration) brakes to
    // standstill along its motion from t0 (appendBrakingKeyframes, within 0.5 mm); a contact in
    // either future counts (MoverContact::others_stopping says which). Bodies on paths or
    // chains follow them in both futures.
    bool others_stop = false;
  };
  std::optional<MoverContact> firstContactAlong(const std::vector<std::string>& movers,
                                                const std::vector<TimedPath>& paths, double t0, double horizon,
                                                const PathQuery& query);
  std::optional<MoverContact> firstContactAlong(const std::vector<std::string>& movers,
                                                const std::vector<TimedPath>& paths, double t0, double horizon);

  const WorldConfig& config() const;
  // Narrow-phase calls made by the last predict: its candidate pairs after any `only` filter
  // and after the pair filters (setFilter, setPairFilter); filtered pairs are not counted.
  size_t lastCandidateCount() const;
  // Pairs of the last predict that the broad phase found and the time-slice cull
  // (WorldConfig::time_slices) dropped before the narrow phase (not counted above).
  size_t lastSliceCulledCount() const;
  // Of those, the pairs answered by a certificate of WorldConfig::coherence (no narrow phase).
  size_t lastReusedCount() const;
  // The pairs of the last predict that the narrow phase could not decide within its budget
  // (TimeOfImpact::undecided: clear up to impact.time, unknown after), in the order of predict's
  // result. Not contacts: predict does not return them. The same for every broad phase.
  const std::vector<Contact>& lastUndecided() const;

 private:
  // The engine, or null once moved from (engine() then stands in an empty one).
  WorldEngine& engine();
  const WorldEngine& engine() const;
  std::unique_ptr<WorldEngine> engine_;
};

// The scale search of a velocity gate: given the first contact time of a body driven by a
// command scaled by s (a function the caller builds, e.g. from World::firstContactIf), the
// largest s in [0, 1] on a grid of step `step` (1, 1 - step, ..., 0) for which nothing is
// touched; when every grid point leads to a contact, the one whose first contact comes latest
// (driving away from a danger is then never blocked). It does not build motions or know the
// world; it only decides which scales to try, largest first, and stops at the first clear one.
struct GateScale {
  double scale = 0.0;
  bool clear = false;           // no contact at `scale` within the window
  double contact_time = 0.0;    // first contact at `scale` (infinity when clear)
  size_t evaluations = 0;       // calls of first_contact
};

// first_contact(s): the first contact time at scale s, +infinity for none. step in (0, 1].
// Guarantees: when clear, `scale` is the largest grid point that is clear and every grid point
// above it leads to a contact (so it is within `step` of the largest clear s unless the clear
// scales above it form an interval shorter than `step`); otherwise `scale` is a grid point of
// the latest first contact, the smallest such point on ties (every scale meeting the same
// contact, e.g. pressed against something whatever the speed: stopping harms least). Throws vadop::InvalidArgument for
// a bad step or a NaN time; what first_contact throws propagates.
GateScale searchGateScale(const std::function<double(double s)>& first_contact, double step = 0.02);

// The threads World runs on (WorldConfig::threads), offered for the caller's own loops beside
// it (the monitor's bodies and impacts): one process-wide pool, kept between calls, so that a
// second pool's workers never compete with the World's for the cores.
// threadCount: a configured count resolved (0: one per hardware thread; at least 1).
// parallelFor: f(k) for every k in [0, n) on up to `threads` threads (this one included),
// `chunk` consecutive k at a time; on this thread alone when n < 2 * min_per_thread. Every k
// runs even when some throw; then the exception of the smallest k that threw is rethrown.
int threadCount(int configured);
void parallelFor(int threads, size_t n, size_t min_per_thread, size_t chunk, const std::function<void(size_t)>& f);

}  // namespace vadop
