#include "vadop_ros/sensor_filter.h"

#include "vadop_ros/source.h"  // SourcedBody

#include <vadop/error.h>
#include <vadop/joint_chain.h>
#include <vadop/world.h>  // parallelFor

#include <algorithm>
#include <cmath>
#include <exception>
#include <string_view>
#include <utility>

namespace vadop_ros {
namespace {

// A candidate spanning more grid cells than this is tested against every point instead.
constexpr double kMaxCellsPerCandidate = 64.0;
// The grid's cells at most (a cloud spread far beyond its bodies gets larger cells): its
// counts, one uint32_t a cell, are cleared for every message.
constexpr double kMaxGridCells = 1 << 18;
// How far up tf's tree a sensor's frame is followed (a tree deeper than this is not a robot).
constexpr int kMaxFrameDepth = 64;
// Points a thread takes at least, and at a time, when the filter's tests are shared out.
constexpr size_t kPointsPerThread = 2048, kPointChunk = 256;

std::string_view bare(std::string_view frame) {
  size_t i = 0;
  while (i < frame.size() && frame[i] == '/') ++i;
  return frame.substr(i);
}

}  // namespace

std::shared_ptr<const FilterSnapshot> makeFilterSnapshot(const BodyRegistry& registry,
                                                         const std::vector<SourcedBody>& tracked,
                                                         FilterCache& cache) {
  auto snap = std::make_shared<FilterSnapshot>();
  snap->base = registry.timeBase();
  const auto& bodies = registry.bodies();
  const auto& elements = registry.elements();
  cache.shapes.resize(elements.size());
  // The frames met in the same order as by the last snapshot keep its map; from the first that
  // differs on, the list is made anew and so is the map (the first owner of a frame wins).
  size_t met = 0;
  bool same = true;
  const auto frame = [&](const std::string& name, size_t owner) {
    if (name.empty()) return;
    const std::string_view f = bare(name);
    if (same && met < cache.frames.size() && cache.frames[met].second == owner && cache.frames[met].first == f) {
      ++met;
      return;
    }
    if (same) cache.frames.resize(met);
    same = false;
    cache.frames.emplace_back(std::string(f), owner);
    ++met;
  };
  for (size_t b = 0; b < bodies.size(); ++b) {
    snap->owners.push_back(bodies[b].name);
    snap->gated.push_back(bodies[b].params.has_gate ? 1 : 0);
  }
  snap->monitored = bodies.size();
  for (size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b].is_static) continue;
    frame(bodies[b].params.frame, b);
    // An odometry body's frame is its messages' child_frame_id (its `frame` key is optional).
    const VelocityState* state = bodies[b].sources.empty() ? nullptr : bodies[b].sources.front()->velocityState();
    if (state) frame(state->child_frame, b);
  }
  for (size_t i = 0; i < elements.size(); ++i) {
    const Element& e = elements[i];
    if (bodies[e.body].is_static) continue;
    frame(e.tf_frame, e.body);
    if (!e.active) continue;
    if (!cache.shapes[i]) cache.shapes[i] = std::make_shared<const vadop::PointDistance>(e.shape);
    snap->items.push_back({e.body, cache.shapes[i], e.motion, e.chain});
  }
  if (met != cache.frames.size()) {  // fewer frames than the last snapshot's
    cache.frames.resize(met);
    same = false;
  }
  if (!same || !cache.frame_owner) {
    auto owner = std::make_shared<std::unordered_map<std::string, size_t>>();
    for (const auto& [f, o] : cache.frames) owner->emplace(f, o);
    cache.frame_owner = std::move(owner);
  }
  snap->frame_owner = cache.frame_owner;
  for (const SourcedBody& t : tracked) {
    if (!t.alive) continue;
    try {
      vadop::Motion m = twistMotion(t.pose, t.v, t.w, registry.seconds(t.stamp));
      snap->items.push_back({snap->owners.size(), std::make_shared<const vadop::PointDistance>(t.shape), m, nullptr});
      snap->owners.push_back(t.name);
      snap->gated.push_back(0);
    } catch (const vadop::InvalidArgument&) {
      // Out of the library's range: the cycle leaves it out of the world too; it filters nothing.
    }
  }
  return snap;
}

// The monitored body with an element whose bounding sphere at `t` holds `origin` (the nearest
// centre), or -1.
int holderOf(const FilterSnapshot& snapshot, double t, const Eigen::Vector3d& origin) {
  int best = -1;
  double best_d2 = 0.0;
  for (const FilterSnapshot::Item& item : snapshot.items) {
    if (item.owner >= snapshot.monitored) continue;
    const double r = item.shape->shape().bounding_radius;
    // The origin stays within the pivot's arm of the motion's centre, which moves in a straight
    // line: a far element is passed over without its pose (a fleet's thousand, per message).
    if (!item.chain) {
      const double reach = r + item.motion.pivotArm();
      if (!((item.motion.centreAt(t) - origin).squaredNorm() <= reach * reach)) continue;
    }
    Eigen::Vector3d centre;
    try {
      centre = (item.chain ? item.chain->poseAt(t) : item.motion.poseAt(t)).translation();
    } catch (const std::exception&) {
      continue;
    }
    const double d2 = (centre - origin).squaredNorm();
    if (d2 <= r * r && (best < 0 || d2 < best_d2)) {
      best = static_cast<int>(item.owner);
      best_d2 = d2;
    }
  }
  return best;
}

int carrierOf(const FilterSnapshot& snapshot, const std::string& frame, const ros::Time& stamp, TransformSource& tf,
              const Eigen::Vector3d* origin) {
  std::string f(bare(frame));
  for (int depth = 0; depth < kMaxFrameDepth && !f.empty(); ++depth) {
    if (const auto it = snapshot.frame_owner->find(f); it != snapshot.frame_owner->end()) {
      return static_cast<int>(it->second);
    }
    std::string parent;
    bool found = false;
    try {
      found = tf.parent(f, stamp, parent) || tf.parent(f, ros::Time(0), parent);
    } catch (const std::exception&) {
      found = false;
    }
    if (!found || bare(parent) == f) break;
    f = std::string(bare(parent));
  }
  return origin ? holderOf(snapshot, secondsBetween(stamp, snapshot.base), *origin) : -1;
}

int64_t SensorFilter::axisCell(double x, int k) const {
  // Clamped: the points lie in the grid's box, but not every candidate's sphere does.
  const double c = std::floor((x - origin_[k]) / cell_);
  return static_cast<int64_t>(std::clamp(c, 0.0, static_cast<double>(dims_[k] - 1)));
}

size_t SensorFilter::cellOf(const Eigen::Vector3d& p) const {
  return static_cast<size_t>((axisCell(p.x(), 0) * dims_[1] + axisCell(p.y(), 1)) * dims_[2] + axisCell(p.z(), 2));
}

void SensorFilter::cull(const FilterSnapshot& snapshot, double t, int self, double margin, double self_margin,
                        const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  candidates_.clear();
  for (size_t i = 0; i < snapshot.items.size(); ++i) {
    const FilterSnapshot::Item& item = snapshot.items[i];
    const bool is_self = static_cast<int>(item.owner) == self;
    const double m = is_self || snapshot.gated[item.owner] ? self_margin : margin;
    Candidate c;
    try {
      const Eigen::Isometry3d pose = item.chain ? item.chain->poseAt(t) : item.motion.poseAt(t);
      c.placed = item.shape->place(pose);  // throws for a pose that is not finite
      c.centre = pose.translation();
    } catch (const std::exception&) {
      continue;  // no pose at the stamp: it filters nothing
    }
    const double reach = item.shape->shape().bounding_radius + m;
    // The grown bounding sphere against the points' box: the box's point nearest the centre.
    if ((c.centre - c.centre.cwiseMax(lo).cwiseMin(hi)).squaredNorm() > reach * reach) continue;
    c.reach2 = reach * reach;
    c.margin = m;
    c.self = is_self;
    candidates_.push_back(c);
  }
}

bool SensorFilter::cellRange(const Candidate& c, Range& range) const {
  const double r = std::sqrt(c.reach2);
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    range.lo[k] = axisCell(c.centre[k] - r, k);
    range.hi[k] = axisCell(c.centre[k] + r, k);
    cells *= static_cast<double>(range.hi[k] - range.lo[k] + 1);
  }
  return cells <= kMaxCellsPerCandidate;
}

void SensorFilter::bin(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  big_.clear();
  // Cells of about a typical candidate's diameter (most candidates span a few cells), over the
  // points' box; larger when that box would need more than kMaxGridCells of them.
  std::vector<double> reach;
  for (const Candidate& c : candidates_) reach.push_back(std::sqrt(c.reach2));
  std::nth_element(reach.begin(), reach.begin() + reach.size() / 2, reach.end());
  cell_ = std::max(2.0 * reach[reach.size() / 2], 1e-3);
  const Eigen::Vector3d span = hi - lo;
  const auto count = [&span](double cell) {
    double n = 1.0;
    for (int k = 0; k < 3; ++k) n *= std::floor(span[k] / cell) + 1.0;
    return n;
  };
  while (count(cell_) > kMaxGridCells) cell_ *= 1.5;
  origin_ = lo;
  for (int k = 0; k < 3; ++k) dims_[k] = static_cast<int64_t>(std::floor(span[k] / cell_)) + 1;
  const size_t cells = static_cast<size_t>(dims_[0] * dims_[1] * dims_[2]);
  // Each candidate in every cell of its range: counted, the counts made starts (a counting
  // sort), then placed; a cell's candidates binned_[starts_[i], starts_[i + 1]).
  const auto forEachCell = [this](const Range& r, auto&& f) {
    for (int64_t x = r.lo[0]; x <= r.hi[0]; ++x) {
      for (int64_t y = r.lo[1]; y <= r.hi[1]; ++y) {
        const size_t row = static_cast<size_t>((x * dims_[1] + y) * dims_[2]);
        for (int64_t z = r.lo[2]; z <= r.hi[2]; ++z) f(row + static_cast<size_t>(z));
      }
    }
  };
  starts_.assign(cells + 1, 0);
  ranges_.resize(candidates_.size());
  for (uint32_t k = 0; k < candidates_.size(); ++k) {
    if (!cellRange(candidates_[k], ranges_[k])) {
      big_.push_back(k);
      continue;
    }
    forEachCell(ranges_[k], [this](size_t i) { ++starts_[i + 1]; });
  }
  for (size_t i = 0; i < cells; ++i) starts_[i + 1] += starts_[i];
  binned_.resize(starts_[cells]);
  next_.assign(starts_.begin(), starts_.end() - 1);
  for (uint32_t k = 0, big = 0; k < candidates_.size(); ++k) {
    if (big < big_.size() && big_[big] == k) {  // big_ is in candidate order
      ++big;
      continue;
    }
    forEachCell(ranges_[k], [this, k](size_t i) { binned_[next_[i]++] = k; });
  }
}

bool SensorFilter::holds(const Candidate& c, const Eigen::Vector3d& p) {
  if ((p - c.centre).squaredNorm() > c.reach2) return false;
  return c.placed.within(p, c.margin);
}

const SensorFilter::Candidate* SensorFilter::holder(const Eigen::Vector3d& p) const {
  const size_t cell = cellOf(p);
  for (uint32_t i = starts_[cell]; i < starts_[cell + 1]; ++i) {
    if (holds(candidates_[binned_[i]], p)) return &candidates_[binned_[i]];
  }
  for (const uint32_t k : big_) {
    if (holds(candidates_[k], p)) return &candidates_[k];
  }
  return nullptr;
}

SensorFilter::Dropped SensorFilter::apply(const FilterSnapshot& snapshot, const ros::Time& stamp, int self,
                                          double margin, double self_margin, std::vector<Eigen::Vector3d>& points,
                                          int threads) {
  Dropped dropped;
  if (points.empty() || snapshot.items.empty()) return dropped;
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const Eigen::Vector3d& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  cull(snapshot, secondsBetween(stamp, snapshot.base), self, margin, self_margin, lo, hi);
  if (candidates_.empty()) return dropped;
  bin(lo, hi);
  // Each point's holder on the threads (the grid and the shapes are only read), then the kept
  // points moved up in order.
  held_.resize(points.size());
  vadop::parallelFor(threads, points.size(), kPointsPerThread, kPointChunk, [&](size_t i) {
    const Candidate* c = holder(points[i]);
    held_[i] = c == nullptr ? 0 : c->self ? 1 : 2;
  });
  size_t kept = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (held_[i] == 0) {
      points[kept++] = points[i];
    } else {
      ++(held_[i] == 1 ? dropped.self : dropped.others);
    }
  }
  points.resize(kept);
  return dropped;
}

}  // namespace vadop_ros
