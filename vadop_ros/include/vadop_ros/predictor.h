// The vadop::World of the monitor, kept incrementally: an element enters the world when it
// first has a motion, is setMotion'ed only when its motion changed, and leaves while it has
// none (skipped, e.g. a missing transform); the world is never rebuilt. predict() runs the
// VADOP broad phase and the continuous narrow phase.
//
// The wrapper keeps the node in element indices: each element enters the world with its index
// as the caller's key (vadop::World::add's `user`), which every vadop::Contact and
// vadop::World::MoverContact carries back (a_user, b_user, other_user) and which the pair
// predicate (setIgnored) and the queries' skip are asked with: no table from the world's keys.
#pragma once

#include <vadop/motion.h>
#include <vadop/shapes.h>
#include <vadop/world.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vadop_ros {

struct PredictorConfig {
  int axes = 32;         // VADOP pool size
  double phi_deg = 25.0; // VADOP zone half-width
  int max_iterations = 10000;  // the narrow phase's budget per pair (vadop::ToiOptions)
  int threads = 1;             // of predict (vadop::WorldConfig::threads; 0: all cores)
  std::string broad_phase = "vadop";  // vadop::parseBroadPhaseKind's names
  int time_slices = 8;                // vadop::WorldConfig::time_slices (1: no cull)
  // vadop::WorldConfig::coherence (0: off).
  double coherence_clearance = 0.0;  // m
  double coherence_lookahead = 0.0;  // s
  // A world that is never predicted, only asked (the gates' copy): a broad phase whose
  // single-body queries scan every body, with nothing to maintain per setMotion.
  bool queries_only = false;
};

// Bit-identical motions (the world is only told about a change).
bool sameMotion(const vadop::Motion& a, const vadop::Motion& b);

class Predictor {
 public:
  // Throws vadop::InvalidArgument when the configuration is rejected.
  explicit Predictor(const PredictorConfig& config);
  ~Predictor();
  Predictor(const Predictor&) = delete;
  Predictor& operator=(const Predictor&) = delete;

  // Element i: present (with this shape and motion) or absent this cycle. `shape` is used when
  // the element enters the world, with the collision group and mask (vadop::World::setFilter:
  // the pair (a, b) reaches the narrow phase only when (a.group & b.mask) && (b.group & a.mask)).
  // With `chain` (vadop::World::setChain: a planned path, or a link moved by its joints) the
  // element follows it; `motion` is its motion at the cycle time (markers, the gates' movers)
  // and takes over when a later set has no chain.
  // Returns false (and sets error) when the world rejected it.
  bool set(size_t i, const std::string& id, const vadop::Shape& shape, const vadop::Motion& motion,
           std::string& error, uint32_t group = 1u, uint32_t mask = 0xffffffffu,
           const std::shared_ptr<const vadop::LinkChain>& chain = nullptr);
  // The same with the shape as another Predictor's world prepared it (prepared()): shared, not
  // built again (a sensor's point set enters the cycle's world and the gates').
  bool set(size_t i, const std::string& id, const std::shared_ptr<const vadop::PreparedShape>& shape,
           const vadop::Motion& motion, std::string& error, uint32_t group = 1u, uint32_t mask = 0xffffffffu,
           const std::shared_ptr<const vadop::LinkChain>& chain = nullptr);
  void unset(size_t i);
  // Every element leaves the world (padding changed: they come back with new shapes).
  void clear();
  bool contains(size_t i) const;
  const vadop::Motion& motion(size_t i) const;  // as given to the world
  const std::shared_ptr<const vadop::LinkChain>& chain(size_t i) const;  // null: none
  // Pose of element i at time t (along its chain, else its motion), and the times inside
  // (t0, t1) worth drawing it at (its path's keyframes; ten even steps when joints move; empty
  // without a chain): for the markers.
  Eigen::Isometry3d poseAt(size_t i, double t) const;
  std::vector<double> pathTimes(size_t i, double t0, double t1) const;
  const vadop::Shape& shape(size_t i) const;    // as given to the world (padded)
  std::shared_ptr<const vadop::PreparedShape> prepared(size_t i) const;  // the same, prepared

  // Pairs of elements (a added to the world first) never given to the narrow phase: called on
  // each candidate pair that passes the groups and masks, before the narrow phase, in predict
  // and in the gate queries (vadop::World::setPairFilter, which asks with the elements'
  // indices). Must depend only on its arguments. Empty: none.
  void setIgnored(std::function<bool(size_t a, size_t b)> ignored);
  // Whether that predicate is asked at all (default true). Off where it could only answer "test"
  // (no pair filter, no two elements of one body in the world): it costs two calls per
  // candidate pair.
  void enableIgnored(bool on);

  // Contacts over [t0, t0 + horizon], sorted by time (vadop::World::predict): a_user and b_user
  // are the two elements' indices (a added to the world first), impact.time in the motions'
  // time base. Throws vadop::InvalidArgument.
  std::vector<vadop::Contact> predict(double t0, double horizon);
  // The pairs of the last predict that the narrow phase could not decide within its budget
  // (vadop::World::lastUndecided): impact.time is the end of the interval certified clear.
  // Not contacts: predict does not return them.
  const std::vector<vadop::Contact>& lastUndecided() const;

  // The first contact of elements `movers` (all in the world) if they moved with `motions`
  // instead of their own, against every other element as it moves, over [t0, t0 + horizon]:
  // the world is not changed. The pair filters apply (setIgnored, groups), and `skip` (an
  // element index; empty: none) leaves out more. A pair the narrow phase cannot decide counts
  // as a contact at the time it is certified clear to (undecided). The contact's `mover` is a
  // position in `movers`, its other_user the element touched. Throws vadop::InvalidArgument
  // for a mover not in the world, a size mismatch or a bad motion.
  std::optional<vadop::World::MoverContact> firstContact(const std::vector<size_t>& movers,
                                                         const std::vector<vadop::Motion>& motions, double t0,
                                                         double horizon,
                                                         const std::function<bool(uint64_t element)>& skip);
  // The same for movers on paths (vadop::World::firstContactAlong): `deviation` (m) how far the
  // paths may lie from the motions they stand for; with `others_stop`, also the future in which
  // every other element brakes to standstill (setStopDuration; the contact's others_stopping
  // says which). Uses beginReach's candidates.
  std::optional<vadop::World::MoverContact> firstContactAlong(const std::vector<size_t>& movers,
                                                              const std::vector<vadop::TimedPath>& paths, double t0,
                                                              double horizon,
                                                              const std::function<bool(uint64_t element)>& skip,
                                                              double deviation, bool others_stop);
  // How long element i takes to brake to standstill from its motion (vadop::World::
  // setStopDuration; +inf: never). Ignored for an element not in the world.
  void setStopDuration(size_t i, double seconds);
  // For a family of firstContact calls on the same movers (a gate's scales): the candidates
  // found once, from a ball about each mover's origin at t0 of its bounding radius plus
  // `reach` (how far its origin may travel under any of the motions; vadop::World::reachable);
  // firstContact then tests only those until endReach() or a change of the world. Throws as
  // firstContact.
  void beginReach(const std::vector<size_t>& movers, const std::vector<Eigen::Vector3d>& origins,
                  const std::vector<double>& reach, double t0, double horizon);
  void endReach();
  // beginReach for the scope's life: endReach when it ends, by a return or an exception.
  class ReachScope {
   public:
    ReachScope(Predictor& p, const std::vector<size_t>& movers, const std::vector<Eigen::Vector3d>& origins,
               const std::vector<double>& reach, double t0, double horizon)
        : p_(p) {
      p_.beginReach(movers, origins, reach, t0, horizon);
    }
    ~ReachScope() { p_.endReach(); }
    ReachScope(const ReachScope&) = delete;
    ReachScope& operator=(const ReachScope&) = delete;

   private:
    Predictor& p_;
  };

  // Tests only: called before every predict with each element in the world (index, id); it
  // may throw to simulate a world that refuses one element (MonitorCore's recovery).
  std::function<void(size_t element, const std::string& id)> before_predict_for_testing;

  size_t size() const;
  // Narrow-phase calls of the last predict (pairs left out by the filters are not counted).
  size_t lastCandidateCount() const;
  // Of those, the pairs answered by certificates (vadop::World::lastReusedCount).
  size_t lastReusedCount() const;
  // Broad-phase pairs the time-slice cull dropped before the narrow phase (not counted above).
  size_t lastSliceCulledCount() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  // set's body: `add()` puts the element into the world when it is not in yet. A template (not
  // std::function): set runs for every element every cycle, and the callable would be allocated.
  template <class Add>
  bool enter(size_t i, const std::string& id, const Add& add, const vadop::Motion& motion, std::string& error,
             uint32_t group, uint32_t mask, const std::shared_ptr<const vadop::LinkChain>& chain);
};

}  // namespace vadop_ros
