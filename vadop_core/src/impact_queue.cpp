#include "vadop/impact_queue.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <new>
#include <sstream>
#include <string>
#include <utility>

namespace vadop {
namespace {

uint64_t mix(uint64_t x) {  // splitmix64 finaliser
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

}  // namespace

size_t ImpactQueue::PairHash::operator()(const PairKey& k) const {
  return static_cast<size_t>(mix(k.a * 0x9e3779b97f4a7c15ULL ^ mix(k.b)));
}

void ImpactQueue::push(uint64_t a, uint64_t b, const Impact& impact) {
  if (a == b) throw InvalidArgument("ImpactQueue::push: a pair needs two bodies, got " + std::to_string(a) + " twice");
  if (!std::isfinite(impact.time)) {
    throw InvalidArgument("ImpactQueue::push: impact time is not finite: " + formatNumber(impact.time));
  }
  if (!impact.point.allFinite()) throw InvalidArgument("ImpactQueue::push: impact point is not finite");
  if (!impact.normal.allFinite()) throw InvalidArgument("ImpactQueue::push: impact normal is not finite");
  QueuedImpact item;
  item.impact = impact;
  if (a < b) {
    item.a = a;
    item.b = b;
  } else {
    item.a = b;
    item.b = a;
    item.impact.normal = -impact.normal;
  }
  const PairKey key{item.a, item.b};

  const auto found = by_pair_.find(key);
  if (found != by_pair_.end()) {  // replace: no allocation, cannot fail
    const size_t slot = found->second;
    const bool earlier = before(item, nodes_[slot].item);
    nodes_[slot].item = item;
    if (earlier) {
      siftUp(nodes_[slot].heap_pos);
    } else {
      siftDown(nodes_[slot].heap_pos);
    }
    return;
  }

  // Everything that can allocate happens before the heap changes, and is undone on failure.
  // (Geometric growth: reserve(size + 1) would reallocate on every push.)
  if (nodes_.size() == nodes_.capacity()) nodes_.reserve(std::max<size_t>(16, 2 * nodes_.capacity()));
  if (heap_.size() == heap_.capacity()) heap_.reserve(std::max<size_t>(16, 2 * heap_.capacity()));
  const size_t slot = nodes_.size();
  const auto inserted = by_pair_.emplace(key, slot).first;
  BodyList* la = nullptr;
  BodyList* lb = nullptr;
  try {
    la = &by_body_[item.a];
    la->partners.push_back(item.b);
    lb = &by_body_[item.b];
    lb->partners.push_back(item.a);
  } catch (...) {
    by_pair_.erase(inserted);
    // A list created just now holds no pending impact: drop it again. (A stale partner left in
    // an older list is harmless: lists are filtered against by_pair_.)
    for (const uint64_t body : {item.a, item.b}) {
      const auto it = by_body_.find(body);
      if (it != by_body_.end() && it->second.live == 0) by_body_.erase(it);
    }
    throw;
  }
  ++la->live;
  ++lb->live;
  if (la->partners.size() > 2 * la->live + 8) compactPartners(item.a, *la);
  if (lb->partners.size() > 2 * lb->live + 8) compactPartners(item.b, *lb);
  nodes_.push_back(Node{item, heap_.size()});
  heap_.push_back(slot);
  siftUp(heap_.size() - 1);
}

const QueuedImpact& ImpactQueue::top() const {
  if (heap_.empty()) throw InvalidArgument("ImpactQueue::top: the queue is empty");
  return nodes_[heap_[0]].item;
}

QueuedImpact ImpactQueue::pop() {
  if (heap_.empty()) throw InvalidArgument("ImpactQueue::pop: the queue is empty");
  QueuedImpact out = nodes_[heap_[0]].item;
  removeSlot(heap_[0]);
  return out;
}

std::vector<QueuedImpact> ImpactQueue::popUntil(double t) {
  if (std::isnan(t)) throw InvalidArgument("ImpactQueue::popUntil: t is NaN");
  std::vector<QueuedImpact> out;
  while (!heap_.empty() && nodes_[heap_[0]].item.impact.time <= t) out.push_back(pop());
  return out;
}

size_t ImpactQueue::invalidate(uint64_t body) {
  const auto it = by_body_.find(body);
  if (it == by_body_.end()) return 0;
  // removeSlot updates (and finally erases) this body's list: iterate over a moved-out copy.
  const std::vector<uint64_t> partners = std::move(it->second.partners);
  it->second.partners.clear();
  size_t removed = 0;
  for (const uint64_t p : partners) {
    const auto f = by_pair_.find(body < p ? PairKey{body, p} : PairKey{p, body});
    if (f == by_pair_.end()) continue;  // stale or repeated partner
    removeSlot(f->second);
    ++removed;
  }
  return removed;
}

bool ImpactQueue::erase(uint64_t a, uint64_t b) {
  const auto f = by_pair_.find(a < b ? PairKey{a, b} : PairKey{b, a});
  if (f == by_pair_.end()) return false;
  removeSlot(f->second);
  return true;
}

bool ImpactQueue::contains(uint64_t a, uint64_t b) const { return find(a, b) != nullptr; }

const QueuedImpact* ImpactQueue::find(uint64_t a, uint64_t b) const {
  const auto f = by_pair_.find(a < b ? PairKey{a, b} : PairKey{b, a});
  return f == by_pair_.end() ? nullptr : &nodes_[f->second].item;
}

size_t ImpactQueue::count(uint64_t body) const {
  const auto it = by_body_.find(body);
  return it == by_body_.end() ? 0 : it->second.live;
}

void ImpactQueue::clear() {
  nodes_.clear();
  nodes_.shrink_to_fit();
  heap_.clear();
  heap_.shrink_to_fit();
  by_pair_.clear();
  by_body_.clear();
}

std::vector<QueuedImpact> ImpactQueue::sorted() const {
  std::vector<QueuedImpact> out;
  out.reserve(nodes_.size());
  for (const Node& n : nodes_) out.push_back(n.item);
  std::sort(out.begin(), out.end(), before);
  return out;
}

size_t ImpactQueue::memoryBytes() const {
  size_t bytes = nodes_.capacity() * sizeof(Node) + heap_.capacity() * sizeof(size_t);
  // Node-based hash maps: one node (value + next pointer + cached hash) per element, plus buckets.
  bytes += by_pair_.size() * (sizeof(std::pair<const PairKey, size_t>) + 2 * sizeof(void*)) +
           by_pair_.bucket_count() * sizeof(void*);
  bytes += by_body_.size() * (sizeof(std::pair<const uint64_t, BodyList>) + 2 * sizeof(void*)) +
           by_body_.bucket_count() * sizeof(void*);
  for (const auto& kv : by_body_) bytes += kv.second.partners.capacity() * sizeof(uint64_t);
  return bytes;
}

void ImpactQueue::siftUp(size_t pos) {
  const size_t slot = heap_[pos];
  while (pos > 0) {
    const size_t parent = (pos - 1) / 2;
    if (!before(nodes_[slot].item, nodes_[heap_[parent]].item)) break;
    place(pos, heap_[parent]);
    pos = parent;
  }
  place(pos, slot);
}

void ImpactQueue::siftDown(size_t pos) {
  const size_t n = heap_.size();
  const size_t slot = heap_[pos];
  for (;;) {
    size_t child = 2 * pos + 1;
    if (child >= n) break;
    if (child + 1 < n && before(nodes_[heap_[child + 1]].item, nodes_[heap_[child]].item)) ++child;
    if (!before(nodes_[heap_[child]].item, nodes_[slot].item)) break;
    place(pos, heap_[child]);
    pos = child;
  }
  place(pos, slot);
}

void ImpactQueue::removeSlot(size_t slot) {
  const QueuedImpact gone = nodes_[slot].item;
  by_pair_.erase(PairKey{gone.a, gone.b});

  // Out of the heap: the last heap element fills the hole and moves up or down.
  const size_t pos = nodes_[slot].heap_pos;
  const size_t last_pos = heap_.size() - 1;
  if (pos != last_pos) {
    place(pos, heap_[last_pos]);
    heap_.pop_back();
    if (pos > 0 && less(pos, (pos - 1) / 2)) {
      siftUp(pos);
    } else {
      siftDown(pos);
    }
  } else {
    heap_.pop_back();
  }

  // Keep the slots dense: the last slot moves into this one.
  const size_t last_slot = nodes_.size() - 1;
  if (slot != last_slot) {
    nodes_[slot] = nodes_[last_slot];
    heap_[nodes_[slot].heap_pos] = slot;
    by_pair_.find(PairKey{nodes_[slot].item.a, nodes_[slot].item.b})->second = slot;
  }
  nodes_.pop_back();
  if (nodes_.capacity() > 64 && nodes_.size() < nodes_.capacity() / 4) {
    // Give memory back after a burst. The copies may throw bad_alloc: then keep the old buffers.
    try {
      std::vector<Node>(nodes_.begin(), nodes_.end()).swap(nodes_);
      std::vector<size_t>(heap_.begin(), heap_.end()).swap(heap_);
    } catch (const std::bad_alloc&) {
    }
  }

  dropPartner(gone.a);
  dropPartner(gone.b);

  // Hash tables never shrink their bucket arrays by themselves: after a burst, rehash down
  // (amortised O(1): only once the size fell to 1/8 of the buckets).
  try {
    if (by_pair_.bucket_count() > 64 && by_pair_.size() < by_pair_.bucket_count() / 8) by_pair_.rehash(0);
    if (by_body_.bucket_count() > 64 && by_body_.size() < by_body_.bucket_count() / 8) by_body_.rehash(0);
  } catch (const std::bad_alloc&) {
  }
}

void ImpactQueue::dropPartner(uint64_t body) {
  const auto it = by_body_.find(body);
  if (it == by_body_.end()) return;  // cannot happen: every pending impact is counted
  BodyList& list = it->second;
  if (--list.live == 0) {
    by_body_.erase(it);
  } else if (list.partners.size() > 4 * list.live + 8) {
    compactPartners(body, list);
  }
}

void ImpactQueue::compactPartners(uint64_t body, BodyList& list) const {
  auto& p = list.partners;
  std::sort(p.begin(), p.end());
  p.erase(std::unique(p.begin(), p.end()), p.end());
  p.erase(std::remove_if(p.begin(), p.end(),
                         [&](uint64_t q) {
                           return by_pair_.count(body < q ? PairKey{body, q} : PairKey{q, body}) == 0;
                         }),
          p.end());
  if (p.capacity() > 2 * p.size() + 16) p.shrink_to_fit();
}

}  // namespace vadop
