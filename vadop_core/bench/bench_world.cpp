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

vadop::ToiOptions toiOptions() {
  vadop::ToiOptions o;
  o.tolerance = kToiTolerance;
  return o;
}
}  // namespace

ContinuousWorld::ContinuousWorld(const Scene& scene, std::unique_ptr<vadop::BroadPhase> bp)
    : ContinuousWorld(scene, initialMotions(scene), std::move(bp)) {}

ContinuousWorld::ContinuousWorld(const Scene& scene, const std::vector<vadop::Motion>& motions,
                                 std::unique_ptr<vadop::BroadPhase> bp)
    : n_(static_cast<uint32_t>(scene.params.n)),
      dt_(1.0 / scene.params.fps),
      wall_(scene.half - scene.params.radius),
      loop_(std::move(bp), toiOptions()) {
  if (motions.size() != n_) throw std::invalid_argument("ContinuousWorld: one motion per sphere needed");
  const auto sphere = std::make_shared<const vadop::Shape>(vadop::makeSphere(scene.params.radius));
  for (uint32_t i = 0; i < n_; ++i) {
    if (motions[i].isRotating()) throw std::invalid_argument("ContinuousWorld: body " + std::to_string(i) + " rotates");
    if (loop_.add(sphere, motions[i]) != i) throw std::logic_error("ContinuousWorld: unexpected body id");
  }
  loop_.setBoundary([this](vadop::BodyId id, const vadop::Motion& m, double from, double t1) {
    return wallContact(id, m, from, t1);
  });
}

std::vector<vadop::Motion> ContinuousWorld::motions() const {
  std::vector<vadop::Motion> m(n_);
  for (uint32_t i = 0; i < n_; ++i) m[i] = loop_.motion(i);
  return m;
}

vadop::TimeOfImpact ContinuousWorld::wallContact(vadop::BodyId, const vadop::Motion& m, double from, double t1) const {
  // The centre reaches a wall plane (|x_k| = wall_) moving outwards; the earliest axis.
  const Eigen::Vector3d p = m.positionAt(from);
  const Eigen::Vector3d& v = m.linear_velocity;
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
  vadop::TimeOfImpact imp;
  if (axis < 0 || from + best > t1) return imp;
  imp.hit = true;
  imp.time = from + best;
  imp.normal = Eigen::Vector3d::Zero();
  imp.normal[axis] = v[axis] > 0 ? 1.0 : -1.0;
  imp.point = m.positionAt(imp.time);
  return imp;
}

void ContinuousWorld::runFrame(int f, FrameStats& st, std::vector<LoggedImpact>* log) {
  st = FrameStats{};
  const double cpu0 = threadCpuSeconds();
  const double t0 = f * dt_, t1 = (f + 1) * dt_;
  const auto start = Clock::now();
  const vadop::ResponseLoop::Stats ls =
      loop_.advance(t0, t1, [log](const vadop::ResponseLoop::Contact& c, vadop::ResponseLoop::Response& r) {
        const double tc = c.impact.time;
        auto from = [tc](const vadop::Motion& m, const Eigen::Vector3d& v) {
          vadop::Motion next = m;
          next.position = m.positionAt(tc);
          next.t_ref = tc;
          next.linear_velocity = v;
          return next;
        };
        if (c.b == vadop::ResponseLoop::kBoundary) {  // wall: reflect
          int axis = 0;
          c.impact.normal.cwiseAbs().maxCoeff(&axis);
          const vadop::Motion& m = r.motion(c.a);
          Eigen::Vector3d v = m.linear_velocity;
          v[axis] = -v[axis];
          r.setMotion(c.a, from(m, v));
          return;
        }
        // Equal masses, elastic: exchange the normal components (the normal from a to b).
        const vadop::Motion& ma = r.motion(c.a);
        const vadop::Motion& mb = r.motion(c.b);
        const Eigen::Vector3d& nrm = c.impact.normal;
        const Eigen::Vector3d va = ma.linear_velocity, vb = mb.linear_velocity;
        const double ua = va.dot(nrm), ub = vb.dot(nrm);
        const vadop::Motion na = from(ma, va + (ub - ua) * nrm), nb = from(mb, vb + (ua - ub) * nrm);
        r.setMotion(c.a, na);
        r.setMotion(c.b, nb);
        if (log) log->push_back(LoggedImpact{c.a, c.b, tc});
      });
  const double total = std::chrono::duration<double>(Clock::now() - start).count();
  const vadop::BroadPhase& bp = loop_.broadPhase();
  st.update_s = broadPhaseUpdateSeconds(bp);
  st.sort_s = std::max(0.0, ls.update_seconds - st.update_s);
  st.test_s = ls.narrow_seconds;
  st.requery_s = ls.query_seconds;
  st.response_s = std::max(0.0, total - ls.update_seconds - ls.narrow_seconds);
  if (const auto* sp = dynamic_cast<const vadop::SweepPruneBroadPhase*>(&bp)) {
    st.sp_endpoints = sp->stats().endpoints;
    st.sp_swaps = sp->stats().swaps;
    st.sp_overlap_tests = sp->stats().overlap_tests;
    st.sp_reinserted = sp->stats().reinserted;
  }
  st.candidates = ls.candidates;
  st.requeried = ls.requeried;
  st.requery_pairs = ls.narrow - ls.candidates;
  st.wall_hits = ls.boundary_contacts;
  st.impacts = ls.contacts - ls.boundary_contacts;
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
