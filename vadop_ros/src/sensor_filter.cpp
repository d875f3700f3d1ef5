#include "vadop_ros/sensor_filter.h"

#include "vadop_ros/source.h"  // SourcedBody

#include <vadop/error.h>
#include <vadop/joint_chain.h>
#include <vadop/world.h>  // parallelFor

#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>

namespace vadop_ros {
namespace {

// A candidate spanning more grid cells than this is tested against every point instead.
constexpr double kMaxCellsPerCandidate = 64.0;
// How far up tf's tree a sensor's frame is followed (a tree deeper than this is not a robot).
constexpr int kMaxFrameDepth = 64;
// Points a thread takes at least, and at a time, when the filter's tests are shared out.
constexpr size_t kPointsPerThread = 2048, kPointChunk = 256;

std::string bare(const std::string& frame) {
  size_t i = 0;
  while (i < frame.size() && frame[i] == '/') ++i;
  return frame.substr(i);
}

}  // namespace

std::shared_ptr<const FilterSnapshot> makeFilterSnapshot(const BodyRegistry& registry,
                                                         const std::vector<SourcedBody>& tracked,
                                                         FilterShapeCache& cache) {
  auto snap = std::make_shared<FilterSnapshot>();
  snap->base = registry.timeBase();
  const auto& bodies = registry.bodies();
  const auto& elements = registry.elements();
  cache.resize(elements.size());
  for (size_t b = 0; b < bodies.size(); ++b) {
    snap->owners.push_back(bodies[b].name);
    snap->gated.push_back(bodies[b].params.has_gate ? 1 : 0);
  }
  snap->monitored = bodies.size();
  for (size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b].is_static) continue;
    if (!bodies[b].params.frame.empty()) snap->frame_owner.emplace(bare(bodies[b].params.frame), b);
    // An odometry body's frame is its messages' child_frame_id (its `frame` key is optional).
    const VelocityState* state = bodies[b].sources.empty() ? nullptr : bodies[b].sources.front()->velocityState();
    if (state && !state->child_frame.empty()) snap->frame_owner.emplace(bare(state->child_frame), b);
  }
  for (size_t i = 0; i < elements.size(); ++i) {
    const Element& e = elements[i];
    if (bodies[e.body].is_static) continue;
    if (!e.tf_frame.empty()) snap->frame_owner.emplace(bare(e.tf_frame), e.body);
    if (!e.active) continue;
    if (!cache[i]) cache[i] = std::make_shared<const vadop::PointDistance>(e.shape);
    snap->items.push_back({e.body, cache[i], e.motion, e.chain});
  }
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
    Eigen::Vector3d centre;
    try {
      centre = (item.chain ? item.chain->poseAt(t) : item.motion.poseAt(t)).translation();
    } catch (const std::exception&) {
      continue;
    }
    const double r = item.shape->shape().bounding_radius, d2 = (centre - origin).squaredNorm();
    if (d2 <= r * r && (best < 0 || d2 < best_d2)) {
      best = static_cast<int>(item.owner);
      best_d2 = d2;
    }
  }
  return best;
}

int carrierOf(const FilterSnapshot& snapshot, const std::string& frame, const ros::Time& stamp, TransformSource& tf,
              const Eigen::Vector3d* origin) {
  std::string f = bare(frame);
  for (int depth = 0; depth < kMaxFrameDepth && !f.empty(); ++depth) {
    if (const auto it = snapshot.frame_owner.find(f); it != snapshot.frame_owner.end()) {
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
    f = bare(parent);
  }
  return origin ? holderOf(snapshot, secondsBetween(stamp, snapshot.base), *origin) : -1;
}

SensorFilter::Cell SensorFilter::cellOf(const Eigen::Vector3d& p) const {
  return {static_cast<int64_t>(std::floor(p.x() / cell_)), static_cast<int64_t>(std::floor(p.y() / cell_)),
          static_cast<int64_t>(std::floor(p.z() / cell_))};
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

bool SensorFilter::cellRange(const Candidate& c, Cell& a, Cell& b) const {
  const double r = std::sqrt(c.reach2);
  a = cellOf(c.centre - Eigen::Vector3d::Constant(r));
  b = cellOf(c.centre + Eigen::Vector3d::Constant(r));
  // In doubles: a large body over small cells would overflow the product of integers.
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) cells *= static_cast<double>(b[k] - a[k] + 1);
  return cells <= kMaxCellsPerCandidate;
}

void SensorFilter::bin() {
  big_.clear();
  // Cells of about a typical candidate's diameter: most candidates span a few cells.
  std::vector<double> reach;
  for (const Candidate& c : candidates_) reach.push_back(std::sqrt(c.reach2));
  std::nth_element(reach.begin(), reach.begin() + reach.size() / 2, reach.end());
  cell_ = std::max(2.0 * reach[reach.size() / 2], 1e-3);
  // One pass over the candidates' cells: each cell's index (in order of its first visit), its
  // count and the (cell, candidate) pairs; then the pairs placed side by side by cell.
  const auto forEachCell = [](const Cell& a, const Cell& b, auto&& f) {
    for (int64_t x = a[0]; x <= b[0]; ++x) {
      for (int64_t y = a[1]; y <= b[1]; ++y) {
        for (int64_t z = a[2]; z <= b[2]; ++z) f(Cell{x, y, z});
      }
    }
  };
  size_t visits = 0;
  ranges_.resize(candidates_.size());
  for (uint32_t k = 0; k < candidates_.size(); ++k) {
    auto& [a, b] = ranges_[k];
    if (!cellRange(candidates_[k], a, b)) {
      big_.push_back(k);
      continue;
    }
    visits += static_cast<size_t>((b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1));
  }
  grid_.reset(visits);
  starts_.clear();
  pairs_.clear();
  for (uint32_t k = 0, big = 0; k < candidates_.size(); ++k) {
    if (big < big_.size() && big_[big] == k) {  // big_ is in candidate order
      ++big;
      continue;
    }
    forEachCell(ranges_[k].first, ranges_[k].second, [this, k](const Cell& cell) {
      bool fresh = false;
      uint32_t& index = grid_.insert(cell, fresh);
      if (fresh) {
        index = static_cast<uint32_t>(starts_.size());
        starts_.push_back(0);
      }
      ++starts_[index];
      pairs_.push_back({index, k});
    });
  }
  // Counts -> starts (exclusive prefix sums), then each candidate at its cell's next place.
  uint32_t total = 0;
  for (uint32_t& s : starts_) total += std::exchange(s, total);
  starts_.push_back(total);
  binned_.resize(total);
  next_.assign(starts_.begin(), starts_.end() - 1);
  for (const auto& [cell, k] : pairs_) binned_[next_[cell]++] = k;
}

bool SensorFilter::holds(const Candidate& c, const Eigen::Vector3d& p) {
  if ((p - c.centre).squaredNorm() > c.reach2) return false;
  return c.placed.within(p, c.margin);
}

const SensorFilter::Candidate* SensorFilter::holder(const Eigen::Vector3d& p) const {
  if (const uint32_t* cell = grid_.find(cellOf(p))) {
    for (uint32_t i = starts_[*cell]; i < starts_[*cell + 1]; ++i) {
      if (holds(candidates_[binned_[i]], p)) return &candidates_[binned_[i]];
    }
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
  bin();
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
