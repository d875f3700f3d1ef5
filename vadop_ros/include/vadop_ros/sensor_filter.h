// What a sensor's points are filtered against (~sensors' filter_margin and self_margin): the
// monitored bodies' collision elements and the tracked objects, as the node's last cycle knew
// them (FilterSnapshot), and the filter itself (SensorFilter). A point within an element's
// unpadded shape, posed at the message's stamp and grown by the margin, is dropped: that body
// is predicted from its own motion instead. The sensor's own body (the monitored body whose
// tf frame, or one of whose link frames, the message's frame hangs from; when none does, the
// monitored body whose element's bounding sphere holds the sensor's origin) uses self_margin,
// and so does every body with a gate (its padding exceeds self_margin: a wall beside it is
// never taken for it), every other body filter_margin (self_margin, the smaller by default: a
// wrong guess keeps points).
// Pose at the stamp: each element's motion of the last cycle (the twist from its latest state,
// or its plan / joint chain) evaluated at the stamp: extrapolated back from its latest state
// when the stamp is before it, which is exact for a body that kept its velocity since. An
// element the last cycle could not place (no state, a transform missing) or whose pose at the
// stamp cannot be had filters nothing: its points stay obstacles (the safe side).
// Cost: the elements' bounding spheres grown by the margin are culled against the points'
// bounding box, the survivors binned in a uniform grid over that box (a counting sort); a
// point is tested exactly
// (vadop::PointDistance) only against the elements whose grown sphere contains it.
// It does not: filter against static obstacles or other sensors' points (never), or
// compensate the sensor's own motion during a scan.
#pragma once

#include "vadop_ros/body_registry.h"  // TransformSource

#include <vadop/motion.h>
#include <vadop/point_distance.h>

#include <Eigen/Geometry>
#include <ros/time.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace vadop {
class LinkChain;
}

namespace vadop_ros {

struct SourcedBody;

// The filter's view of the bodies at one cycle: immutable once made, shared by the sensors'
// message handlers outside the node's lock.
struct FilterSnapshot {
  struct Item {
    size_t owner = 0;  // index into owners
    std::shared_ptr<const vadop::PointDistance> shape;  // unpadded
    vadop::Motion motion;                                // registry seconds
    std::shared_ptr<const vadop::LinkChain> chain;       // null: `motion` alone
  };
  ros::Time base;                   // the registry's time base (seconds() of its motions)
  std::vector<Item> items;
  std::vector<std::string> owners;  // a monitored body's or tracked object's name
  size_t monitored = 0;             // owners [0, monitored) are the registry's bodies
  // Per owner: a body with a gate. Points beside it are dropped only within self_margin,
  // whichever sensor saw them: its padding exceeds that margin (checkSelfMargins), so its gate
  // stops it before a wall there could be taken for it (with filter_margin, a sensor not on the
  // robot would drop a wall's points as the robot neared them and its gate would drive it in).
  std::vector<char> gated;
  // The monitored bodies' tf frames (body frame, links' tf frames) -> owner (never null in a
  // made snapshot; shared by the snapshots while the frames stay the same).
  std::shared_ptr<const std::unordered_map<std::string, size_t>> frame_owner;
};

// What makeFilterSnapshot keeps from one snapshot to the next: the prepared shapes of the
// registry's elements (built once each: a mesh's tree is costly), and the frames' owners, in
// the order they were met (a fleet's thousands of frames hashed into a new map every cycle
// cost more than the rest of the snapshot: the map is kept while they are met again alike).
struct FilterCache {
  std::vector<std::shared_ptr<const vadop::PointDistance>> shapes;
  std::vector<std::pair<std::string, size_t>> frames;
  std::shared_ptr<const std::unordered_map<std::string, size_t>> frame_owner;
};

// The snapshot of the moving bodies' elements placed at the last update and of the tracked
// objects `tracked` (alive slots).
std::shared_ptr<const FilterSnapshot> makeFilterSnapshot(const BodyRegistry& registry,
                                                         const std::vector<SourcedBody>& tracked,
                                                         FilterCache& cache);

// The owner whose frame `frame` hangs from in tf (the frame itself, then its parents up to the
// root, asked at `stamp`, else the latest); when none does and `origin` (the frame's origin in
// the fixed frame) is given, the monitored body with an element whose bounding sphere at the
// stamp holds it (the nearest centre); else -1.
int carrierOf(const FilterSnapshot& snapshot, const std::string& frame, const ros::Time& stamp, TransformSource& tf,
              const Eigen::Vector3d* origin = nullptr);

// Drops the points within the snapshot's elements posed at `stamp`, grown by `margin` (the
// owner `self`: by `self_margin`), the points tested on up to `threads` threads (resolved: at
// least 1) when they are many; the kept ones stay in their order. One per sensor (its scratch
// is reused across messages).
class SensorFilter {
 public:
  struct Dropped {
    size_t self = 0, others = 0;
  };
  Dropped apply(const FilterSnapshot& snapshot, const ros::Time& stamp, int self, double margin, double self_margin,
                std::vector<Eigen::Vector3d>& points, int threads = 1);

 private:
  struct Candidate {
    // The element at the stamp, its closed-form kinds' parameters beside the pose: a point's
    // test reads the candidate alone (the filter tests tens of thousands of points a message).
    vadop::PointDistance::Placed placed;
    Eigen::Vector3d centre;
    double reach2 = 0.0;  // (bounding radius + margin)^2
    double margin = 0.0;
    bool self = false;
  };
  // The items whose grown bounding sphere meets the box [lo, hi].
  void cull(const FilterSnapshot& snapshot, double t, int self, double margin, double self_margin,
            const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
  // The candidates into a grid over the points' box [lo, hi] (those spanning too many cells:
  // big_).
  void bin(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
  // The grid's cell along axis k of coordinate x (clamped into the grid), and of a point.
  int64_t axisCell(double x, int k) const;
  size_t cellOf(const Eigen::Vector3d& p) const;
  // The candidate that holds `p`, or null.
  const Candidate* holder(const Eigen::Vector3d& p) const;
  static bool holds(const Candidate& c, const Eigen::Vector3d& p);

  // The cells of the candidate's grown sphere's box, inclusive, clamped into the grid; false
  // when there are more than kMaxCellsPerCandidate (the candidate then goes to big_).
  struct Range {
    std::array<int64_t, 3> lo, hi;
  };
  bool cellRange(const Candidate& c, Range& range) const;

  std::vector<Candidate> candidates_;
  // The grid (dims_ cells of cell_ from origin_, x-major): cell i's candidates are
  // binned_[starts_[i], starts_[i + 1]).
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  std::array<int64_t, 3> dims_{1, 1, 1};
  std::vector<uint32_t> starts_, binned_;
  std::vector<Range> ranges_;     // bin's cellRange of each candidate
  std::vector<uint32_t> next_;   // bin's next place in each cell
  std::vector<uint32_t> big_;
  std::vector<uint8_t> held_;  // per point: 0 kept, 1 dropped on its own body, 2 on another
  double cell_ = 1.0;
};

}  // namespace vadop_ros
