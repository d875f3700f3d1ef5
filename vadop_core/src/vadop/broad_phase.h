// The broad phase interface of continuous detection: bodies with a shape and a rigid motion,
// and, per frame [t0, t1], the candidate pairs whose swept volumes may intersect. Every
// implementation is complete (it never drops a pair whose swept volumes intersect); they
// differ in how tight and how fast they are. It does not compute contacts: see the narrow
// phase. Bad input throws vadop::InvalidArgument and leaves the broad phase unchanged.
#pragma once

#include "vadop/detail/large_array.h"
#include "vadop/motion.h"
#include "vadop/pair_set.h"
#include "vadop/shapes.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace vadop {
namespace detail {
class CellGrid;  // src/cell_grid.h
}  // namespace detail

class BroadPhase {
 public:
  BroadPhase();
  virtual ~BroadPhase();

  // Adds a body and returns its id: the smallest id not in use, so every implementation fed
  // the same calls hands out the same ids.
  BodyId add(std::shared_ptr<const Shape> shape, const Motion& motion);
  BodyId add(const Shape& shape, const Motion& motion);
  void remove(BodyId id);
  // A new motion takes effect at the next update(); invalidates the body's pairs then.
  void setMotion(BodyId id, const Motion& motion);

  // Computes the candidate pairs of the frame [t0, t1] (t0 <= t1, both finite).
  void update(double t0, double t1);

  // Boxes of the bodies over the next update()'s frame [t0, t1], computed by the caller, for
  // engines that would compute the same (the grid engine takes them instead of its own swept
  // boxes; the others ignore them): 6 doubles per BodyId from 0 (lo x y z, hi x y z), each
  // holding that body's shape (margin included) at every time of [t0, t1]: SweptBody's box, or
  // a tighter one that still does, such as the union of its boxes over parts of the window.
  // nullptr: none. Read by the next update() only, which forgets them; the array must outlive
  // that call.
  void setFrameBoxes(const double* boxes_by_id) { frame_boxes_ = boxes_by_id; }

  // Candidate pairs of the last update, sorted, a < b in each.
  const std::vector<Pair>& pairs() const { return pairs_; }

  // Threads an update may use (1, the default: the caller's only; engines that do not split
  // their update ignore it). The pairs are the same whatever the count. Throws
  // vadop::InvalidArgument below 1.
  void setThreads(int threads);
  int threads() const { return threads_; }

  // Single-body queries (the gate's "what does this body reach if it moves so?"): the bodies
  // whose swept volumes over [t0, t1] (finite, t0 <= t1) may intersect that of body `id`, with
  // every motion as currently set (a setMotion since the last update counts at once). Complete
  // like update(): every body whose swept volume intersects is listed; an engine may list more
  // (its own bound, stated with it). Never `id` itself; `out` is replaced, sorted, no repeats.
  // Throws vadop::InvalidArgument for an unknown id or a bad interval (out untouched).
  // Windows inside the last update's frame are answered from the engine's structure of that
  // update (queryFrame) for the bodies unchanged since, and from a hash grid of the swept boxes
  // of those added or given a new motion since (kept over the frame's remainder, so a response
  // loop's queries, whose t0 only grows, do not rebuild it); other windows, and engines without
  // such a structure, scan every body with swept bounding-sphere capsules (O(n)).
  void query(BodyId id, double t0, double t1, std::vector<BodyId>& out);
  // The same for a shape moving with `motion` that is not in the broad phase (a candidate
  // command, a planned path). Throws for an invalid shape or motion.
  void query(const Shape& shape, const Motion& motion, double t0, double t1, std::vector<BodyId>& out);

  bool contains(BodyId id) const { return id < bodies_.size() && bodies_[id].alive; }
  size_t size() const { return alive_count_; }
  // Throw for an unknown id; inline, as the narrow phase reads them for every pair.
  const Shape& shape(BodyId id) const {
    if (!contains(id)) throwUnknown(id, "shape");
    return *bodies_[id].shape;
  }
  const Motion& motion(BodyId id) const {
    if (!contains(id)) throwUnknown(id, "motion");
    return bodies_[id].motion;
  }
  // A hint that the body's shape and motion will be read soon (a query's first step): starts
  // loading its record from memory, so that the loads of several bodies overlap. No effect on
  // results; ids out of range are ignored.
  void prefetch(BodyId id) const {
    if (id >= bodies_.size()) return;
    const char* p = reinterpret_cast<const char*>(&bodies_[id]);
    for (size_t k = 0; k < sizeof(Body); k += 64) __builtin_prefetch(p + k);
  }
  virtual std::string name() const = 0;
  // Bytes held by the implementation's own structures (not counting shapes).
  virtual size_t memoryBytes() const = 0;

 protected:
  struct Body {
    std::shared_ptr<const Shape> shape;
    Motion motion;
    bool alive = false;
  };
  // Hooks called after the base class has validated the call and updated bodies_.
  virtual void onAdd(BodyId id) = 0;
  virtual void onRemove(BodyId id) = 0;  // bodies_[id] still holds the shape and motion
  // Called after validation, before bodies_[id].motion is replaced: state derived from the old
  // motion can still be computed, and a throw leaves the motion as it was.
  virtual void onSetMotion(BodyId id) = 0;
  virtual void computePairs(double t0, double t1, std::vector<Pair>& out) = 0;
  // A query's answer from the structure of the last update, for an engine that keeps one:
  // append every body whose volume of that update may intersect the swept box `box` (lo x y z,
  // hi x y z; of a window inside that update's frame), in any order. Repeats, removed bodies
  // and bodies changed since are allowed: the base class drops them and answers for the
  // changed ones itself. Return false without such a structure (the base class then scans).
  virtual bool queryFrame(const double* box, std::vector<BodyId>& out) {
    (void)box;
    (void)out;
    return false;
  }

  const detail::LargeArray<Body>& bodies() const { return bodies_; }
  // setFrameBoxes' boxes during update() (nullptr: none).
  const double* frameBoxes() const { return frame_boxes_; }
  void requireKnown(BodyId id, const char* operation) const {
    if (!contains(id)) throwUnknown(id, operation);
  }
  [[noreturn]] static void throwUnknown(BodyId id, const char* operation);

 private:
  static constexpr BodyId kNoBody = ~BodyId{0};
  // The query after validation: candidates of `shape` moving with `motion` over [t0, t1],
  // excluding `self` (kNoBody for a shape not in the broad phase), in any order.
  void queryCandidates(const Shape& shape, const Motion& motion, BodyId self, double t0, double t1,
                       std::vector<BodyId>& out);
  void queryChanged(const double* box, BodyId self, double t0, double t1, std::vector<BodyId>& out);
  void markChanged(BodyId id);

  detail::LargeArray<Body> bodies_;  // read at random by queries
  std::vector<BodyId> free_ids_;  // min-heap
  size_t alive_count_ = 0;
  int threads_ = 1;
  const double* frame_boxes_ = nullptr;
  std::vector<Pair> pairs_;
  // The last update's frame, and the bodies added, removed or given a new motion since (in
  // order, with repeats: a body changed twice is listed twice).
  bool framed_ = false;
  double frame_t0_ = 0.0, frame_t1_ = 0.0;
  std::vector<uint8_t> changed_flag_;  // by BodyId
  std::vector<BodyId> changed_;
  // Past a few changed bodies, their swept boxes over the rest of the frame from the query
  // that indexed them (the latest such t0: changed_t0_) in a hash grid, filled up to
  // changed_indexed_ entries of changed_.
  std::unique_ptr<detail::CellGrid> changed_grid_;
  size_t changed_indexed_ = 0;
  double changed_t0_ = 0.0;
  bool changed_grid_valid_ = false;
  std::vector<BodyId> frame_found_;
};

// Reference broad phase: every pair, tested by the exact distance between the capsules that
// the bodies' bounding spheres sweep (for a non-rotating sphere that is its exact swept
// volume). O(n^2) time, O(1) extra memory: for ground truth and small n only.
class BruteForceBroadPhase : public BroadPhase {
 public:
  std::string name() const override { return "brute"; }
  size_t memoryBytes() const override { return 0; }

 protected:
  void onAdd(BodyId) override {}
  void onRemove(BodyId) override {}
  void onSetMotion(BodyId) override {}
  void computePairs(double t0, double t1, std::vector<Pair>& out) override;
};

// Squared distance between segments [p0, p1] and [q0, q1].
double segmentSegmentDistanceSquared(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                     const Eigen::Vector3d& q0, const Eigen::Vector3d& q1);

}  // namespace vadop
