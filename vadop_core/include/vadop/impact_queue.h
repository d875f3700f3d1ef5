// The pending impacts of a frame or horizon in time order: the response loop of the VADOP
// paper. Pop the earliest impact, respond to it (change the velocities of its bodies),
// invalidate every pending impact of those bodies, predict their new impacts from that time
// on and push them; repeat.
//
// Bodies are named by 64-bit keys chosen by the caller; the keys also break ties, so the
// order is total and deterministic: by time, then by the pair (a, b) with a < b (World uses
// its insertion-order keys: a is then the body added first). A pair has at most one pending
// impact (its first contact): pushing it again replaces the old one.
//
// Eager invalidation over an indexed binary heap: invalidate(body) removes that body's
// impacts at once, so size() is exact and memory is O(pending impacts), whatever the number
// of pushes, pops and invalidations so far. push, pop, erase: O(log n); invalidate: O(k log n)
// for k pending impacts of the body (amortised). It does not compute impacts (World and the
// narrow phase do) and is not thread-safe. Bad input throws vadop::InvalidArgument and leaves
// the queue unchanged.
#pragma once

#include "vadop/time_of_impact.h"

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace vadop {

struct QueuedImpact {
  uint64_t a = 0;  // a < b
  uint64_t b = 0;
  Impact impact;   // impact.time is the key; impact.normal points from a to b
};

class ImpactQueue {
 public:
  // Schedules the impact of the pair {a, b}, replacing the pair's pending impact if any.
  // When a > b the pair is stored as (b, a) with the normal negated, so the normal always
  // points from the smaller key to the larger. Throws when a == b or impact.time, point or
  // normal is not finite.
  void push(uint64_t a, uint64_t b, const Impact& impact);

  bool empty() const { return heap_.empty(); }
  size_t size() const { return heap_.size(); }

  // The earliest pending impact (ties: smallest a, then smallest b). Throws when empty.
  const QueuedImpact& top() const;
  // Removes and returns top(). Throws when empty.
  QueuedImpact pop();
  // Pops every pending impact with time <= t, in order.
  std::vector<QueuedImpact> popUntil(double t);

  // Removes every pending impact involving `body` (its velocity changed: they are stale).
  // Returns how many were removed.
  size_t invalidate(uint64_t body);
  // Removes the pending impact of the pair {a, b}; returns whether there was one.
  bool erase(uint64_t a, uint64_t b);
  bool contains(uint64_t a, uint64_t b) const;
  // The pending impact of the pair {a, b} (stored as a < b), or nullptr.
  const QueuedImpact* find(uint64_t a, uint64_t b) const;
  // Number of pending impacts involving `body`.
  size_t count(uint64_t body) const;

  void clear();

  // Every pending impact in pop order, without removing them. O(n log n).
  std::vector<QueuedImpact> sorted() const;

  // Bytes held by the queue's own structures (an estimate for the hash maps).
  size_t memoryBytes() const;

 private:
  struct PairKey {
    uint64_t a, b;
    friend bool operator==(const PairKey& x, const PairKey& y) { return x.a == y.a && x.b == y.b; }
  };
  struct PairHash {
    size_t operator()(const PairKey& k) const;
  };
  struct Node {
    QueuedImpact item;
    size_t heap_pos = 0;
  };
  struct BodyList {
    std::vector<uint64_t> partners;  // may hold stale or repeated partners; filtered lazily
    size_t live = 0;                 // pending impacts of this body
  };

  static bool before(const QueuedImpact& x, const QueuedImpact& y) {
    if (x.impact.time != y.impact.time) return x.impact.time < y.impact.time;
    if (x.a != y.a) return x.a < y.a;
    return x.b < y.b;
  }
  bool less(size_t i, size_t j) const { return before(nodes_[heap_[i]].item, nodes_[heap_[j]].item); }
  void place(size_t pos, size_t slot) {
    heap_[pos] = slot;
    nodes_[slot].heap_pos = pos;
  }
  void siftUp(size_t pos);
  void siftDown(size_t pos);
  // Removes the impact in `slot` from the heap, the pair map and the body lists, and keeps
  // the slots dense (the last slot moves into the hole).
  void removeSlot(size_t slot);
  void dropPartner(uint64_t body);  // one pending impact of `body` is gone
  void compactPartners(uint64_t body, BodyList& list) const;

  std::vector<Node> nodes_;        // dense: nodes_.size() == heap_.size()
  std::vector<size_t> heap_;       // slot indices, a binary min-heap under before()
  std::unordered_map<PairKey, size_t, PairHash> by_pair_;
  std::unordered_map<uint64_t, BodyList> by_body_;
};

}  // namespace vadop
