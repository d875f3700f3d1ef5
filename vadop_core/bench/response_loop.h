// The response loop of continuous detection: bodies advance over [t0, t1] with their impacts
// processed in time order. The broad phase finds the interval's candidate pairs, the narrow
// phase their first contacts, and the earliest pending impact goes to a user callback, which
// may give any body a new motion; exactly the bodies whose motion changed lose their pending
// impacts and are re-predicted for the rest of the interval from the broad phase's own
// single-body queries (BroadPhase::query), until no impact is left before t1.
//
// It does not respond by itself (no velocity solver, no masses): the callback decides (elastic
// bounce, stop, nothing). A contact is reported once: after the impact of (a, b) at time t, a
// re-prediction of (a, b) whose first contact is at or before t (they still touch) reports
// nothing, so touching bodies that separate, or that the callback leaves touching, cannot loop;
// the pair is predicted again when one of the two next changes motion. Contacts with a fixed
// boundary that is not a body (the walls of a box, a floor) come from a user function
// (setBoundary) and go through the same queue and callback.
// Not thread-safe. Bad input throws vadop::InvalidArgument and changes nothing.
//
// It is the event loop of the paper's benchmark (vadop_bench's ContinuousWorld), not a front
// door of vadop_core: it has none of World's features (paths, chains, filters, time slices,
// threads), and it lives beside the library, in the bench's library vadop_response_loop, which
// needs vadop_core only.
#pragma once

#include "impact_queue.h"
#include "vadop/broad_phase.h"
#include "vadop/detail/flat_map.h"
#include "vadop/distance.h"
#include "vadop/motion.h"
#include "vadop/shapes.h"
#include "vadop/time_of_impact.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace vadop {

class ResponseLoop {
 public:
  // The broad phase must be empty; the loop owns it. Throws for a null broad phase, a
  // non-empty one, or bad narrow-phase options.
  explicit ResponseLoop(std::unique_ptr<BroadPhase> broad_phase, const ToiOptions& toi = {});

  // The shape is padded by the narrow phase's tolerance for the broad phase (as World does).
  BodyId add(const Shape& shape, const Motion& motion);
  // The same for a shape shared by many bodies (n equal spheres, a fleet of one robot model):
  // while consecutive adds pass the same pointer, its padded copy and prepared form are made
  // once and shared.
  BodyId add(std::shared_ptr<const Shape> shape, const Motion& motion);
  void remove(BodyId id);
  void setMotion(BodyId id, const Motion& motion);
  const Motion& motion(BodyId id) const { return bp_->motion(id); }
  bool contains(BodyId id) const { return bp_->contains(id); }
  size_t size() const { return bp_->size(); }
  const BroadPhase& broadPhase() const { return *bp_; }
  // Bytes held by the loop's own structures (queue, per-body records; not the broad phase).
  size_t memoryBytes() const;

  // b of a contact with the boundary.
  static constexpr BodyId kBoundary = ~BodyId{0};
  struct Contact {
    BodyId a = 0, b = 0;  // a < b (b == kBoundary: the boundary); impact.normal points from a to b
    TimeOfImpact impact;
  };
  // A body's first contact with the boundary over [from, t1] along `motion` (hit false for
  // none; the normal points from the body into the boundary). Asked for every body at each
  // advance and again whenever the body's motion changes; a hit outside [from, t1] or with a
  // non-finite point or normal throws InvalidArgument from advance. Empty: no boundary. The
  // boundary is one partner per body for the report-once rule: return a corner (two walls at
  // one instant) as one contact, with the normal the response needs.
  using Boundary = std::function<TimeOfImpact(BodyId id, const Motion& motion, double from, double t1)>;
  void setBoundary(Boundary boundary) { boundary_ = std::move(boundary); }
  // What the callback may do: read and change motions (a change takes effect at once and
  // re-predicts that body from the impact's time). Valid only during the call.
  class Response {
   public:
    const Motion& motion(BodyId id) const { return loop_.motion(id); }
    void setMotion(BodyId id, const Motion& motion);  // throws as ResponseLoop::setMotion
    double time() const { return time_; }

   private:
    friend class ResponseLoop;
    Response(ResponseLoop& loop, double time) : loop_(loop), time_(time) {}
    ResponseLoop& loop_;
    double time_;
    std::vector<BodyId> changed_;
  };
  using Callback = std::function<void(const Contact&, Response&)>;

  struct Stats {
    size_t candidates = 0;   // broad-phase pairs of the interval
    size_t narrow = 0;       // narrow-phase calls (candidates and re-predictions)
    size_t contacts = 0;     // callbacks made
    size_t requeried = 0;    // bodies re-predicted after a change
    size_t undecided = 0;    // pairs the narrow phase could not decide within its budget
    size_t boundary_contacts = 0;  // of `contacts`, those with the boundary
    // Wall time of the broad phase's update, of the narrow phase (the interval's candidates
    // and the re-predictions) and of the re-predictions' queries; the rest of advance is the
    // callbacks and the queue.
    double update_seconds = 0, narrow_seconds = 0, query_seconds = 0;
  };
  // Advances over [t0, t1] (finite, t0 <= t1): every contact in it, in time order (ties by
  // the pair's ids), goes to `on_contact`. Returns the interval's statistics. When the
  // callback throws, the loop stops there: every body keeps the motion last set (the changes
  // made by that call included), nothing is pending, and the exception propagates; a later
  // advance starts afresh.
  Stats advance(double t0, double t1, const Callback& on_contact);

 private:
  void predict(BodyId a, BodyId b, double from, double t1);
  void predictBoundary(BodyId id, double from, double t1);
  bool reportedAt(BodyId a, BodyId b, double t) const;

  std::unique_ptr<BroadPhase> bp_;
  ToiOptions toi_;
  Boundary boundary_;
  // By BodyId, one cache line each: what the pair cull before the narrow phase reads (the
  // origin at t_ref and its velocity for a body that does not turn; reach < 0 for one that
  // does, else the padded bounding radius rounded up to a float) and the body's prepared shape
  // (an index into shapes_), so that a pair costs two cache lines before its motions.
  struct alignas(64) Kinematics {
    Eigen::Vector3d position, velocity;
    double t_ref = 0.0;
    float reach = -1.0f;
    uint32_t shape = 0;
  };
  std::vector<Kinematics> kinematics_;
  void setKinematics(BodyId id);
  // The distinct prepared shapes, shared by the bodies that use them (uses == 0: free, listed
  // in free_shapes_ for the next new shape).
  struct SharedShape {
    std::optional<PreparedShape> prepared;
    size_t uses = 0;
  };
  std::vector<SharedShape> shapes_;
  std::vector<uint32_t> free_shapes_;
  // False only when the two bodies, both translating, stay farther apart over [from, t1] than
  // their bounding radii and twice the tolerance: timeOfImpact would report no hit.
  static bool mayTouch(const Kinematics& a, const Kinematics& b, double from, double t1);
  // The last shared shape added, its padded copy and its entry in shapes_.
  std::shared_ptr<const Shape> last_shape_, last_padded_;
  uint32_t last_index_ = 0;
  ImpactQueue queue_;
  // The last time each pair was reported (key a << 32 | b), cleared by every advance.
  struct KeyHash {
    size_t operator()(uint64_t k) const;
  };
  detail::FlatMap<uint64_t, double, KeyHash> reported_;
  Stats stats_;
};

}  // namespace vadop
