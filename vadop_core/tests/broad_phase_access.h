// The tests' view of the engines' volumes: the per-axis intervals of the last update, which the
// property tests check against the paper's zone rule and against the motions. Not part of the
// library's API (the engines befriend this struct; nothing installed defines it).
#pragma once

#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <vector>

namespace vadop {

struct BroadPhaseTestAccess {
  static std::vector<SweepPruneBroadPhase::AxisSpan> volume(const SweepPruneBroadPhase& bp, BodyId id) {
    return bp.volume(id);
  }
  static std::vector<SweepPruneBroadPhase::AxisSpan> volume(const VadopGridBroadPhase& bp, BodyId id) {
    return bp.volume(id);
  }
  static Eigen::Vector3d axisDirection(const VadopGridBroadPhase& bp, uint32_t axis) {
    return bp.axisDirection(axis);
  }
};

}  // namespace vadop
