#include "vadop/sweep_prune.h"

#include "vadop/error.h"
#include "axis_set.h"
#include "popcount.h"

#include <algorithm>
#include <chrono>
#include <cmath>

// How the candidate set stays exact (the invariant: a pair is in pairs_ iff the two bodies'
// intervals overlap on every axis they share, for the values the lists were last sorted with).
//  - A body whose axis set is unchanged keeps its endpoints; update() writes the new values and
//    insertion sort moves them. Only a swap of a min past a max changes whether two intervals
//    overlap on that axis. When one starts an overlap, the pair is tested on all shared axes
//    with the new values and added if they all overlap; when one ends an overlap, the pair is
//    dropped. After the last swap that touches a pair, its status is right: if it was an
//    overlap start, the full test saw the final values; if there was none on any axis, the
//    pair's per-axis status did not change and the invariant carried over.
//  - A body whose axis set changes (or that is new) changes which axes it shares with everyone,
//    which no swap reports. Such a body is taken out (its pairs erased, its endpoints marked
//    dead), and after the sort it is merged back into its new lists and its pairs are found by
//    querying each of its lists for intervals that overlap its own. Velocity alignment makes
//    this rare: an axis set changes only when the direction of motion turns by more than the
//    hysteresis, and fixed-axis modes never change sets.
namespace vadop {

SweepPruneBroadPhase::SweepPruneBroadPhase(const VadopConfig& config)
    : SweepPruneBroadPhase(makeAxisPool(config.axes), config, true) {}

SweepPruneBroadPhase::SweepPruneBroadPhase(std::unique_ptr<AxisPool> pool, const VadopConfig& config,
                                           bool aligned)
    : pool_(std::move(pool)), config_(config), aligned_(aligned) {
  if (aligned_) {
    phi_ = validateVadopConfig(config_, *pool_);
    zones_ = axisZones(config_, phi_);
  }
  const size_t m = pool_->size();
  lists_.resize(m);
  pending_.resize(m);
  max_length_.assign(m, 0.0);
}

std::unique_ptr<SweepPruneBroadPhase> SweepPruneBroadPhase::makeEveryAxis(int m) {
  VadopConfig config;
  config.axes = m;
  return std::unique_ptr<SweepPruneBroadPhase>(new SweepPruneBroadPhase(makeAxisPool(m), config, false));
}

std::string SweepPruneBroadPhase::name() const {
  if (aligned_) return "vadop";
  return pool_->size() == 3 ? "sap" : "kdop";
}

size_t SweepPruneBroadPhase::memoryBytes() const {
  size_t bytes = pairs_.memoryBytes() + states_.capacity() * sizeof(State) +
                 dirty_.capacity() * sizeof(BodyId);
  for (const auto& s : states_) bytes += s.entries.capacity() * sizeof(Entry);
  for (const auto& l : lists_) bytes += l.capacity() * sizeof(Endpoint);
  for (const auto& l : pending_) bytes += l.capacity() * sizeof(Endpoint);
  return bytes;
}

std::vector<SweepPruneBroadPhase::AxisSpan> SweepPruneBroadPhase::volume(BodyId id) const {
  requireKnown(id, "volume");
  std::vector<AxisSpan> out;
  const State& s = states_[id];
  if (!s.listed) return out;
  for (const Entry& e : s.entries) out.push_back({e.axis, Interval{e.lo, e.hi}});
  return out;
}

void SweepPruneBroadPhase::onAdd(BodyId id) {
  if (states_.size() <= id) states_.resize(id + 1);
  // The generation survives the id's reuse, so endpoints of its previous owner stay stale.
  const uint32_t generation = states_[id].generation;
  states_[id] = State{};
  states_[id].generation = generation;
  states_[id].dirty = true;
  dirty_.push_back(id);
}

void SweepPruneBroadPhase::onSetMotion(BodyId id) {
  if (!states_[id].dirty) {
    states_[id].dirty = true;
    dirty_.push_back(id);
  }
}

void SweepPruneBroadPhase::onRemove(BodyId id) {
  // Immediately, so that the id can be handed out again before the next update.
  if (states_[id].listed) unlist(id);
  const uint32_t generation = states_[id].generation;
  states_[id] = State{};
  states_[id].generation = generation;
  // A stale entry in dirty_ is skipped in computePairs (the body is not alive or is new).
}


VADOP_POPCNT_CLONES  // the hottest function of the engine counts bits
bool SweepPruneBroadPhase::overlapOnShared(BodyId a, BodyId b) {
  ++stats_.overlap_tests;
  const State& sa = states_[a];
  const State& sb = states_[b];
  // With rho <= phi two listed bodies always share an axis; sharing none would leave the
  // boxes to decide (the paper's rule), as overlapOnSharedAxes does.
  return detail::overlapOnSharedAxes(sa.axis_bits.data(), sa.rank.data(), sa.entries.data(), sb.axis_bits.data(),
                                     sb.rank.data(), sb.entries.data(), sa.axis_bits.size());
}

void SweepPruneBroadPhase::setAxes(State& s, const std::vector<uint32_t>& axes) {
  const size_t words = (pool_->size() + 63) / 64;
  s.entries.clear();
  s.axis_bits.assign(words, 0);
  s.rank.assign(words, 0);
  for (uint32_t k : axes) {
    s.entries.push_back(Entry{k, 0.0, 0.0});
    s.axis_bits[k / 64] |= uint64_t{1} << (k % 64);
  }
  detail::buildAxisRanks(s.axis_bits.data(), words, s.rank.data());
}

template <class F>
void SweepPruneBroadPhase::forEachOverlapOnAxis(BodyId id, const Entry& e, F&& f) const {
  // Every interval on this axis is at most max_length_ long, so one that overlaps [lo, hi]
  // has its min endpoint in [lo - max_length, hi]: a binary search and a short scan.
  const auto& list = lists_[e.axis];
  const double from = e.lo - max_length_[e.axis];
  auto it = std::lower_bound(list.begin(), list.end(), from,
                             [](const Endpoint& p, double v) { return p.value < v; });
  for (; it != list.end() && it->value <= e.hi; ++it) {
    if (it->isMax() || it->body == id || !isLive(*it)) continue;
    const Entry& other = states_[it->body].entries[it->entry()];
    if (other.hi < e.lo) continue;
    f(it->body);
  }
}

bool SweepPruneBroadPhase::queryFrame(const double* box, std::vector<BodyId>& out) {
  const Eigen::Vector3d centre(0.5 * (box[0] + box[3]), 0.5 * (box[1] + box[4]), 0.5 * (box[2] + box[5]));
  const Eigen::Vector3d half(0.5 * (box[3] - box[0]), 0.5 * (box[4] - box[1]), 0.5 * (box[5] - box[2]));
  const size_t m = pool_->size();
  std::vector<Interval> proj(m);  // the box on every pool axis, widened for rounding
  for (size_t k = 0; k < m; ++k) {
    const Eigen::Vector3d& a = pool_->axis(static_cast<int>(k));
    const double c = a.dot(centre), r = a.cwiseAbs().dot(half);
    const double widen = 1e-12 * (1.0 + std::abs(c) + r);
    proj[k] = Interval{c - r - widen, c + r + widen};
  }
  if (query_stamp_.size() < states_.size()) query_stamp_.resize(states_.size(), 0);
  if (++query_now_ == 0) {
    std::fill(query_stamp_.begin(), query_stamp_.end(), 0);
    query_now_ = 1;
  }
  const size_t scanned = aligned_ ? m : std::min<size_t>(m, 1);
  for (size_t k = 0; k < scanned; ++k) {
    const Entry probe{static_cast<uint32_t>(k), proj[k].lo, proj[k].hi};
    forEachOverlapOnAxis(~BodyId{0}, probe, [&](BodyId id) {
      if (query_stamp_[id] == query_now_) return;
      query_stamp_[id] = query_now_;
      for (const Entry& e : states_[id].entries) {
        if (e.lo > proj[e.axis].hi || proj[e.axis].lo > e.hi) return;
      }
      out.push_back(id);
    });
  }
  return true;
}

void SweepPruneBroadPhase::unlist(BodyId id) {
  State& s = states_[id];
  for (const Entry& e : s.entries) {
    forEachOverlapOnAxis(id, e, [&](BodyId other) { pairs_.erase(id, other); });
  }
  s.generation = (s.generation + 1) & 0x7ffffu;
  s.listed = false;
}

void SweepPruneBroadPhase::refresh(uint32_t axis) {
  auto& list = lists_[axis];
  size_t w = 0;
  for (size_t r = 0; r < list.size(); ++r) {
    Endpoint e = list[r];
    if (!isLive(e)) continue;
    const Entry& entry = states_[e.body].entries[e.entry()];
    e.value = e.isMax() ? entry.hi : entry.lo;
    list[w++] = e;
  }
  list.resize(w);
}

void SweepPruneBroadPhase::insertionSort(uint32_t axis) {
  auto& list = lists_[axis];
  const uint32_t n = static_cast<uint32_t>(list.size());
  for (uint32_t i = 1; i < n; ++i) {
    if (!before(list[i], list[i - 1])) continue;
    const Endpoint x = list[i];
    uint32_t j = i;
    do {
      const Endpoint& y = list[j - 1];
      if (!x.isMax() && y.isMax()) {
        // x's min moves left of y's max: the intervals start to overlap on this axis.
        if (overlapOnShared(x.body, y.body)) pairs_.insert(x.body, y.body);
      } else if (x.isMax() && !y.isMax()) {
        // x's max moves left of y's min: x now lies wholly below y on this axis.
        pairs_.erase(x.body, y.body);
      }
      list[j] = y;
      --j;
      ++stats_.swaps;
    } while (j > 0 && before(x, list[j - 1]));
    list[j] = x;
  }
}

void SweepPruneBroadPhase::mergePending(uint32_t axis) {
  auto& add = pending_[axis];
  if (add.empty()) return;
  std::sort(add.begin(), add.end(), [](const Endpoint& x, const Endpoint& y) { return before(x, y); });
  auto& list = lists_[axis];
  const size_t old_size = list.size();
  list.resize(old_size + add.size());
  // Merge from the back.
  size_t r = old_size, a = add.size(), w = list.size();
  while (a > 0) {
    --w;
    if (r > 0 && before(add[a - 1], list[r - 1])) {
      list[w] = list[--r];
    } else {
      list[w] = add[--a];
    }
  }
  add.clear();
}

void SweepPruneBroadPhase::computePairs(double t0, double t1, std::vector<Pair>& out) {
  stats_ = Stats{};
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto& b = bodies();
  const double frame = t1 - t0;

  // 1. Bodies whose motion changed: new axis set; take out those whose set changed.
  std::vector<BodyId> reinsert;
  for (BodyId id : dirty_) {
    if (id >= b.size() || !b[id].alive || !states_[id].dirty) continue;
    State& s = states_[id];
    s.dirty = false;
    std::vector<uint32_t> axes;  // its current set, then the new one
    axes.reserve(s.entries.size());
    for (const Entry& e : s.entries) axes.push_back(e.axis);
    bool changed = !s.listed;
    if (aligned_) {
      changed |= updateAxes(b[id].motion, b[id].shape->bounding_radius, frame, *pool_, config_, zones_, axes);
    } else if (!s.listed) {
      axes.resize(pool_->size());
      for (uint32_t k = 0; k < axes.size(); ++k) axes[k] = k;
    }
    if (!changed) continue;  // same lists: the sort below handles it
    if (s.listed) unlist(id);
    setAxes(s, axes);
    reinsert.push_back(id);
  }
  dirty_.clear();
  stats_.reinserted = reinsert.size();

  // 2. New intervals for every body over [t0, t1].
  std::fill(max_length_.begin(), max_length_.end(), 0.0);
  for (BodyId id = 0; id < b.size(); ++id) {
    if (!b[id].alive) continue;
    State& s = states_[id];
    const SweptBody swept(*b[id].shape, b[id].motion, t0, t1);
    for (uint32_t i = 0; i < s.entries.size(); ++i) {
      Entry& e = s.entries[i];
      const Interval iv = swept.project(pool_->axis(static_cast<int>(e.axis)));
      e.lo = iv.lo;
      e.hi = iv.hi;
      max_length_[e.axis] = std::max(max_length_[e.axis], iv.hi - iv.lo);
      if (!s.listed) {
        pending_[e.axis].push_back(Endpoint{iv.lo, id, makeRef(s.generation, i, false)});
        pending_[e.axis].push_back(Endpoint{iv.hi, id, makeRef(s.generation, i, true)});
      }
    }
  }

  const auto sorted_from = Clock::now();
  stats_.update_seconds = std::chrono::duration<double>(sorted_from - start).count();

  // 3. Per axis: drop stale endpoints and load the new values, re-sort (swaps maintain the pairs
  //    of bodies that stayed), then merge the re-inserted bodies' endpoints in.
  for (uint32_t k = 0; k < lists_.size(); ++k) {
    refresh(k);
    insertionSort(k);
    mergePending(k);
    stats_.endpoints += lists_[k].size();
  }
  for (BodyId id : reinsert) states_[id].listed = true;

  // 4. Pairs of the re-inserted bodies, found on each of their axes; a pair is reported from
  //    the first axis the two share only, and only if it overlaps on all of them.
  for (BodyId id : reinsert) {
    for (const Entry& e : states_[id].entries) {
      forEachOverlapOnAxis(id, e, [&](BodyId other) {
        // Bits first: the full interval test only on the one axis that reports the pair.
        if (detail::firstSharedAxis(states_[id].axis_bits.data(), states_[other].axis_bits.data(), states_[id].axis_bits.size()) != e.axis) return;
        if (overlapOnShared(id, other)) pairs_.insert(id, other);
      });
    }
  }

  pairs_.appendTo(out);
  stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - sorted_from).count();
}

}  // namespace vadop
