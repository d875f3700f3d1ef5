// Temporal coherence of the narrow phase: "no contact" verdicts kept from one predict to the
// next. A certificate says that under motions (ma, mb) the gap between two bodies exceeds the
// clearance at every time of [from, until). It answers a later window [t0, t1] inside that
// interval under new motions (na, nb) when maxDisplacement(ma, na) + maxDisplacement(mb, nb)
// over the window stays below clearance - tolerance: the gap then exceeds the tolerance
// throughout, which is what the narrow phase's "no contact" means (time_of_impact.h).
// Pairs whose certification failed within the window (or that touch) are marked near: computed
// directly for the next kNearWait lookups, then certification is tried again; so are, for a
// growing while, pairs whose certificates keep dying young (noisy motions). Keys are the World's insertion keys
// (never reused). Motions only: pairs involving a path or a chain are not certified here.
// Not thread-safe.
#pragma once

#include "vadop/motion.h"

#include <cstdint>
#include <unordered_map>

namespace vadop {
namespace detail {

class PairCertificates {
 public:
  enum class Verdict {
    kClear,    // a certificate answers the window: no contact
    kNear,     // the last attempt found them within the clearance: compute directly
    kUnknown,  // no usable certificate: compute and try to certify
  };
  struct Body {
    uint64_t key;
    const Motion* motion;
    double radius;  // bounding radius (maxDisplacement's)
  };

  // clearance > tolerance > 0 (the World checks).
  void configure(double clearance, double tolerance) {
    clearance_ = clearance;
    budget_ = clearance - tolerance;
  }
  double clearance() const { return clearance_; }

  Verdict lookup(const Body& a, const Body& b, double t0, double t1);
  // The pair is apart by more than the clearance over [from, until) (also at `until` when
  // `closed`) under motions ma, mb.
  void certify(const Body& a, const Body& b, double from, double until, bool closed);
  static constexpr int kNearWait = 15;
  // A certificate invalidated by the motions after fewer reuses than this died young: the pair
  // waits 1, 2, 4, ... up to kNearWait lookups before the next attempt.
  static constexpr int kYoung = 3;
  void markNear(const Body& a, const Body& b);

  // A full pass (every candidate pair looked up) ends with endPass: entries no lookup touched
  // since beginPass (pairs no longer candidates, bodies removed) are dropped.
  void beginPass() { ++pass_; }
  void endPass();
  size_t size() const { return entries_.size(); }

 private:
  struct Entry {
    Motion a, b;
    double from = 0.0, until = 0.0;
    bool closed = false;
    int near = 0;     // lookups left before certification is tried again
    int reuses = 0;   // windows answered by the current certificate
    int backoff = 0;  // the last wait after a certificate that died young
    uint64_t pass = 0;
  };
  struct PairKey {
    uint64_t a, b;
    bool operator==(const PairKey& o) const { return a == o.a && b == o.b; }
  };
  struct PairKeyHash {
    size_t operator()(const PairKey& k) const;
  };
  static PairKey pairKey(uint64_t a, uint64_t b) { return PairKey{a, b}; }
  Entry& slot(const Body& a, const Body& b);

  double clearance_ = 0.0, budget_ = 0.0;
  uint64_t pass_ = 0;
  std::unordered_map<PairKey, Entry, PairKeyHash> entries_;
};

}  // namespace detail
}  // namespace vadop
