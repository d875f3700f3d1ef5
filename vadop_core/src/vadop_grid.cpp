#include "vadop/vadop_grid.h"

#include "axis_set.h"
#include "cell_grid.h"
#include "fat_box_pairs.h"
#include "grid_cells.h"
#include "popcount.h"
#include "vadop/detail/parallel_for.h"
#include "vadop/error.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

// Why the candidate set is exactly {swept AABBs overlap and intervals overlap on every shared
// pool axis}, each pair once:
//  - Two bodies whose boxes overlap share the cell holding the lo corner of the boxes'
//    intersection (both boxes contain that point), and the floor of a maximum is the maximum of
//    the floors, so that cell is (max of the two lo-corner cells) per axis: a pair is tested in
//    that cell only. Cells are found by exact integer coordinates (cell_grid.h), so two far
//    cells never merge.
//  - A body whose box spans more than CellGrid::kMaxCells cells is not put in the grid but tested
//    against every body: a few huge or very fast bodies cannot blow up the grid's memory.
namespace vadop {
namespace {

// Cell size choice (computePairs, step 3): cost of one (body, cell) incidence in box tests
// (measured with callgrind on the benchmark's scenes: ~120 instructions against ~15), and
// how many bodies the estimate looks at.
constexpr double kIncidenceCost = 8.0;
constexpr size_t kSample = 1024;
// Cells with more bodies than this are swept along x rather than tested pair by pair.
constexpr uint32_t kSweepMin = 8;
// Threads for worlds of at least this many bodies; bodies taken a few at a time, and blocks of
// cells (or of slots) per thread: cell loads vary, a few blocks each balance them.
constexpr size_t kParallelBodies = 512;
constexpr size_t kBodyChunk = 32;
constexpr size_t kBlocksPerThread = 8;
constexpr double kInf = std::numeric_limits<double>::infinity();
using detail::CellGrid;

}  // namespace

VadopGridBroadPhase::VadopGridBroadPhase(const VadopConfig& config, double cell_size, double incremental)
    : config_(config) {
  setOptions(cell_size, incremental);
  pool_ = makeAxisPool(config.axes);
  phi_ = validateVadopConfig(config_, *pool_);
  zones_ = axisZones(config_, phi_);
  words_ = (static_cast<size_t>(pool_->size()) + 63) / 64;
}

VadopGridBroadPhase::VadopGridBroadPhase(BoxOnly, double cell_size, double incremental) {
  setOptions(cell_size, incremental);
  words_ = 1;  // every axis set stays empty: the boxes alone decide
}

std::unique_ptr<VadopGridBroadPhase> VadopGridBroadPhase::makeBoxOnly(double cell_size, double incremental) {
  return std::unique_ptr<VadopGridBroadPhase>(new VadopGridBroadPhase(BoxOnly{}, cell_size, incremental));
}

VadopGridBroadPhase::~VadopGridBroadPhase() = default;

void VadopGridBroadPhase::setOptions(double cell_size, double incremental) {
  fat_ = std::make_unique<FatBoxPairs>();
  grid_ = std::make_unique<CellGrid>();
  if (!std::isfinite(cell_size) || cell_size < 0.0) {
    throw InvalidArgument("cell_size must be finite and >= 0 (0 = automatic), got " + formatNumber(cell_size));
  }
  if (!(incremental >= 0.0 && incremental <= 1.0)) {
    throw InvalidArgument("incremental must be in [0, 1] (0 = off), got " + formatNumber(incremental));
  }
  incremental_ = incremental;
  cell_size_ = cell_size;
}

const AxisPool& VadopGridBroadPhase::pool() const {
  if (!pool_) throw InvalidArgument("pool: the box-only grid has no axis pool");
  return *pool_;
}

size_t VadopGridBroadPhase::memoryBytes() const {
  size_t bytes = axis_bits_.capacity() * sizeof(uint64_t) + axis_direction_.capacity() * sizeof(Eigen::Vector3d) +
                 dirty_flag_.capacity() +
                 (dirty_.capacity() + scratch_changed_.capacity()) * sizeof(BodyId);
  bytes += (slot_body_.capacity() + slot_of_.capacity() + offset_.capacity()) * sizeof(uint32_t) +
           box_.capacity() * sizeof(double) + bits_.capacity() * sizeof(uint64_t) +
           rank_.capacity() * sizeof(uint16_t) + intervals_.capacity() * sizeof(Interval);
  bytes += fat_->memoryBytes() + fat_ids_.capacity() * sizeof(BodyId) + fat_boxes_.capacity() * sizeof(double);
  bytes += grid_->memoryBytes() + (large_slots_.capacity() + scratch_slots_.capacity()) * sizeof(uint32_t);
  for (const SlotPairs& h : hits_) bytes += h.pairs.capacity() * sizeof(SlotPair);
  return bytes;
}

template <class F>
void VadopGridBroadPhase::forEachProjected(uint32_t s, const Motion& motion, F&& f) const {
  const SweptBody swept(*bodies()[slot_body_[s]].shape, motion, frame_t0_, frame_t1_);
  detail::forEachSetBit(&bits_[words_ * s], words_,
                        [&](uint32_t k) { f(k, swept.project(pool_->axis(static_cast<int>(k)))); });
}

std::vector<VadopGridBroadPhase::AxisSpan> VadopGridBroadPhase::volume(BodyId id) const {
  requireKnown(id, "volume");
  std::vector<AxisSpan> out;
  const uint32_t s = id < slot_of_.size() ? slot_of_[id] : kNoSlot;
  if (s == kNoSlot) return out;
  if (interval_ready_[s] == kIntervalsSet) {
    uint32_t i = 0;
    detail::forEachSetBit(&bits_[words_ * s], words_,
                          [&](uint32_t k) { out.push_back({k, intervals_[offset_[s] + i++]}); });
  } else {  // lazy and not needed by the update: projected with the update's motion
    const Motion& motion = interval_ready_[s] == kMotionKept ? update_motion_[s] : bodies()[id].motion;
    forEachProjected(s, motion, [&](uint32_t k, const Interval& iv) { out.push_back({k, iv}); });
  }
  const uint32_t m = pool_ ? static_cast<uint32_t>(pool_->size()) : 0;
  for (uint32_t k = 0; k < 3; ++k) out.push_back({m + k, Interval{box_[6 * s + k], box_[6 * s + 3 + k]}});
  return out;
}

Eigen::Vector3d VadopGridBroadPhase::axisDirection(uint32_t axis) const {
  const uint32_t m = pool_ ? static_cast<uint32_t>(pool_->size()) : 0;
  if (axis < m) return pool_->axis(static_cast<int>(axis));
  if (axis < m + 3) return Eigen::Vector3d::Unit(static_cast<int>(axis - m));
  throw InvalidArgument("axisDirection: axis " + std::to_string(axis) + " out of range [0, " +
                        std::to_string(m + 3) + ")");
}

void VadopGridBroadPhase::onAdd(BodyId id) {
  if (dirty_flag_.size() <= id) {
    axis_bits_.resize((id + 1) * words_, 0);
    axis_direction_.resize(id + 1, Eigen::Vector3d::Zero());
    dirty_flag_.resize(id + 1, 0);
    slot_of_.resize(id + 1, kNoSlot);
  }
  clearAxes(id);
  slot_of_[id] = kNoSlot;
  if (!dirty_flag_[id]) {
    dirty_flag_[id] = 1;
    dirty_.push_back(id);
  }
}

void VadopGridBroadPhase::onSetMotion(BodyId id) {
  // volume() reports the last update's intervals: keep a lazy slot's motion before it goes
  // (called before the base class stores the new motion).
  const uint32_t s = id < slot_of_.size() ? slot_of_[id] : kNoSlot;
  if (pool_ && s != kNoSlot && interval_ready_[s] == 0) {
    if (update_motion_.size() < interval_ready_.size()) update_motion_.resize(interval_ready_.size());
    update_motion_[s] = bodies()[id].motion;
    interval_ready_[s] = kMotionKept;
  }
  if (!dirty_flag_[id]) {
    dirty_flag_[id] = 1;
    dirty_.push_back(id);
  }
}

void VadopGridBroadPhase::projectSlot(uint32_t s) {
  Interval* out = intervals_.data() + offset_[s];
  forEachProjected(s, bodies()[slot_body_[s]].motion, [&](uint32_t, const Interval& iv) { *out++ = iv; });
  interval_ready_[s] = kIntervalsSet;
}

void VadopGridBroadPhase::clearAxes(BodyId id) { std::fill_n(&axis_bits_[id * words_], words_, 0); }

void VadopGridBroadPhase::onRemove(BodyId id) {
  clearAxes(id);
  fat_->remove(id);
  slot_of_[id] = kNoSlot;
  // A stale entry in dirty_ is harmless: the body is re-selected when the id is reused.
}

VADOP_POPCNT_CLONES
bool VadopGridBroadPhase::overlapOnShared(uint32_t a, uint32_t b) const {
  // No shared axis cannot happen with rho <= phi; if it did, the boxes alone decide.
  return detail::overlapOnSharedAxes(&bits_[a * words_], &rank_[a * words_], intervals_.data() + offset_[a],
                                     &bits_[b * words_], &rank_[b * words_], intervals_.data() + offset_[b], words_);
}

bool VadopGridBroadPhase::boxesOverlap(uint32_t a, uint32_t b) const {
  const double* x = &box_[6 * a];
  const double* y = &box_[6 * b];
  return !(x[0] > y[3] || y[0] > x[3] || x[1] > y[4] || y[1] > x[4] || x[2] > y[5] || y[2] > x[5]);
}

void VadopGridBroadPhase::boxHit(uint32_t a, uint32_t b, SlotPairs& hits) {
  ++hits.shared_tests;
  hits.pairs.push_back({a, b});
}

void VadopGridBroadPhase::testLargeAgainstAll(const std::vector<uint32_t>& large, SlotPairs& hits) {
  if (large.empty()) return;
  const uint32_t slots = static_cast<uint32_t>(slot_body_.size());
  std::vector<uint8_t>& is_large = scratch_large_;
  is_large.assign(slots, 0);
  for (uint32_t s : large) is_large[s] = 1;
  for (uint32_t l : large) {
    for (uint32_t s = 0; s < slots; ++s) {
      if (s == l || (is_large[s] && s < l)) continue;  // a pair of two large bodies once
      ++hits.box_tests;
      if (boxesOverlap(l, s)) boxHit(l, s, hits);
    }
  }
}

bool VadopGridBroadPhase::queryFrame(const double* q, std::vector<BodyId>& out) {
  if (!framed_) return false;
  const size_t slots = slot_body_.size();
  if (slots == 0) return true;
  auto boxesOverlap = [q](const double* x) {
    return !(x[0] > q[3] || q[0] > x[3] || x[1] > q[4] || q[1] > x[4] || x[2] > q[5] || q[2] > x[5]);
  };
  // A slot describes the frame volume of the body that held it (BroadPhase drops the bodies
  // removed, re-added or changed since).
  auto push = [&](uint32_t s) { out.push_back(slot_body_[s]); };
  if (!cells_ready_) {
    // Incremental mode: no cells this frame, but every slot's frame box lies in its body's fat
    // box, so the fat boxes that overlap the query (and the large ones) hold the answer.
    auto test = [&](BodyId id) {
      const uint32_t s = id < slot_of_.size() ? slot_of_[id] : kNoSlot;
      if (s != kNoSlot && boxesOverlap(&box_[6 * static_cast<size_t>(s)])) out.push_back(id);
    };
    fat_->forEachOverlap(q, test);
    for (BodyId id : fat_->large()) test(id);
    return true;
  }
  grid_->forEachOverlap(q, push);
  for (uint32_t s : grid_->large()) {
    if (boxesOverlap(&box_[6 * s])) push(s);
  }
  return true;
}

double VadopGridBroadPhase::chooseCellSize(const double* world_lo, const double* world_hi) {
  const size_t slots = slot_body_.size();
  double h = cell_size_;
  if (h == 0.0 && slots > 0) {
    std::vector<double>& e = scratch_extent_;
    e.resize(slots);
    for (size_t s = 0; s < slots; ++s) {
      const double* bx = &box_[6 * s];
      e[s] = std::max({bx[3] - bx[0], bx[4] - bx[1], bx[5] - bx[2]});
    }
    const size_t mid = e.size() / 2;
    std::nth_element(e.begin(), e.begin() + static_cast<long>(mid), e.end());
    const double median = e[mid];
    const double volume = (world_hi[0] - world_lo[0]) * (world_hi[1] - world_lo[1]) * (world_hi[2] - world_lo[2]);
    const size_t stride = std::max<size_t>(1, slots / kSample);
    double best = kInf;
    for (double factor : {0.5, 0.75, 1.0, 1.5, 2.0, 3.0}) {
      const double hc = factor * median;
      if (!(hc > 0.0)) continue;
      double incidences = 0.0;
      size_t sampled = 0;
      for (size_t i = 0; i < slots; i += stride, ++sampled) {
        const double* bx = &box_[6 * i];
        incidences += (1.0 + (bx[3] - bx[0]) / hc) * (1.0 + (bx[4] - bx[1]) / hc) * (1.0 + (bx[5] - bx[2]) / hc);
      }
      incidences *= static_cast<double>(slots) / static_cast<double>(sampled);
      const double cells = std::max(1.0, std::min(incidences, volume / (hc * hc * hc)));
      const double cost = kIncidenceCost * incidences + incidences * incidences / (2.0 * cells);
      if (cost < best) {
        best = cost;
        h = hc;
      }
    }
  }
  double max_abs = 0.0;
  for (int k = 0; k < 3; ++k) max_abs = std::max({max_abs, std::abs(world_lo[k]), std::abs(world_hi[k])});
  return std::max({h, max_abs / CellGrid::kMaxCoordinate, 1e-9});
}

void VadopGridBroadPhase::computePairs(double t0, double t1, std::vector<Pair>& out) {
  stats_ = Stats{};
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const double frame = t1 - t0;
  // How far the frames advance: the frame itself when they follow each other (the paper's
  // scene), less when they overlap (the monitor: 2 s windows every 1/30 s). The incremental
  // mode counts its fat boxes' lifetimes in these steps.
  const double step = framed_ && t0 > frame_t0_ && t0 - frame_t0_ < frame ? t0 - frame_t0_ : frame;
  const size_t slots = size();
  // Small worlds on this thread: below this, starting threads costs more than the work.
  const int threads = slots >= kParallelBodies ? this->threads() : 1;
  // The shared axes are tested after all pairs whose boxes overlap are found (testSharedAxes),
  // the intervals of their slots computed first in slot order: testing each pair as soon as
  // its boxes overlap, the intervals computed on first use in the pairs' order, reads the
  // bodies' motions and shapes out of order (the paper's scene at 10^5 bodies, one thread,
  // 6 rounds: the search 0.68x of that at fast speed, 0.78x slow, 0.88x medium).
  selectChangedAxes(frame, threads);
  assignSlots(t0, t1, slots, threads);
  auto grid_from = Clock::now();
  stats_.update_seconds = std::chrono::duration<double>(grid_from - start).count();
  if (slots < 2) {
    stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
    return;
  }
  // The pairs whose boxes overlap, per block of cells (or of slots), then on every shared axis.
  const size_t blocks = threads > 1 ? kBlocksPerThread * static_cast<size_t>(threads) : 1;
  hits_.resize(blocks + 1);  // the last for the large bodies
  for (SlotPairs& h : hits_) h.clear();

  // 2b. Incremental mode, while the scene is slow enough.
  if (incremental_ > 0.0 && computeFromFatBoxes(step, threads, blocks)) {
    testSharedAxes(threads, out);
    stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
    return;
  }
  buildCells(slots);
  testCellPairs(threads, blocks);
  // 5. Bodies too large for the grid: against every other body.
  testLargeAgainstAll(grid_->large(), hits_.back());
  testSharedAxes(threads, out);
  stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
}

void VadopGridBroadPhase::selectChangedAxes(double frame, int threads) {
  const auto& b = bodies();
  // 1. New axis sets for the bodies whose motion changed (kept under the hysteresis rule).
  std::vector<BodyId>& changed = scratch_changed_;
  changed.clear();
  for (BodyId id : dirty_) {
    if (id >= b.size() || !dirty_flag_[id]) continue;
    dirty_flag_[id] = 0;
    if (b[id].alive && pool_) changed.push_back(id);
  }
  dirty_.clear();
  std::atomic<size_t> reinserted{0};
  detail::parallelFor(threads, changed.size(), kParallelBodies / 2, kBodyChunk, [&](size_t i) {
    const BodyId id = changed[i];
    // A new motion along the same direction (a body turning about a fixed pivot, a new pose
    // along the same line) keeps its axes (axisSelectionDirection): no pool scan.
    const Eigen::Vector3d u = axisSelectionDirection(b[id].motion, b[id].shape->bounding_radius, frame, config_);
    uint64_t* bits = &axis_bits_[id * words_];
    if (u == axis_direction_[id] && std::any_of(bits, bits + words_, [](uint64_t w) { return w != 0; })) return;
    axis_direction_[id] = u;
    thread_local std::vector<uint32_t> axes;
    axes.clear();
    detail::forEachSetBit(bits, words_, [&](uint32_t k) { axes.push_back(k); });
    if (updateAxes(b[id].motion, b[id].shape->bounding_radius, frame, *pool_, config_, zones_, axes)) {
      reinserted.fetch_add(1, std::memory_order_relaxed);
      std::fill_n(bits, words_, 0);
      for (uint32_t k : axes) bits[k / 64] |= uint64_t{1} << (k % 64);
    }
  });
  stats_.reinserted = reinserted.load();
}

void VadopGridBroadPhase::assignSlots(double t0, double t1, size_t slots, int threads) {
  const auto& b = bodies();
  // 2. Per alive body, in id order: its slot (here), its swept AABB and axis ranks (on the
  //    threads), then where its pool-axis intervals go. The intervals are computed later, for
  //    the slots of pairs whose boxes overlap only (testSharedAxes).
  slot_body_.resize(slots);
  offset_.resize(slots);
  box_.resize(6 * slots);
  bits_.resize(words_ * slots);
  rank_.resize(words_ * slots);
  interval_ready_.assign(slots, 0);
  std::fill(slot_of_.begin(), slot_of_.end(), kNoSlot);
  frame_t0_ = t0;
  frame_t1_ = t1;
  framed_ = true;
  cells_ready_ = false;
  uint32_t next_slot = 0;
  for (BodyId id = 0; id < b.size(); ++id) {
    if (!b[id].alive) continue;
    slot_of_[id] = next_slot;
    slot_body_[next_slot++] = id;
  }
  const double* given = frameBoxes();
  detail::parallelFor(threads, slots, kParallelBodies / 2, kBodyChunk, [&](size_t s) {
    const BodyId id = slot_body_[s];
    if (given) {
      std::copy_n(given + 6 * static_cast<size_t>(id), 6, &box_[6 * s]);
    } else {
      SweptBody(*b[id].shape, b[id].motion, t0, t1).box(&box_[6 * s]);
    }
    uint64_t* bits = &bits_[words_ * s];
    std::copy_n(&axis_bits_[id * words_], words_, bits);
    detail::buildAxisRanks(bits, words_, &rank_[words_ * s]);
  });
  uint32_t next_interval = 0;
  for (size_t s = 0; s < slots; ++s) {
    offset_[s] = next_interval;
    next_interval += detail::axisCount(&bits_[words_ * s], &rank_[words_ * s], words_);
  }
  intervals_.resize(next_interval);
}

void VadopGridBroadPhase::buildCells(size_t slots) {
  // 3. Cell size, unless configured: the candidate (a multiple of the median box extent) with
  //    the least estimated cost, kIncidenceCost per (body, cell) incidence I(h) plus one per
  //    box test, about I^2 / (2 C) for C = min(I, volume / h^3) occupied cells. Large cells
  //    suit slow bodies (few incidences), small ones fast bodies (long boxes crowd a big cell).
  //    I(h) is estimated from at most kSample bodies. The boxes' bounds give the grid's extent.
  double world_lo[3] = {kInf, kInf, kInf}, world_hi[3] = {-kInf, -kInf, -kInf};
  for (size_t s = 0; s < slots; ++s) {
    for (int k = 0; k < 3; ++k) {
      world_lo[k] = std::min(world_lo[k], box_[6 * s + k]);
      world_hi[k] = std::max(world_hi[k], box_[6 * s + 3 + k]);
    }
  }
  const double h = chooseCellSize(world_lo, world_hi);
  stats_.cell_size = h;
  grid_->build(box_.data(), slots, h);
  stats_.cells = grid_->cellCount();
  stats_.cell_entries = grid_->entryCount();
  stats_.large_bodies = grid_->large().size();
  cells_ready_ = true;
}

void VadopGridBroadPhase::testCellPairs(int threads, size_t blocks) {
  // 4. Pairs of each cell, each reported in the cell of its boxes' common lo corner. A crowded
  //    cell is swept along x first (sorted by box lo x, a body meets only those that start
  //    before its box ends), a small one tested pair by pair. Blocks of cells on the threads.
  using Entry = CellGrid::Entry;
  CellGrid& grid = *grid_;
  const size_t cells = grid.cellCount();
  detail::parallelFor(threads, blocks, 1, 1, [&](size_t block) {
    SlotPairs& hits = hits_[block];
    auto test = [&](const Entry& x, const Entry& y, const CellGrid::Cell& cell) {
      if (std::max(x.lo_cell[0], y.lo_cell[0]) != cell.x || std::max(x.lo_cell[1], y.lo_cell[1]) != cell.y ||
          std::max(x.lo_cell[2], y.lo_cell[2]) != cell.z) {
        return;  // tested in another cell they share
      }
      ++hits.box_tests;
      if (x.box[0] > y.box[3] || y.box[0] > x.box[3] || x.box[1] > y.box[4] || y.box[1] > x.box[4] ||
          x.box[2] > y.box[5] || y.box[2] > x.box[5]) {
        return;
      }
      boxHit(x.item, y.item, hits);
    };
    for (size_t c = detail::blockBegin(cells, blocks, block), end = detail::blockBegin(cells, blocks, block + 1);
         c < end; ++c) {
      Entry* first = grid.entriesBegin(c);
      Entry* last = grid.entriesEnd(c);
      if (last - first < 2) continue;
      const CellGrid::Cell cell = grid.cell(c);
      if (last - first <= kSweepMin) {
        for (Entry* x = first; x + 1 < last; ++x) {
          for (Entry* y = x + 1; y < last; ++y) test(*x, *y, cell);
        }
        continue;
      }
      std::sort(first, last, [](const Entry& x, const Entry& y) { return x.box[0] < y.box[0]; });
      for (Entry* x = first; x + 1 < last; ++x) {
        for (Entry* y = x + 1; y < last && y->box[0] <= x->box[3]; ++y) test(*x, *y, cell);
      }
    }
  });
}

void VadopGridBroadPhase::testSharedAxes(int threads, std::vector<Pair>& out) {
  for (const SlotPairs& h : hits_) {
    stats_.box_tests += h.box_tests;
    stats_.overlap_tests += h.shared_tests;
  }
  if (pool_) {
    // The intervals of the slots that need them (each once), then the shared-axis tests; both
    // on the threads, each writing its own slots or its own block.
    // The slots in slot (= body id) order: their bodies' motions and shapes are then read in
    // the order they are stored (in the pairs' order each cost a few cache misses).
    constexpr uint8_t kWanted = 2;
    for (const SlotPairs& h : hits_) {
      for (const SlotPair& p : h.pairs) {
        for (uint32_t s : {p.a, p.b}) {
          if (!interval_ready_[s]) interval_ready_[s] = kWanted;
        }
      }
    }
    std::vector<uint32_t>& need = scratch_slots_;
    need.clear();
    for (uint32_t s = 0; s < interval_ready_.size(); ++s) {
      if (interval_ready_[s] != kWanted) continue;
      interval_ready_[s] = kIntervalsSet;  // set below, before anything reads it
      need.push_back(s);
    }
    detail::parallelFor(threads, need.size(), kParallelBodies / 2, kBodyChunk, [&](size_t i) { projectSlot(need[i]); });
  }
  // Each block's pairs in body order, on the threads (slots are in body order). The incremental
  // mode's blocks are ranges of the pairs' first slots, so their concatenation is sorted as
  // well and BroadPhase::update need not sort it again.
  detail::parallelFor(threads, hits_.size(), 1, 1, [&](size_t block) {
    std::vector<SlotPair>& pairs = hits_[block].pairs;
    if (pool_) {
      pairs.erase(std::remove_if(pairs.begin(), pairs.end(), [&](const SlotPair& p) { return !overlapOnShared(p.a, p.b); }),
                  pairs.end());
    }
    for (SlotPair& p : pairs) {
      if (p.b < p.a) std::swap(p.a, p.b);
    }
    std::sort(pairs.begin(), pairs.end(),
              [](const SlotPair& x, const SlotPair& y) { return x.a < y.a || (x.a == y.a && x.b < y.b); });
  });
  size_t large_from = 0;
  for (const SlotPairs& h : hits_) {
    large_from = out.size();
    for (const SlotPair& p : h.pairs) out.push_back(makePair(slot_body_[p.a], slot_body_[p.b]));
  }
  // The last block, the large bodies' pairs (a sensor's points span the room: one pair with
  // every body), is sorted on its own: merged into the others' when their concatenation is
  // sorted (the incremental mode), instead of BroadPhase::update sorting them all again.
  const auto large = out.begin() + static_cast<std::ptrdiff_t>(large_from);
  if (large != out.end() && std::is_sorted(out.begin(), large)) std::inplace_merge(out.begin(), large, out.end());
}

// Incremental mode. A body's fat box holds its swept box of this frame and, while its motion
// stays the same, those of the frames to come up to kFatFrames steps (how far the frames
// advance) or kFatReach times its half-extent of travel ahead, padded by kFatPad of its
// half-extent. While a body's swept box stays inside its fat box, its
// pairs of overlapping fat boxes (FatBoxPairs) stay valid, and every pair of overlapping swept
// boxes is among them (swept inside fat on both sides): the candidates are exactly those of the
// full path, found by testing the kept pairs. Bodies that left their fat boxes (new velocity,
// or simply far enough along) get new ones; when that is more than the fraction `incremental`
// of the bodies in a frame, the full path is cheaper and takes over.
namespace {
constexpr double kFatFrames = 32.0;
constexpr double kFatReach = 3.0;
constexpr double kFatPad = 0.1;

// Half the largest extent of a slot's swept box, and how far ahead in time (s) its fat box
// reaches at `speed`.
double halfExtent(const double* box) { return 0.5 * std::max({box[3] - box[0], box[4] - box[1], box[5] - box[2]}); }
double fatLead(double half, double speed, double step) {
  return speed > 0.0 ? std::min(kFatFrames * step, kFatReach * half / speed) : kFatFrames * step;
}
// A bound of the origin's speed: a body turning about a pivot at rest (a robot on an arc, as the
// monitor predicts it) travels though its linear velocity is zero.
double travelSpeed(const Motion& m) { return m.linear_velocity.norm() + m.angular_velocity.norm() * m.pivotArm(); }
}  // namespace

double VadopGridBroadPhase::expectedEscapeRate(double step) const {
  const size_t slots = slot_body_.size();
  if (slots == 0 || !(step > 0.0)) return 0.0;
  const size_t stride = std::max<size_t>(1, slots / kSample);
  double rate = 0.0;
  size_t sampled = 0;
  for (size_t s = 0; s < slots; s += stride, ++sampled) {
    const double speed = travelSpeed(bodies()[slot_body_[s]].motion);
    rate += 1.0 / std::max(1.0, fatLead(halfExtent(&box_[6 * s]), speed, step) / step);
  }
  return rate / static_cast<double>(sampled);
}

void VadopGridBroadPhase::appendFatBox(uint32_t s, double step) {
  // The body's swept box over the frame extended by its lead: it holds the swept box of every
  // later frame ending within the lead while the motion stays the same (re-referenced along
  // the same path included), turning bodies as well as straight ones.
  const Body& body = bodies()[slot_body_[s]];
  const double* t = &box_[6 * s];
  const double half = halfExtent(t);
  const double speed = travelSpeed(body.motion);
  double box[6];
  if (speed > 0.0) {
    SweptBody(*body.shape, body.motion, frame_t0_, frame_t1_ + fatLead(half, speed, step)).box(box);
  } else {
    std::copy_n(t, 6, box);
  }
  const double pad = kFatPad * half;
  for (int k = 0; k < 3; ++k) fat_boxes_.push_back(std::min(box[k], t[k]) - pad);
  for (int k = 0; k < 3; ++k) fat_boxes_.push_back(std::max(box[3 + k], t[3 + k]) + pad);
}

bool VadopGridBroadPhase::computeFromFatBoxes(double step, int threads, size_t blocks) {
  const size_t slots = slot_body_.size();
  fat_ids_.clear();
  fat_boxes_.clear();
  if (!fat_valid_) {
    if (retry_wait_ > 0) {
      --retry_wait_;
      return false;
    }
    if (!rebuildFatBoxes(step, threads)) return false;
  } else if (!refreshFatBoxes(step, threads)) {
    return false;
  }
  stats_.incremental = true;
  stats_.cell_size = fat_->cellSize();
  stats_.escaped = fat_ids_.size();
  stats_.fat_pairs = fat_->pairs();
  stats_.large_bodies = fat_->large().size();

  detail::parallelFor(threads, blocks, 1, 1, [&](size_t block) {
    SlotPairs& hits = hits_[block];
    for (uint32_t s = static_cast<uint32_t>(detail::blockBegin(slots, blocks, block)),
                  end = static_cast<uint32_t>(detail::blockBegin(slots, blocks, block + 1));
         s < end; ++s) {
      const BodyId id = slot_body_[s];
      for (const BodyId j : fat_->partners(id)) {
        if (j <= id) continue;
        const uint32_t t = slot_of_[j];
        ++hits.box_tests;
        if (boxesOverlap(s, t)) boxHit(s, t, hits);
      }
    }
  });
  large_slots_.clear();
  for (BodyId l : fat_->large()) large_slots_.push_back(slot_of_[l]);
  testLargeAgainstAll(large_slots_, hits_.back());
  return true;
}

bool VadopGridBroadPhase::rebuildFatBoxes(double step, int threads) {
  const size_t slots = slot_body_.size();
  // Worth building? At constant velocity a body leaves its fat box after about its lead time
  // in steps: estimate the share of bodies leaving per step on a sample, and stay with the
  // full path (asking again in a few frames) while it is over half the allowed fraction.
  if (incremental_ < 1.0 && expectedEscapeRate(step) > 0.5 * incremental_) {
    retry_wait_ = 8;
    return false;
  }
  // Build from scratch: cells twice the median fat box (or as configured), within the key
  // range of FatBoxPairs.
  std::vector<double>& extent = scratch_extent_;
  extent.resize(slots);
  double max_abs = 0.0;
  for (uint32_t s = 0; s < slots; ++s) {
    fat_ids_.push_back(slot_body_[s]);
    appendFatBox(s, step);
    const double* f = &fat_boxes_[6 * static_cast<size_t>(s)];
    extent[s] = std::max({f[3] - f[0], f[4] - f[1], f[5] - f[2]});
    for (int k = 0; k < 6; ++k) max_abs = std::max(max_abs, std::abs(f[k]));
  }
  const size_t mid = slots / 2;
  std::nth_element(extent.begin(), extent.begin() + static_cast<long>(mid), extent.end());
  const double h = cell_size_ > 0.0 ? cell_size_ : 2.0 * extent[mid];
  fat_->reset(std::max(h, 1e-9), max_abs);
  fat_->update(fat_ids_, fat_boxes_, threads);
  fat_valid_ = true;
  streak_ = 0;
  stats_.fat_rebuilt = true;
  return true;
}

bool VadopGridBroadPhase::refreshFatBoxes(double step, int threads) {
  const size_t slots = slot_body_.size();
  for (uint32_t s = 0; s < slots; ++s) {
    if (!fat_->contains(slot_body_[s], &box_[6 * s])) {
      fat_ids_.push_back(slot_body_[s]);
      appendFatBox(s, step);
    }
  }
  if (static_cast<double>(fat_ids_.size()) > incremental_ * static_cast<double>(slots)) {
    fat_valid_ = false;
    backoff_ = std::min(64, 2 * backoff_);
    retry_wait_ = backoff_;
    return false;
  }
  fat_->update(fat_ids_, fat_boxes_, threads);
  if (++streak_ >= 8) backoff_ = 1;
  if (fat_->wasteful()) {
    fat_valid_ = false;  // rebuilt at the next update (this frame's pairs are still exact)
    retry_wait_ = 0;
  }
  return true;
}

}  // namespace vadop
