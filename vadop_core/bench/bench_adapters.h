// The peers of vadop_bench behind the vadop::BroadPhase interface, so the world code is the
// same for every method. Each bounds a body over the frame by the axis-aligned box of its
// swept sphere (sweptBox), or, for the pseudo-dynamic mode, by the box of the sphere at the
// frame pose t1 only. Their time split, as for SweepPruneBroadPhase (c_u = the new bounding
// volumes, c_s = maintaining the structure and the pairs): c_u = computing the boxes;
// c_s = everything the library does with them (FCL: writing the leaves, refit or rebuild,
// collide(); Bullet: setAabb, which moves the leaf and collides it at once, and
// calculateOverlappingPairs) plus reading the pairs out.
#pragma once

#include "bench_world.h"
#include "vadop/broad_phase.h"

#include <memory>
#include <string>
#include <vector>

namespace vadop_bench {

class TimedBroadPhase : public vadop::BroadPhase {
 public:
  double lastUpdateSeconds() const { return update_s_; }

 protected:
  // boxes_[id] = every alive body's box over [ta, tb] (bounding sphere swept along its path).
  void computeBoxes(double ta, double tb);

  double update_s_ = 0.0;
  std::vector<Box> boxes_;  // indexed by BodyId
};

enum class FclMode { kRefit, kRebuild };
enum class BoxKind { kSwept, kDiscrete };

// FCL 0.7 DynamicAABBTreeCollisionManager. kRefit: manager update() (refit + incremental
// balance) every frame; kRebuild: clear(), registerObjects(), setup() every frame.
std::unique_ptr<TimedBroadPhase> makeFclBroadPhase(FclMode mode, BoxKind boxes);

// Bullet btDbvtBroadphase: setAabb for every body, calculateOverlappingPairs. Its pair cache
// keeps pairs whose boxes stopped overlapping until its incremental cleanup reaches them; the
// adapter drops those (exact box test) so that the narrow phase sees the true box overlaps.
std::unique_ptr<TimedBroadPhase> makeBulletBroadPhase();

// Self-test of the bench's miss detection: FCL rebuild with every 5th candidate pair dropped.
std::unique_ptr<TimedBroadPhase> makeFaultyBroadPhase();

}  // namespace vadop_bench
