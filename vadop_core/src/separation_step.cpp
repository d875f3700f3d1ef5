// Certified step along a separating direction. See separation_step.h for the three bounds.
#include "separation_step.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace vadop {
namespace detail {

namespace {

// Refines a bracket [lo, hi] of the first root of a concave f on [0, horizon] with f(0) > 0,
// f(lo) = flo > 0 and f(hi) = fhi <= 0, and returns the largest certified step found (f > 0
// on [0, step)): any point where f was evaluated > 0 is safe (f > 0 between 0 and it). For
// concave f the chord root never passes the root (f lies above its chords), so plain regula
// falsi only ever moves lo, slowly when f bends sharply (a root far below the horizon); the
// Illinois rule halves the weight of an end kept twice in a row, which brings hi down too.
template <class F>
double refineConcaveRoot(const F& f, double lo, double flo, double hi, double fhi) {
  double wlo = flo, whi = fhi;  // the ends' weights in the secant
  int kept = 0;                 // +1: lo moved last, -1: hi moved last
  for (int k = 0; k < 16; ++k) {
    const double x = lo + (hi - lo) * (wlo / (wlo - whi));
    if (!(x > lo && x < hi)) break;
    const double fx = f(x);
    if (fx > 0.0) {
      lo = x;
      wlo = fx;
      if (kept > 0) whi *= 0.5;
      kept = 1;
    } else {
      hi = x;
      whi = fx;
      if (kept < 0) wlo *= 0.5;
      kept = -1;
    }
    if (hi - lo <= 0.02 * lo) break;
  }
  return lo;
}

}  // namespace

double separationStep(const Convex& A, const Kin& ka, const Convex& B, const Kin& kb,
                      const Eigen::Vector3d& n, double horizon, double adv, double cap, bool* clear,
                      double deviation) {
  *clear = false;
  const Eigen::Vector3d ua = ka.w.cross(n), ub = kb.w.cross(n);
  const double kA = ua.norm(), kB = ub.norm();
  const Eigen::Vector3d P = B.p - A.p;
  const Eigen::Vector3d V = kb.v - ka.v;
  const double base = n.dot(P);
  const double hA0 = A.h(n), hB0 = B.h(-n);
  const double f0 = base - hA0 - hB0 - adv;
  if (!(f0 > 0.0)) return 0.0;
  const double closing = -n.dot(V);
  const double mu = closing + A.lever * kA + B.lever * kB;
  // f0 - mu D - deviation D^2 / 2 = 0, cancellation-free (f0 / mu without deviation).
  const double dev = 0.5 * deviation;
  const double step_lin = dev > 0.0 ? 2.0 * f0 / (mu + std::sqrt(mu * mu + 4.0 * dev * f0)) : mu > 0.0 ? f0 / mu : kInf;
  if (step_lin >= horizon) {
    *clear = true;
    return horizon;
  }
  if (kA == 0.0 && kB == 0.0) return step_lin;  // translation: the exact linear law
  if (step_lin >= cap) return step_lin;
  const double wa = ka.w.norm(), wb = kb.w.norm();
  const Eigen::Vector3d rel = (kb.w - ka.w).cross(n);
  const double wsum2 = (wa + wb) * (wa + wb);
  const double Pn = P.norm(), Vn = V.norm();
  const double nV = n.dot(V);
  // (1) fixed axis; (2) attached to b; (3) attached to a (the axis -n turns with a).
  const double q = 0.5 * (A.lever * wa * kA + B.lever * wb * kB);
  const double r1b = ub.dot(P) + nV, r1a = ua.dot(P) + nV;
  const double c2b = std::max(0.0, -ub.dot(V)) + 0.5 * wb * kB * Pn + 0.5 * A.lever * wsum2;
  const double c2a = std::max(0.0, -ua.dot(V)) + 0.5 * wa * kA * Pn + 0.5 * B.lever * wsum2;
  const double c3b = 0.5 * wb * kB * Vn, c3a = 0.5 * wa * kA * Vn;
  auto bound = [&](int which, double D) {
    switch (which) {
      case 0: return base + D * nV - A.h(n - D * ua) - B.h(-n + D * ub) - (q + dev) * D * D - adv;
      case 1: return base + D * r1b - (c2b + dev + c3b * D) * D * D - hB0 - A.h(n + D * rel) - adv;
      default: return base + D * r1a - (c2a + dev + c3a * D) * D * D - hA0 - B.h(-n + D * rel) - adv;
    }
  };
  // Each bound at the horizon: one still positive there certifies it all. Otherwise the bound
  // whose chord from (0, f0) to (horizon, f(horizon)) crosses zero last is refined first (the
  // chord root is where its refinement starts); another is refined only if it is still positive
  // where the best step so far ends (then its root lies beyond; one evaluation rules it out
  // otherwise), instead of refining all three in full.
  struct Candidate {
    int which;
    double at_horizon;
    double chord_root;
  };
  std::array<Candidate, 3> cand;
  int m = 0;
  for (int which = 0; which < 3; ++which) {
    if ((which == 1 && kB == 0.0) || (which == 2 && kA == 0.0)) continue;
    const double fT = bound(which, horizon);
    if (fT > 0.0) {
      *clear = true;
      return horizon;
    }
    cand[m++] = {which, fT, horizon * (f0 / (f0 - fT))};
  }
  for (int i = 1; i < m; ++i) {  // by chord root, largest first (insertion sort of <= 3)
    for (int j = i; j > 0 && cand[j].chord_root > cand[j - 1].chord_root; --j) std::swap(cand[j], cand[j - 1]);
  }
  double best = step_lin;
  for (int k = 0; k < m; ++k) {
    auto f = [&](double D) { return bound(cand[k].which, D); };
    double lo = 0.0, flo = f0;
    if (k > 0) {
      // Positive at the best step: positive up to it (concave), its root lies beyond.
      flo = f(best);
      if (!(flo > 0.0)) continue;
      lo = best;
    }
    best = std::max(best, refineConcaveRoot(f, lo, flo, horizon, cand[k].at_horizon));
    if (best >= cap) return std::min(best, horizon);
  }
  return std::min(best, horizon);
}

}  // namespace detail
}  // namespace vadop
