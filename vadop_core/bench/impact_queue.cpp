#include "impact_queue.h"

#include "vadop/error.h"

#include <algorithm>
#include <cmath>
#include <new>
#include <sstream>
#include <stdexcept>
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

size_t ImpactQueue::BodyHash::operator()(uint64_t k) const { return static_cast<size_t>(mix(k)); }

void ImpactQueue::push(uint64_t a, uint64_t b, const TimeOfImpact& impact) {
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

  if (const uint32_t* found = by_pair_.find(key)) {  // replace: no allocation, cannot fail
    const size_t slot = *found;
    const bool earlier = before(item, nodes_[slot].item);
    nodes_[slot].item = item;
    if (earlier) {
      siftUp(nodes_[slot].heap_pos);
    } else {
      siftDown(nodes_[slot].heap_pos);
    }
    return;
  }

  // Everything that can allocate happens before the queue changes (geometric growth:
  // reserve(size + 1) would reallocate on every push); the inserts below cannot throw.
  if (nodes_.size() >= (kNil >> 1)) throw std::length_error("ImpactQueue::push: too many pending impacts");
  if (nodes_.size() == nodes_.capacity()) nodes_.reserve(std::max<size_t>(16, 2 * nodes_.capacity()));
  if (heap_.size() == heap_.capacity()) heap_.reserve(std::max<size_t>(16, 2 * heap_.capacity()));
  by_pair_.reserve(by_pair_.size() + 1);
  by_body_.reserve(by_body_.size() + 2);
  const uint32_t slot = static_cast<uint32_t>(nodes_.size());
  by_pair_.insert(key, slot);
  nodes_.push_back(Node{});
  nodes_.back().item = item;
  nodes_.back().heap_pos = heap_.size();
  heap_.push_back(slot);
  linkEnd(slot, 0);
  linkEnd(slot, 1);
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
  size_t removed = 0;
  // removeSlot unlinks the head (and drops the body with its last impact): take it again.
  while (const BodyList* list = by_body_.find(body)) {
    removeSlot(list->head >> 1);
    ++removed;
  }
  return removed;
}

bool ImpactQueue::erase(uint64_t a, uint64_t b) {
  const uint32_t* f = by_pair_.find(a < b ? PairKey{a, b} : PairKey{b, a});
  if (f == nullptr) return false;
  removeSlot(*f);
  return true;
}

bool ImpactQueue::contains(uint64_t a, uint64_t b) const { return find(a, b) != nullptr; }

const QueuedImpact* ImpactQueue::find(uint64_t a, uint64_t b) const {
  const uint32_t* f = by_pair_.find(a < b ? PairKey{a, b} : PairKey{b, a});
  return f == nullptr ? nullptr : &nodes_[*f].item;
}

size_t ImpactQueue::count(uint64_t body) const {
  const BodyList* list = by_body_.find(body);
  return list == nullptr ? 0 : list->live;
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
  return nodes_.capacity() * sizeof(Node) + heap_.capacity() * sizeof(size_t) + by_pair_.memoryBytes() +
         by_body_.memoryBytes();
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

void ImpactQueue::linkEnd(uint32_t slot, int end) {
  Node& node = nodes_[slot];
  BodyList& list = by_body_.insert(end ? node.item.b : node.item.a, BodyList{});  // reserved: no throw
  const uint32_t link = slot * 2 + end;
  node.next[end] = list.head;
  node.prev[end] = kNil;
  if (list.head != kNil) prevOf(list.head) = link;
  list.head = link;
  ++list.live;
}

void ImpactQueue::unlinkEnd(uint32_t slot, int end) {
  Node& node = nodes_[slot];
  const uint64_t body = end ? node.item.b : node.item.a;
  BodyList& list = *by_body_.find(body);
  const uint32_t p = node.prev[end], n = node.next[end];
  if (p != kNil) {
    nextOf(p) = n;
  } else {
    list.head = n;
  }
  if (n != kNil) prevOf(n) = p;
  if (--list.live == 0) by_body_.erase(body);
}

void ImpactQueue::relinkMoved(uint32_t to) {
  Node& node = nodes_[to];
  for (int end = 0; end < 2; ++end) {
    const uint32_t link = to * 2 + end;
    if (node.prev[end] != kNil) {
      nextOf(node.prev[end]) = link;
    } else {
      by_body_.find(end ? node.item.b : node.item.a)->head = link;
    }
    if (node.next[end] != kNil) prevOf(node.next[end]) = link;
  }
  heap_[node.heap_pos] = to;
  *by_pair_.find(PairKey{node.item.a, node.item.b}) = to;
}

void ImpactQueue::removeSlot(size_t slot_index) {
  const uint32_t slot = static_cast<uint32_t>(slot_index);
  by_pair_.erase(PairKey{nodes_[slot].item.a, nodes_[slot].item.b});
  unlinkEnd(slot, 0);
  unlinkEnd(slot, 1);

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
  const uint32_t last_slot = static_cast<uint32_t>(nodes_.size() - 1);
  if (slot != last_slot) {
    nodes_[slot] = nodes_[last_slot];
    relinkMoved(slot);
  }
  nodes_.pop_back();

  // Give memory back after a burst (amortised O(1): only once the size fell to 1/4 of the
  // capacity, 1/8 for the hash maps). The copies may throw bad_alloc: then keep the old buffers.
  try {
    if (nodes_.capacity() > 64 && nodes_.size() < nodes_.capacity() / 4) {
      std::vector<Node>(nodes_.begin(), nodes_.end()).swap(nodes_);
      std::vector<size_t>(heap_.begin(), heap_.end()).swap(heap_);
    }
    by_pair_.shrinkIfSparse();
    by_body_.shrinkIfSparse();
  } catch (const std::bad_alloc&) {
  }
}

}  // namespace vadop
