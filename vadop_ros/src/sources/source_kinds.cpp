// The registration tables of the input kinds (source.h): a new kind is its own file in this
// directory and one line here (its SourceKind or BodiesSourceKind, declared and listed).
#include "vadop_ros/source.h"

namespace vadop_ros {

SourceKind odometrySourceKind();
SourceKind twistSourceKind();
SourceKind bodyStatesSourceKind();
SourceKind jointStatesSourceKind();
SourceKind jointTrajectorySourceKind();
SourceKind pathSourceKind();
BodiesSourceKind trackedObjectsSourceKind();
BodiesSourceKind sensorsSourceKind();

const std::vector<SourceKind>& sourceKinds() {
  // The velocity source first: the others start from the body frame it gives. The rest in the
  // order the diagnostics list their counts.
  static const std::vector<SourceKind> kinds = {
      odometrySourceKind(), twistSourceKind(), bodyStatesSourceKind(), jointStatesSourceKind(),
      jointTrajectorySourceKind(), pathSourceKind(),
  };
  return kinds;
}

const std::vector<BodiesSourceKind>& bodiesSourceKinds() {
  static const std::vector<BodiesSourceKind> kinds = {
      trackedObjectsSourceKind(),
      sensorsSourceKind(),
  };
  return kinds;
}

}  // namespace vadop_ros
