#include "pair_certificates.h"

namespace vadop {
namespace detail {

size_t PairCertificates::PairKeyHash::operator()(const PairKey& k) const {
  uint64_t x = k.a * 0x9e3779b97f4a7c15ull ^ (k.b + 0x632be59bd9b4e019ull);
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return static_cast<size_t>(x ^ (x >> 31));
}

PairCertificates::Verdict PairCertificates::lookup(const Body& a, const Body& b, double t0, double t1) {
  const auto it = entries_.find(pairKey(a.key, b.key));
  if (it == entries_.end()) return Verdict::kUnknown;
  Entry& e = it->second;
  e.pass = pass_;
  if (e.near > 0) {
    --e.near;
    return Verdict::kNear;
  }
  const bool inside = t0 >= e.from && (e.closed ? t1 <= e.until : t1 < e.until);
  if (!inside) return Verdict::kUnknown;
  const double moved = maxDisplacement(e.a, *a.motion, a.radius, t0, t1) +
                       maxDisplacement(e.b, *b.motion, b.radius, t0, t1);
  if (moved < budget_) {
    ++e.reuses;
    return Verdict::kClear;
  }
  // The motions left the certificate (noise, a new command). One that dies young did not pay
  // for its wide test: wait before the next, twice as long each time it happens again.
  if (e.reuses < kYoung) {
    e.backoff = std::min(kNearWait, std::max(1, 2 * e.backoff));
    e.near = e.backoff - 1;  // this lookup is the first of the wait
    e.until = e.from;
    return Verdict::kNear;
  }
  e.backoff = 0;
  return Verdict::kUnknown;
}

PairCertificates::Entry& PairCertificates::slot(const Body& a, const Body& b) {
  Entry& e = entries_[pairKey(a.key, b.key)];
  e.pass = pass_;
  return e;
}

void PairCertificates::certify(const Body& a, const Body& b, double from, double until, bool closed) {
  Entry& e = slot(a, b);
  e.a = *a.motion;
  e.b = *b.motion;
  e.from = from;
  e.until = until;
  e.closed = closed;
  e.near = 0;
  e.reuses = 0;
}

void PairCertificates::markNear(const Body& a, const Body& b) {
  Entry& e = slot(a, b);
  e.near = kNearWait;
  e.until = e.from;  // no certificate once the wait is over
  e.closed = false;
}

void PairCertificates::endPass() {
  for (auto it = entries_.begin(); it != entries_.end();) {
    it = it->second.pass == pass_ ? std::next(it) : entries_.erase(it);
  }
}

}  // namespace detail
}  // namespace vadop
