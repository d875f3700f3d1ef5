#include "bench_world.h"

#include "bench_adapters.h"
#include "vadop/sweep_prune.h"
#include "vadop/vadop_grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>

#include <time.h>

namespace vadop_bench {
namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// Random sequential addition with a grid of cell >= 2r: O(n) expected below density ~0.2.
bool placeRandom(const SceneParams& p, double half, std::mt19937_64& rng, std::vector<Eigen::Vector3d>& out) {
  const double r = p.radius, lo = -half + r, hi = half - r;
  if (hi < lo) return false;
  const double side = 2.0 * half;
  const double cell = std::max(2.0 * r, side / std::cbrt(static_cast<double>(p.n)));
  const int g = std::max(1, static_cast<int>(std::ceil(side / cell)));
  std::vector<int32_t> head(static_cast<size_t>(g) * g * g, -1), next;
  next.reserve(p.n);
  auto cellOf = [&](double x) { return std::clamp(static_cast<int>((x + half) / cell), 0, g - 1); };
  std::uniform_real_distribution<double> u(lo, hi);
  const size_t max_attempts = 2000 * static_cast<size_t>(p.n) + 100000;
  size_t attempts = 0;
  out.clear();
  out.reserve(p.n);
  while (static_cast<int>(out.size()) < p.n) {
    if (++attempts > max_attempts) return false;
    const Eigen::Vector3d c(u(rng), u(rng), u(rng));
    const int cx = cellOf(c.x()), cy = cellOf(c.y()), cz = cellOf(c.z());
    bool free = true;
    for (int z = std::max(0, cz - 1); free && z <= std::min(g - 1, cz + 1); ++z) {
      for (int y = std::max(0, cy - 1); free && y <= std::min(g - 1, cy + 1); ++y) {
        for (int x = std::max(0, cx - 1); free && x <= std::min(g - 1, cx + 1); ++x) {
          for (int32_t k = head[(static_cast<size_t>(z) * g + y) * g + x]; k >= 0; k = next[k]) {
            if ((out[k] - c).squaredNorm() <= 4.0 * r * r * (1.0 + 1e-9)) {
              free = false;
              break;
            }
          }
        }
      }
    }
    if (!free) continue;
    const size_t idx = (static_cast<size_t>(cz) * g + cy) * g + cx;
    next.push_back(head[idx]);
    head[idx] = static_cast<int32_t>(out.size());
    out.push_back(c);
  }
  return true;
}

// Jittered face-centred cubic lattice (packing up to 0.74): for densities where random
// sequential addition jams.
bool placeLattice(const SceneParams& p, double half, std::mt19937_64& rng, std::vector<Eigen::Vector3d>& out) {
  const double r = p.radius, span = 2.0 * (half - r);
  out.clear();
  if (span < 0) return false;
  if (p.n == 1) {
    out.push_back(Eigen::Vector3d::Zero());
    return true;
  }
  int k = 1;
  auto sites = [](int kk) { return (static_cast<long long>(kk + 1) * (kk + 1) * (kk + 1) + 1) / 2; };
  while (sites(k) < p.n) ++k;
  const double s = span / k;
  const double nn = s * std::sqrt(2.0);
  if (nn < 2.0 * r * (1.0 + 1e-9)) return false;
  std::vector<Eigen::Vector3d> all;
  for (int z = 0; z <= k; ++z)
    for (int y = 0; y <= k; ++y)
      for (int x = 0; x <= k; ++x)
        if ((x + y + z) % 2 == 0) all.emplace_back(-half + r + x * s, -half + r + y * s, -half + r + z * s);
  std::shuffle(all.begin(), all.end(), rng);
  const double jitter = 0.999 * (nn - 2.0 * r) / (2.0 * std::sqrt(3.0));
  std::uniform_real_distribution<double> u(-jitter, jitter);
  for (int i = 0; i < p.n; ++i) {
    Eigen::Vector3d c = all[i];
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(c[a] + u(rng), -half + r, half - r);
    out.push_back(c);
  }
  return true;
}

}  // namespace

Scene makeScene(const SceneParams& p) {
  Scene s;
  s.params = p;
  const double volume = p.n * 4.0 / 3.0 * M_PI * p.radius * p.radius * p.radius / p.density;
  s.half = 0.5 * std::cbrt(volume);
  // Separate streams, so that the positions do not depend on the speed.
  std::mt19937_64 rng_pos(p.seed * 0x9e3779b97f4a7c15ULL + 1);
  std::mt19937_64 rng_vel(p.seed * 0xbf58476d1ce4e5b9ULL + 2);
  bool ok = p.density <= 0.2 ? placeRandom(p, s.half, rng_pos, s.position) : false;
  if (!ok) ok = placeLattice(p, s.half, rng_pos, s.position);
  if (!ok) {
    throw std::runtime_error("cannot place " + std::to_string(p.n) + " non-overlapping spheres at density " +
                             std::to_string(p.density) + " (try more spheres or a lower density)");
  }
  std::normal_distribution<double> g;
  const double v = p.speed * p.radius * p.fps;
  s.velocity.resize(p.n);
  for (auto& vel : s.velocity) {
    Eigen::Vector3d d;
    do {
      d = Eigen::Vector3d(g(rng_vel), g(rng_vel), g(rng_vel));
    } while (d.squaredNorm() < 1e-12);
    vel = d.normalized() * v;
  }
  return s;
}

Box segmentBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  const double pad = r + 1e-9;
  return Box{a.cwiseMin(b).array() - pad, a.cwiseMax(b).array() + pad};
}

Box sweptBox(const vadop::Motion& m, double r, double ta, double tb) {
  return segmentBox(m.positionAt(ta), m.positionAt(tb), r);
}

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double broadPhaseUpdateSeconds(const vadop::BroadPhase& bp) {
  if (const auto* sp = dynamic_cast<const vadop::SweepPruneBroadPhase*>(&bp)) return sp->stats().update_seconds;
  if (const auto* vg = dynamic_cast<const vadop::VadopGridBroadPhase*>(&bp)) return vg->stats().update_seconds;
  if (const auto* tb = dynamic_cast<const TimedBroadPhase*>(&bp)) return tb->lastUpdateSeconds();
  return 0.0;
}

// ---------------------------------------------------------------------------------------------
// RequeryGrid

int RequeryGrid::cellOf(double x) const {
  const double c = std::floor((x - origin_) * inv_h_);
  if (!(c >= 0.0)) return 0;  // also NaN
  if (c >= g_ - 1) return g_ - 1;
  return static_cast<int>(c);
}

RequeryGrid::FloatBox RequeryGrid::toFloat(const Box& b) {
  // Conversion to float is monotone (x <= y implies float(x) <= float(y)), so boxes that
  // overlap in double still overlap in float: the rounding can add answers, never drop one.
  FloatBox f;
  for (int k = 0; k < 3; ++k) {
    f.lo[k] = static_cast<float>(b.lo[k]);
    f.hi[k] = static_cast<float>(b.hi[k]);
  }
  return f;
}

void RequeryGrid::build(const std::vector<Box>& boxes, double half) {
  const size_t n = boxes.size();
  auto extent = [&boxes](size_t i) { return (boxes[i].hi - boxes[i].lo).maxCoeff(); };
  const double side = 2.0 * half + 4.0;
  origin_ = -half - 2.0;
  // Cells at least as large as 98% of the boxes (such a box spans at most 2 cells per axis,
  // so a query only looks one cell below its own range) and about one body per cell. The
  // few larger boxes (bodies much faster than the rest) are listed in every cell they
  // overlap, like the bodies that change velocity during the frame.
  double typical = 0.0;
  if (n > 0) {
    std::vector<double> e(n);
    for (size_t i = 0; i < n; ++i) e[i] = extent(i);
    const size_t k = std::min(n - 1, static_cast<size_t>(0.98 * n));
    std::nth_element(e.begin(), e.begin() + k, e.end());
    typical = e[k];
  }
  h_ = std::max(typical, side / std::max(1.0, std::cbrt(static_cast<double>(n))));
  inv_h_ = 1.0 / h_;
  g_ = std::max(1, static_cast<int>(std::ceil(side / h_)) + 1);
  const size_t cells = static_cast<size_t>(g_) * g_ * g_;
  cell_start_.assign(cells + 1, 0);
  std::vector<uint32_t> cell_of(n);
  for (size_t i = 0; i < n; ++i) {
    cell_of[i] = static_cast<uint32_t>(index(cellOf(boxes[i].lo.x()), cellOf(boxes[i].lo.y()), cellOf(boxes[i].lo.z())));
    ++cell_start_[cell_of[i] + 1];
  }
  std::partial_sum(cell_start_.begin(), cell_start_.end(), cell_start_.begin());
  std::vector<uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
  entries_.resize(n);
  entry_of_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t e = fill[cell_of[i]]++;
    entries_[e] = Entry{toFloat(boxes[i]), static_cast<uint32_t>(i)};
    entry_of_[i] = e;
  }
  moved_version_.resize(n, 0);
  if (dyn_head_.size() != cells) {
    dyn_head_.assign(cells, -1);
  } else {
    for (size_t c : dyn_touched_) dyn_head_[c] = -1;
  }
  dyn_touched_.clear();
  dyn_nodes_.clear();
  if (stamp_.size() != n) {
    stamp_.assign(n, 0);
    stamp_now_ = 0;
  }
  for (size_t i = 0; i < n; ++i) {
    if (extent(i) > h_) moved(static_cast<uint32_t>(i), boxes[i]);
  }
}

void RequeryGrid::moved(uint32_t id, const Box& box) {
  if (entry_of_[id] != kNone) {  // off its frame path: empty its static entry
    FloatBox& gone = entries_[entry_of_[id]].box;
    gone.lo[0] = std::numeric_limits<float>::infinity();
    gone.hi[0] = -std::numeric_limits<float>::infinity();
    entry_of_[id] = kNone;
  }
  const uint32_t version = ++moved_version_[id];
  const int x0 = cellOf(box.lo.x()), x1 = cellOf(box.hi.x());
  const int y0 = cellOf(box.lo.y()), y1 = cellOf(box.hi.y());
  const int z0 = cellOf(box.lo.z()), z1 = cellOf(box.hi.z());
  Node node{toFloat(box), id, version, -1};
  for (int z = z0; z <= z1; ++z)
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const size_t c = index(x, y, z);
        if (dyn_head_[c] < 0) dyn_touched_.push_back(c);
        node.next = dyn_head_[c];
        dyn_nodes_.push_back(node);
        dyn_head_[c] = static_cast<int32_t>(dyn_nodes_.size() - 1);
      }
}

void RequeryGrid::query(uint32_t id, const Box& box, std::vector<uint32_t>& out) {
  out.clear();
  const FloatBox q = toFloat(box);
  // Bodies still on their frame path: each has one entry, in the cell of its box's lo corner,
  // which lies within one cell size below the query box if the boxes overlap.
  {
    const int x0 = cellOf(box.lo.x() - h_), x1 = cellOf(box.hi.x());
    const int y0 = cellOf(box.lo.y() - h_), y1 = cellOf(box.hi.y());
    const int z0 = cellOf(box.lo.z() - h_), z1 = cellOf(box.hi.z());
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y) {
        const size_t row = index(0, y, z);
        const Entry* e = entries_.data() + cell_start_[row + x0];
        const Entry* end = entries_.data() + cell_start_[row + x1 + 1];
        for (; e != end; ++e) {
          if (overlaps(e->box, q) && e->body != id) out.push_back(e->body);
        }
      }
  }
  // Bodies that changed velocity this frame: possibly listed in several cells, so deduplicated.
  if (!dyn_nodes_.empty()) {
    if (++stamp_now_ == 0) {
      std::fill(stamp_.begin(), stamp_.end(), 0);
      stamp_now_ = 1;
    }
    stamp_[id] = stamp_now_;
    const int x0 = cellOf(box.lo.x()), x1 = cellOf(box.hi.x());
    const int y0 = cellOf(box.lo.y()), y1 = cellOf(box.hi.y());
    const int z0 = cellOf(box.lo.z()), z1 = cellOf(box.hi.z());
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
          for (int32_t k = dyn_head_[index(x, y, z)]; k >= 0; k = dyn_nodes_[k].next) {
            const Node& node = dyn_nodes_[k];
            if (!overlaps(node.box, q) || node.version != moved_version_[node.body] ||
                stamp_[node.body] == stamp_now_) {
              continue;
            }
            stamp_[node.body] = stamp_now_;
            out.push_back(node.body);
          }
  }
}

size_t RequeryGrid::memoryBytes() const {
  return cell_start_.capacity() * 4 + entries_.capacity() * sizeof(Entry) + entry_of_.capacity() * 4 +
         moved_version_.capacity() * 4 + dyn_head_.capacity() * 4 + dyn_touched_.capacity() * sizeof(size_t) +
         dyn_nodes_.capacity() * sizeof(Node) + stamp_.capacity() * 4;
}

// ---------------------------------------------------------------------------------------------
// ContinuousWorld

namespace {
std::vector<vadop::Motion> initialMotions(const Scene& s) {
  std::vector<vadop::Motion> m(s.position.size());
  for (size_t i = 0; i < m.size(); ++i) {
    m[i].t_ref = 0.0;
    m[i].position = s.position[i];
    m[i].linear_velocity = s.velocity[i];
  }
  return m;
}
}  // namespace

ContinuousWorld::ContinuousWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp, RequeryMode mode)
    : ContinuousWorld(scene, initialMotions(scene), std::move(bp), mode) {}

ContinuousWorld::ContinuousWorld(const Scene& scene, const std::vector<vadop::Motion>& motions,
                                 std::unique_ptr<vadop::BroadPhase> bp, RequeryMode mode)
    : scene_(scene),
      n_(static_cast<uint32_t>(scene.params.n)),
      dt_(1.0 / scene.params.fps),
      wall_(scene.half - scene.params.radius),
      narrow_shape_(std::make_shared<const vadop::Shape>(vadop::makeSphere(scene.params.radius))),
      broad_shape_(std::make_shared<const vadop::Shape>(
          vadop::inflate(vadop::makeSphere(scene.params.radius), kBroadPadding))),
      narrow_prepared_(*narrow_shape_),
      bp_(std::move(bp)),
      mode_(mode),
      motions_(motions) {
  scene_.position.clear();
  scene_.velocity.clear();
  if (bp_->size() != 0) throw std::logic_error("ContinuousWorld: the broad phase must be empty");
  if (motions_.size() != n_) throw std::invalid_argument("ContinuousWorld: one motion per sphere needed");
  kin_.resize(n_);
  moved_flag_.assign(n_, 0);
  for (uint32_t i = 0; i < n_; ++i) {
    // The spheres only translate: the compact copy (and mayTouch) hold no rotation.
    if (motions_[i].isRotating()) throw std::invalid_argument("ContinuousWorld: body " + std::to_string(i) + " rotates");
    kin_[i] = Kinematics{motions_[i].position, motions_[i].t_ref, motions_[i].linear_velocity};
  }
  for (uint32_t i = 0; i < n_; ++i) {
    if (bp_->add(broad_shape_, motions_[i]) != i) throw std::logic_error("ContinuousWorld: unexpected body id");
  }
}

size_t ContinuousWorld::memoryBytes() const {
  return queue_.memoryBytes() + grid_.memoryBytes() + motions_.capacity() * sizeof(vadop::Motion) +
         kin_.capacity() * sizeof(Kinematics) +
         boxes_.capacity() * sizeof(Box);
}

bool ContinuousWorld::mayTouch(uint32_t a, uint32_t b, double ts, double t1) const {
  const Kinematics& ka = kin_[a];
  const Kinematics& kb = kin_[b];
  // Relative position d(s) = d0 + w s for s in [0, t1 - ts]; its least norm against the sum of
  // the radii plus two tolerances (the narrow phase hits at a gap <= one tolerance; rounding
  // here is ~1e-13 m, far below the tolerance).
  const Eigen::Vector3d d0 = (kb.p + kb.v * (ts - kb.t_ref)) - (ka.p + ka.v * (ts - ka.t_ref));
  const Eigen::Vector3d w = kb.v - ka.v;
  const double ww = w.squaredNorm();
  const double s = ww > 0.0 ? std::clamp(-d0.dot(w) / ww, 0.0, t1 - ts) : 0.0;
  const double reach = 2.0 * scene_.params.radius + 2.0 * kToiTolerance;
  return (d0 + w * s).squaredNorm() <= reach * reach;
}

void ContinuousWorld::predictPair(uint32_t a, uint32_t b, double ts, double t1) {
  // The ground-truth run (RequeryMode::kScan) calls the narrow phase on every pair, so the
  // comparison with it also checks that the cull never drops a hit.
  if (mode_ == RequeryMode::kGrid && !mayTouch(a, b, ts, t1)) return;
  const vadop::Impact imp = vadop::timeOfImpact(narrow_prepared_, motions_[a], narrow_prepared_, motions_[b], ts, t1);
  if (!imp.hit) return;
  if (imp.initially_touching) {
    // Touching at ts: an impact only if they approach (a pair that just responded separates).
    const double rel = (motions_[b].linear_velocity - motions_[a].linear_velocity).dot(imp.normal);
    if (rel >= 0.0) return;
  }
  queue_.push(a, b, imp);
}

Box ContinuousWorld::pathBox(uint32_t i, double ta, double tb) const {
  return segmentBox(kin_[i].at(ta), kin_[i].at(tb), broad_shape_->bounding_radius);
}

void ContinuousWorld::predictWall(uint32_t i, double ts, double t1) {
  const Kinematics& m = kin_[i];
  const Eigen::Vector3d p = m.at(ts);
  const Eigen::Vector3d& v = m.v;
  double best = std::numeric_limits<double>::infinity();
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    double tk;
    if (v[k] > 0.0) {
      tk = p[k] >= wall_ ? 0.0 : (wall_ - p[k]) / v[k];
    } else if (v[k] < 0.0) {
      tk = p[k] <= -wall_ ? 0.0 : (-wall_ - p[k]) / v[k];
    } else {
      continue;
    }
    if (tk < best) {
      best = tk;
      axis = k;
    }
  }
  if (axis < 0 || ts + best > t1) return;
  vadop::Impact imp;
  imp.hit = true;
  imp.time = ts + best;
  imp.normal = Eigen::Vector3d::Zero();
  imp.normal[axis] = v[axis] > 0 ? 1.0 : -1.0;
  imp.point = m.at(imp.time);
  queue_.push(i, n_ + i, imp);
}

void ContinuousWorld::setMotion(uint32_t i, const Eigen::Vector3d& v, double tc) {
  vadop::Motion& m = motions_[i];
  m.position = m.positionAt(tc);
  m.t_ref = tc;
  m.linear_velocity = v;
  kin_[i] = Kinematics{m.position, m.t_ref, m.linear_velocity};
  bp_->setMotion(i, m);  // takes effect at the next frame's update()
  if (mode_ == RequeryMode::kGrid) {
    grid_.moved(i, pathBox(i, tc, frame_t1_));
    if (!moved_flag_[i]) {
      moved_flag_[i] = 1;
      moved_since_build_.push_back(i);
    }
  }
}

void ContinuousWorld::prepareRequeryGrid(int f) {
  // At the frame's first event no body has changed yet this frame, so a body's remaining path
  // is its frame path. Slow scenes keep the grid for several frames: a body that has not
  // changed velocity since the build is still on the path whose box was listed (the box of its
  // motion over all those frames); the bodies that have changed are listed anew with the box
  // of this frame. Rebuilt when the lead runs out or a quarter of the bodies have changed.
  const double t0 = f * dt_, t1 = (f + 1) * dt_;
  if (f >= grid_first_frame_ && f < grid_last_frame_ && moved_since_build_.size() <= n_ / 4) {
    for (uint32_t i : moved_since_build_) grid_.moved(i, pathBox(i, t0, t1));
    return;
  }
  // Lead: as many frames as keep a typical box within two radii of its frame box (1 in fast
  // scenes: rebuilt every frame), at most kMaxGridFrames.
  constexpr int kMaxGridFrames = 16;
  std::vector<double> speeds;
  const size_t stride = std::max<size_t>(1, n_ / 1024);
  for (size_t i = 0; i < n_; i += stride) speeds.push_back(motions_[i].linear_velocity.norm());
  std::nth_element(speeds.begin(), speeds.begin() + speeds.size() / 2, speeds.end());
  const double step = speeds.empty() ? 0.0 : speeds[speeds.size() / 2] * dt_;
  const double frames = step > 0.0 ? 2.0 * scene_.params.radius / step : kMaxGridFrames;
  const int lead = std::max(1, static_cast<int>(std::min<double>(frames, kMaxGridFrames)));
  grid_first_frame_ = f;
  grid_last_frame_ = f + lead;
  const double t_end = grid_last_frame_ * dt_;  // the end of frame f + lead - 1, as runFrame computes it
  boxes_.resize(n_);
  for (uint32_t i = 0; i < n_; ++i) boxes_[i] = pathBox(i, t0, t_end);
  grid_.build(boxes_, scene_.half);
  for (uint32_t i : moved_since_build_) moved_flag_[i] = 0;
  moved_since_build_.clear();
}

void ContinuousWorld::requery(uint32_t i, double tc, double t1, std::vector<uint32_t>& out) {
  out.clear();
  if (mode_ == RequeryMode::kGrid) {
    grid_.query(i, pathBox(i, tc, t1), out);
    return;
  }
  // Exhaustive: the exact swept-capsule test of BruteForceBroadPhase against every body.
  const double rb = broad_shape_->bounding_radius;
  const Eigen::Vector3d p0 = motions_[i].positionAt(tc), p1 = motions_[i].positionAt(t1);
  const double reach = 2.0 * rb * (1.0 + 1e-12) + 1e-12;
  for (uint32_t k = 0; k < n_; ++k) {
    if (k == i) continue;
    const Eigen::Vector3d q0 = motions_[k].positionAt(tc), q1 = motions_[k].positionAt(t1);
    if (vadop::segmentSegmentDistanceSquared(p0, p1, q0, q1) <= reach * reach) out.push_back(k);
  }
}

void ContinuousWorld::runFrame(int f, FrameStats& st, std::vector<LoggedImpact>* log) {
  st = FrameStats{};
  const double cpu0 = threadCpuSeconds();
  const double t0 = f * dt_, t1 = (f + 1) * dt_;
  frame_t1_ = t1;

  // 1. Broad phase.
  const auto c0 = Clock::now();
  bp_->update(t0, t1);
  const auto c1 = Clock::now();
  st.update_s = broadPhaseUpdateSeconds(*bp_);
  st.sort_s = std::max(0.0, seconds(c0, c1) - st.update_s);
  if (const auto* sp = dynamic_cast<const vadop::SweepPruneBroadPhase*>(bp_.get())) {
    st.sp_endpoints = sp->stats().endpoints;
    st.sp_swaps = sp->stats().swaps;
    st.sp_overlap_tests = sp->stats().overlap_tests;
    st.sp_reinserted = sp->stats().reinserted;
  }
  const std::vector<vadop::Pair>& pairs = bp_->pairs();
  st.candidates = pairs.size();

  // 2. Narrow phase on every candidate.
  queue_.clear();
  for (const vadop::Pair& p : pairs) predictPair(p.a, p.b, t0, t1);
  const auto c2 = Clock::now();
  st.test_s = seconds(c1, c2);

  // 3. Responses in time order.
  double test_in_loop = 0.0;
  for (uint32_t i = 0; i < n_; ++i) predictWall(i, t0, t1);
  grid_built_ = false;
  const size_t max_events = 64 * static_cast<size_t>(n_) + 10000;
  size_t events = 0;
  uint32_t changed[2];
  while (!queue_.empty()) {
    const vadop::QueuedImpact q = queue_.pop();
    if (++events > max_events) throw std::runtime_error("runaway response loop in frame " + std::to_string(f));
    const double tc = q.impact.time;
    if (mode_ == RequeryMode::kGrid && !grid_built_) {
      const auto g0 = Clock::now();
      prepareRequeryGrid(f);
      grid_built_ = true;
      st.requery_s += seconds(g0, Clock::now());
    }
    int nchanged;
    if (q.b >= n_) {  // wall
      const uint32_t i = static_cast<uint32_t>(q.a);
      int axis = 0;
      q.impact.normal.cwiseAbs().maxCoeff(&axis);
      Eigen::Vector3d v = motions_[i].linear_velocity;
      v[axis] = -v[axis];
      queue_.invalidate(i);
      setMotion(i, v, tc);
      changed[0] = i;
      nchanged = 1;
      ++st.wall_hits;
    } else {
      const uint32_t a = static_cast<uint32_t>(q.a), b = static_cast<uint32_t>(q.b);
      const Eigen::Vector3d& nrm = q.impact.normal;  // from a to b
      const Eigen::Vector3d va = motions_[a].linear_velocity, vb = motions_[b].linear_velocity;
      const double ua = va.dot(nrm), ub = vb.dot(nrm);
      // Equal masses, elastic: exchange the normal components.
      queue_.invalidate(a);
      queue_.invalidate(b);
      setMotion(a, va + (ub - ua) * nrm, tc);
      setMotion(b, vb + (ua - ub) * nrm, tc);
      if (log) log->push_back(LoggedImpact{a, b, tc});
      ++st.impacts;
      changed[0] = a;
      changed[1] = b;
      nchanged = 2;
    }
    for (int c = 0; c < nchanged; ++c) {
      const uint32_t i = changed[c];
      const auto r0 = Clock::now();
      requery(i, tc, t1, scratch_);
      const auto r1 = Clock::now();
      ++st.requeried;
      for (uint32_t k : scratch_) {
        if (c == 1 && k == changed[0]) continue;  // the pair was predicted from the other side
        predictPair(i, k, tc, t1);
        ++st.requery_pairs;
      }
      const auto r2 = Clock::now();
      st.requery_s += seconds(r0, r1);
      test_in_loop += seconds(r1, r2);
      predictWall(i, tc, t1);
    }
  }
  const auto c3 = Clock::now();
  st.test_s += test_in_loop;
  st.response_s = seconds(c2, c3) - test_in_loop;
  st.cpu_s = threadCpuSeconds() - cpu0;
}

// ---------------------------------------------------------------------------------------------
// DiscreteWorld

DiscreteWorld::DiscreteWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp)
    : scene_(scene),
      n_(static_cast<uint32_t>(scene.params.n)),
      dt_(1.0 / scene.params.fps),
      r_(scene.params.radius),
      wall_(scene.half - scene.params.radius),
      bp_(std::move(bp)),
      motions_(initialMotions(scene)) {
  scene_.position.clear();
  scene_.velocity.clear();
  const auto shape = std::make_shared<const vadop::Shape>(vadop::makeSphere(scene.params.radius));
  for (uint32_t i = 0; i < n_; ++i) {
    if (bp_->add(shape, motions_[i]) != i) throw std::logic_error("DiscreteWorld: unexpected body id");
  }
}

void DiscreteWorld::runFrame(int f, FrameStats& st, std::vector<vadop::Pair>& detected) {
  st = FrameStats{};
  const double cpu0 = threadCpuSeconds();
  detected.clear();
  const double t0 = f * dt_, t1 = (f + 1) * dt_;
  const auto c0 = Clock::now();
  bp_->update(t0, t1);  // the adapter bounds the pose at t1 only
  const auto c1 = Clock::now();
  st.update_s = broadPhaseUpdateSeconds(*bp_);
  st.sort_s = std::max(0.0, seconds(c0, c1) - st.update_s);
  st.candidates = bp_->pairs().size();
  const double reach2 = 4.0 * r_ * r_;
  for (const vadop::Pair& p : bp_->pairs()) {
    if ((motions_[p.b].positionAt(t1) - motions_[p.a].positionAt(t1)).squaredNorm() <= reach2) detected.push_back(p);
  }
  const auto c2 = Clock::now();
  st.test_s = seconds(c1, c2);
  // Responses at the frame pose.
  std::vector<uint32_t> changed;
  std::vector<Eigen::Vector3d> v(n_);
  std::vector<uint8_t> is_changed(n_, 0);
  auto velocity = [&](uint32_t i) -> Eigen::Vector3d& {
    if (!is_changed[i]) {
      is_changed[i] = 1;
      v[i] = motions_[i].linear_velocity;
      changed.push_back(i);
    }
    return v[i];
  };
  for (const vadop::Pair& p : detected) {
    const Eigen::Vector3d d = motions_[p.b].positionAt(t1) - motions_[p.a].positionAt(t1);
    const double len = d.norm();
    if (len <= 0.0) continue;
    const Eigen::Vector3d nrm = d / len;
    Eigen::Vector3d& va = velocity(p.a);
    Eigen::Vector3d& vb = velocity(p.b);
    const double ua = va.dot(nrm), ub = vb.dot(nrm);
    if (ub - ua >= 0.0) continue;  // separating already
    va += (ub - ua) * nrm;
    vb += (ua - ub) * nrm;
    ++st.impacts;
  }
  for (uint32_t i = 0; i < n_; ++i) {
    const Eigen::Vector3d p = motions_[i].positionAt(t1);
    const Eigen::Vector3d& cur = is_changed[i] ? v[i] : motions_[i].linear_velocity;
    for (int k = 0; k < 3; ++k) {
      if ((p[k] > wall_ && cur[k] > 0) || (p[k] < -wall_ && cur[k] < 0)) {
        Eigen::Vector3d& vi = velocity(i);
        vi[k] = -vi[k];
        ++st.wall_hits;
      }
    }
  }
  for (uint32_t i : changed) {
    vadop::Motion& m = motions_[i];
    m.position = m.positionAt(t1);
    m.t_ref = t1;
    m.linear_velocity = v[i];
    bp_->setMotion(i, m);
  }
  st.response_s = seconds(c2, Clock::now());
  st.cpu_s = threadCpuSeconds() - cpu0;
}

}  // namespace vadop_bench
