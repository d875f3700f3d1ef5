// The pending impacts of a frame or horizon in time order: the response loop of the VADOP
// paper. Pop the earliest impact, respond to it (change the velocities of its bodies),
// invalidate every pending impact of those bodies, predict their new impacts from that time
// on and push them; repeat. The queue of the bench's ResponseLoop (response_loop.h), built
// with it into the bench's library vadop_response_loop, not into libvadop_core.
//
// Bodies are named by 64-bit keys chosen by the caller; the keys also break ties, so the
// order is total and deterministic: by time, then by the pair (a, b) with a < b (given World's
// insertion-order keys, as fuzz_scene does, a is then the body added first). A pair has at most one pending
// impact (its first contact): pushing it again replaces the old one.
//
// Eager invalidation over an indexed binary heap: invalidate(body) removes that body's
// impacts at once, so size() is exact and memory is O(pending impacts), whatever the number
// of pushes, pops and invalidations so far. push, pop, erase: O(log n); invalidate: O(k log n)
// for k pending impacts of the body. Each impact sits in the pending lists of its two bodies
// (intrusive, doubly linked), and pairs and bodies are found through open-addressing hash
// maps: no allocation per impact or per body once the arrays have grown. It does not compute impacts (the narrow
// phase does) and is not thread-safe. Bad input throws vadop::InvalidArgument and leaves
// the queue unchanged.
#pragma once

#include "vadop/detail/flat_map.h"
#include "vadop/time_of_impact.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vadop {

struct QueuedImpact {
  uint64_t a = 0;  // a < b
  uint64_t b = 0;
  TimeOfImpact impact;   // impact.time is the key; impact.normal points from a to b
};

class ImpactQueue {
 public:
  // Schedules the impact of the pair {a, b}, replacing the pair's pending impact if any.
  // When a > b the pair is stored as (b, a) with the normal negated, so the normal always
  // points from the smaller key to the larger. Throws when a == b or impact.time, point or
  // normal is not finite.
  void push(uint64_t a, uint64_t b, const TimeOfImpact& impact);

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
  struct BodyHash {
    size_t operator()(uint64_t k) const;
  };
  // A link names one end of a node: slot * 2 + end, where end 0 is the node's body a and end 1
  // its body b. Each node is in two lists, the pending impacts of a and those of b.
  static constexpr uint32_t kNil = ~uint32_t{0};
  struct Node {
    QueuedImpact item;
    size_t heap_pos = 0;
    uint32_t next[2] = {kNil, kNil}, prev[2] = {kNil, kNil};
  };
  struct BodyList {
    uint32_t head = kNil;  // link of its first pending impact
    uint32_t live = 0;     // number of pending impacts
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
  uint64_t bodyOf(uint32_t link) const { return (link & 1) ? nodes_[link >> 1].item.b : nodes_[link >> 1].item.a; }
  uint32_t& nextOf(uint32_t link) { return nodes_[link >> 1].next[link & 1]; }
  uint32_t& prevOf(uint32_t link) { return nodes_[link >> 1].prev[link & 1]; }
  void siftUp(size_t pos);
  void siftDown(size_t pos);
  void linkEnd(uint32_t slot, int end);    // into its body's list (by_body_ has room for it)
  void unlinkEnd(uint32_t slot, int end);  // out of it; drops the body at zero
  // The node moved from slot `from` to slot `to`: repoint its neighbours and list heads.
  void relinkMoved(uint32_t to);
  // Removes the impact in `slot` from the heap, the pair map and the body lists, and keeps
  // the slots dense (the last slot moves into the hole).
  void removeSlot(size_t slot);

  std::vector<Node> nodes_;        // dense: nodes_.size() == heap_.size()
  std::vector<size_t> heap_;       // slot indices, a binary min-heap under before()
  detail::FlatMap<PairKey, uint32_t, PairHash> by_pair_;  // pair -> slot
  detail::FlatMap<uint64_t, BodyList, BodyHash> by_body_;  // bodies with pending impacts
};

}  // namespace vadop
