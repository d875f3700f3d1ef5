#include "vadop/vadop_grid.h"

#include "vadop/error.h"
#include "axis_set.h"
#include "cell_grid.h"
#include "fat_box_pairs.h"
#include "grid_cells.h"
#include "popcount.h"

#include <algorithm>
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
  size_t bytes = axis_bits_.capacity() * sizeof(uint64_t) + scratch_axes_.capacity() * sizeof(uint32_t) + dirty_flag_.capacity() +
                 dirty_.capacity() * sizeof(BodyId);
  bytes += (slot_body_.capacity() + slot_of_.capacity() + offset_.capacity()) * sizeof(uint32_t) +
           box_.capacity() * sizeof(double) + bits_.capacity() * sizeof(uint64_t) +
           rank_.capacity() * sizeof(uint16_t) + intervals_.capacity() * sizeof(Interval);
  bytes += fat_->memoryBytes() + fat_ids_.capacity() * sizeof(BodyId) + fat_boxes_.capacity() * sizeof(double);
  bytes += grid_->memoryBytes() + large_slots_.capacity() * sizeof(uint32_t);
  return bytes;
}

template <class F>
void VadopGridBroadPhase::forEachProjected(uint32_t s, F&& f) const {
  const Body& body = bodies()[slot_body_[s]];
  const SweptBody swept(*body.shape, body.motion, frame_t0_, frame_t1_);
  detail::forEachSetBit(&bits_[words_ * s], words_,
                        [&](uint32_t k) { f(k, swept.project(pool_->axis(static_cast<int>(k)))); });
}

std::vector<VadopGridBroadPhase::AxisSpan> VadopGridBroadPhase::volume(BodyId id) const {
  requireKnown(id, "volume");
  std::vector<AxisSpan> out;
  const uint32_t s = id < slot_of_.size() ? slot_of_[id] : kNoSlot;
  if (s == kNoSlot) return out;
  if (interval_ready_[s]) {
    uint32_t i = 0;
    detail::forEachSetBit(&bits_[words_ * s], words_,
                          [&](uint32_t k) { out.push_back({k, intervals_[offset_[s] + i++]}); });
  } else {  // lazy and not needed by the update; the motion is unchanged since (onSetMotion)
    forEachProjected(s, [&](uint32_t k, const Interval& iv) { out.push_back({k, iv}); });
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
  // volume() reports the last update's intervals: compute a lazy slot's before its motion goes.
  const uint32_t s = id < slot_of_.size() ? slot_of_[id] : kNoSlot;
  if (s != kNoSlot) requireIntervals(s);
  if (!dirty_flag_[id]) {
    dirty_flag_[id] = 1;
    dirty_.push_back(id);
  }
}

void VadopGridBroadPhase::projectSlot(uint32_t s) {
  Interval* out = intervals_.data() + offset_[s];
  forEachProjected(s, [&](uint32_t, const Interval& iv) { *out++ = iv; });
  interval_ready_[s] = 1;
}

void VadopGridBroadPhase::clearAxes(BodyId id) { std::fill_n(&axis_bits_[id * words_], words_, 0); }

void VadopGridBroadPhase::onRemove(BodyId id) {
  clearAxes(id);
  fat_->remove(id);
  slot_of_[id] = kNoSlot;
  // A stale entry in dirty_ is harmless: the body is re-selected when the id is reused.
}

VADOP_POPCNT_CLONES
bool VadopGridBroadPhase::overlapOnShared(uint32_t a, uint32_t b) {
  ++stats_.overlap_tests;
  // No shared axis cannot happen with rho <= phi; if it did, the boxes alone decide.
  return detail::overlapOnSharedAxes(&bits_[a * words_], &rank_[a * words_], intervals_.data() + offset_[a],
                                     &bits_[b * words_], &rank_[b * words_], intervals_.data() + offset_[b], words_);
}

void VadopGridBroadPhase::testPair(uint32_t a, uint32_t b, std::vector<Pair>& out) {
  ++stats_.box_tests;
  const double* x = &box_[6 * a];
  const double* y = &box_[6 * b];
  if (x[0] > y[3] || y[0] > x[3] || x[1] > y[4] || y[1] > x[4] || x[2] > y[5] || y[2] > x[5]) return;
  requireIntervals(a);
  requireIntervals(b);
  if (overlapOnShared(a, b)) out.push_back(makePair(slot_body_[a], slot_body_[b]));
}

VADOP_POPCNT_CLONES
size_t VadopGridBroadPhase::countAliveAxes() const {
  const auto& b = bodies();
  size_t n = 0;
  for (BodyId id = 0; id < b.size(); ++id) {
    if (!b[id].alive) continue;
    for (size_t w = 0; w < words_; ++w) n += static_cast<size_t>(__builtin_popcountll(axis_bits_[id * words_ + w]));
  }
  return n;
}

void VadopGridBroadPhase::testLargeAgainstAll(const std::vector<uint32_t>& large, std::vector<Pair>& out) {
  if (large.empty()) return;
  const uint32_t slots = static_cast<uint32_t>(slot_body_.size());
  std::vector<uint8_t>& is_large = scratch_large_;
  is_large.assign(slots, 0);
  for (uint32_t s : large) is_large[s] = 1;
  for (uint32_t l : large) {
    for (uint32_t s = 0; s < slots; ++s) {
      if (s == l || (is_large[s] && s < l)) continue;  // a pair of two large bodies once
      testPair(l, s, out);
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
  const auto& b = bodies();
  const double frame = t1 - t0;

  // 1. New axis sets for the bodies whose motion changed (kept under the hysteresis rule).
  for (BodyId id : dirty_) {
    if (id >= b.size() || !dirty_flag_[id]) continue;
    dirty_flag_[id] = 0;
    if (!b[id].alive || !pool_) continue;
    std::vector<uint32_t>& axes = scratch_axes_;
    axes.clear();
    uint64_t* bits = &axis_bits_[id * words_];
    detail::forEachSetBit(bits, words_, [&](uint32_t k) { axes.push_back(k); });
    if (updateAxes(b[id].motion, b[id].shape->bounding_radius, frame, *pool_, config_, zones_, axes)) {
      ++stats_.reinserted;
      std::fill_n(bits, words_, 0);
      for (uint32_t k : axes) bits[k / 64] |= uint64_t{1} << (k % 64);
    }
  }
  dirty_.clear();

  // 2. Per alive body, in id order: swept AABB and intervals on its pool axes. Sized first and
  //    written in place: this loop runs over every body every frame.
  const size_t slots = size();
  const size_t total_axes = countAliveAxes();
  slot_body_.resize(slots);
  offset_.resize(slots);
  box_.resize(6 * slots);
  intervals_.resize(total_axes);
  frame_t0_ = t0;
  frame_t1_ = t1;
  framed_ = true;
  cells_ready_ = false;
  // Lazy intervals when the incremental mode will be tried (filled for all if it declines).
  const bool lazy = incremental_ > 0.0 && (fat_valid_ || retry_wait_ == 0);
  interval_ready_.assign(slots, lazy ? 0 : 1);
  bits_.resize(words_ * slots);
  rank_.assign(words_ * slots, 0);
  std::fill(slot_of_.begin(), slot_of_.end(), kNoSlot);
  // Bounds of all boxes: the grid's extent (cell size choice, coordinate range).
  double world_lo[3] = {kInf, kInf, kInf}, world_hi[3] = {-kInf, -kInf, -kInf};
  uint32_t s = 0, next_interval = 0;
  for (BodyId id = 0; id < b.size(); ++id) {
    if (!b[id].alive) continue;
    slot_of_[id] = s;
    slot_body_[s] = id;
    const SweptBody swept(*b[id].shape, b[id].motion, t0, t1);
    double* box = &box_[6 * s];
    swept.box(box);
    for (int k = 0; k < 3; ++k) {
      world_lo[k] = std::min(world_lo[k], box[k]);
      world_hi[k] = std::max(world_hi[k], box[3 + k]);
    }
    offset_[s] = next_interval;
    uint64_t* bits = &bits_[words_ * s];
    std::copy_n(&axis_bits_[id * words_], words_, bits);
    uint16_t* rank = &rank_[words_ * s];
    detail::buildAxisRanks(bits, words_, rank);
    if (!lazy) {
      Interval* iv = intervals_.data() + next_interval;
      detail::forEachSetBit(bits, words_, [&](uint32_t k) { *iv++ = swept.project(pool_->axis(static_cast<int>(k))); });
    }
    next_interval += detail::axisCount(bits, rank, words_);
    ++s;
  }
  auto grid_from = Clock::now();
  stats_.update_seconds = std::chrono::duration<double>(grid_from - start).count();
  if (slots < 2) {
    stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
    return;
  }

  // 2b. Incremental mode, while the scene is slow enough.
  if (incremental_ > 0.0 && computeFromFatBoxes(frame, out)) {
    stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
    return;
  }
  if (lazy) {  // declined: the full path tests most slots
    const auto project_from = Clock::now();
    for (uint32_t slot = 0; slot < slots; ++slot) requireIntervals(slot);
    grid_from = Clock::now();
    stats_.update_seconds += std::chrono::duration<double>(grid_from - project_from).count();
  }

  // 3. Cell size, unless configured: the candidate (a multiple of the median box extent) with
  //    the least estimated cost, kIncidenceCost per (body, cell) incidence I(h) plus one per
  //    box test, about I^2 / (2 C) for C = min(I, volume / h^3) occupied cells. Large cells
  //    suit slow bodies (few incidences), small ones fast bodies (long boxes crowd a big cell).
  //    I(h) is estimated from at most kSample bodies.
  const double h = chooseCellSize(world_lo, world_hi);
  stats_.cell_size = h;
  grid_->build(box_.data(), slots, h);
  stats_.cells = grid_->cellCount();
  stats_.cell_entries = grid_->entryCount();
  stats_.large_bodies = grid_->large().size();
  cells_ready_ = true;

  // 4. Pairs of each cell, each reported in the cell of its boxes' common lo corner. A crowded
  //    cell is swept along x first (sorted by box lo x, a body meets only those that start
  //    before its box ends), a small one tested pair by pair.
  using Entry = CellGrid::Entry;
  auto test = [this, &out](const Entry& x, const Entry& y, const CellGrid::Cell& cell) {
    if (std::max(x.lo_cell[0], y.lo_cell[0]) != cell.x || std::max(x.lo_cell[1], y.lo_cell[1]) != cell.y ||
        std::max(x.lo_cell[2], y.lo_cell[2]) != cell.z) {
      return;  // tested in another cell they share
    }
    ++stats_.box_tests;
    if (x.box[0] > y.box[3] || y.box[0] > x.box[3] || x.box[1] > y.box[4] || y.box[1] > x.box[4] ||
        x.box[2] > y.box[5] || y.box[2] > x.box[5]) {
      return;
    }
    if (overlapOnShared(x.item, y.item)) out.push_back(makePair(slot_body_[x.item], slot_body_[y.item]));
  };
  CellGrid& grid = *grid_;
  for (size_t c = 0, cells = grid.cellCount(); c < cells; ++c) {
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
  // 5. Bodies too large for the grid: against every other body.
  testLargeAgainstAll(grid_->large(), out);
  stats_.sort_seconds = std::chrono::duration<double>(Clock::now() - grid_from).count();
}

// Incremental mode. A body's fat box holds its swept box of this frame and, at constant velocity,
// those of the frames to come up to kFatFrames frames or kFatReach times its half-extent ahead,
// padded by kFatPad of its half-extent. While a body's swept box stays inside its fat box, its
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
double fatLead(double half, double speed, double frame) {
  return speed > 0.0 ? std::min(kFatFrames * frame, kFatReach * half / speed) : kFatFrames * frame;
}
}  // namespace

double VadopGridBroadPhase::expectedEscapeRate(double frame) const {
  const size_t slots = slot_body_.size();
  if (slots == 0 || !(frame > 0.0)) return 0.0;
  const size_t stride = std::max<size_t>(1, slots / kSample);
  double rate = 0.0;
  size_t sampled = 0;
  for (size_t s = 0; s < slots; s += stride, ++sampled) {
    const double speed = bodies()[slot_body_[s]].motion.linear_velocity.norm();
    rate += 1.0 / std::max(1.0, fatLead(halfExtent(&box_[6 * s]), speed, frame) / frame);
  }
  return rate / static_cast<double>(sampled);
}

void VadopGridBroadPhase::appendFatBox(uint32_t s, double frame) {
  const double* t = &box_[6 * s];
  const Eigen::Vector3d& v = bodies()[slot_body_[s]].motion.linear_velocity;
  const double half = halfExtent(t);
  const double ahead = fatLead(half, v.norm(), frame);  // v = 0: no lead to add
  const double pad = kFatPad * half;
  for (int k = 0; k < 3; ++k) fat_boxes_.push_back(t[k] + std::min(0.0, v[k] * ahead) - pad);
  for (int k = 0; k < 3; ++k) fat_boxes_.push_back(t[3 + k] + std::max(0.0, v[k] * ahead) + pad);
}

bool VadopGridBroadPhase::computeFromFatBoxes(double frame, std::vector<Pair>& out) {
  const size_t slots = slot_body_.size();
  fat_ids_.clear();
  fat_boxes_.clear();
  if (!fat_valid_) {
    if (retry_wait_ > 0) {
      --retry_wait_;
      return false;
    }
    // Worth building? At constant velocity a body leaves its fat box after about its lead time
    // in frames: estimate the share of bodies leaving per frame on a sample, and stay with the
    // full path (asking again in a few frames) while it is over half the allowed fraction.
    if (incremental_ < 1.0 && expectedEscapeRate(frame) > 0.5 * incremental_) {
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
      appendFatBox(s, frame);
      const double* f = &fat_boxes_[6 * static_cast<size_t>(s)];
      extent[s] = std::max({f[3] - f[0], f[4] - f[1], f[5] - f[2]});
      for (int k = 0; k < 6; ++k) max_abs = std::max(max_abs, std::abs(f[k]));
    }
    const size_t mid = slots / 2;
    std::nth_element(extent.begin(), extent.begin() + static_cast<long>(mid), extent.end());
    const double h = cell_size_ > 0.0 ? cell_size_ : 2.0 * extent[mid];
    fat_->reset(std::max(h, 1e-9), max_abs);
    fat_->update(fat_ids_, fat_boxes_);
    fat_valid_ = true;
    streak_ = 0;
    stats_.fat_rebuilt = true;
  } else {
    for (uint32_t s = 0; s < slots; ++s) {
      if (!fat_->contains(slot_body_[s], &box_[6 * s])) {
        fat_ids_.push_back(slot_body_[s]);
        appendFatBox(s, frame);
      }
    }
    if (static_cast<double>(fat_ids_.size()) > incremental_ * static_cast<double>(slots)) {
      fat_valid_ = false;
      backoff_ = std::min(64, 2 * backoff_);
      retry_wait_ = backoff_;
      return false;
    }
    fat_->update(fat_ids_, fat_boxes_);
    if (++streak_ >= 8) backoff_ = 1;
    if (fat_->wasteful()) {
      fat_valid_ = false;  // rebuilt at the next update (this frame's pairs are still exact)
      retry_wait_ = 0;
    }
  }
  stats_.incremental = true;
  stats_.cell_size = fat_->cellSize();
  stats_.escaped = fat_ids_.size();
  stats_.fat_pairs = fat_->pairs();
  stats_.large_bodies = fat_->large().size();

  for (uint32_t s = 0; s < slots; ++s) {
    const BodyId id = slot_body_[s];
    for (const BodyId j : fat_->partners(id)) {
      if (j > id) testPair(s, slot_of_[j], out);
    }
  }
  large_slots_.clear();
  for (BodyId l : fat_->large()) large_slots_.push_back(slot_of_[l]);
  testLargeAgainstAll(large_slots_, out);
  return true;
}

}  // namespace vadop
