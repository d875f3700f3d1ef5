// Cost per pair of the narrow phase on links of joint chains (joint_chain.h) against the
// constant-twist narrow phase on the same shapes (each link frozen on its base's twist at t0):
// the random scenes of the chain property test (tests/chain_scenes.h), chains of 2 to 6 joints,
// a 2 s window. Methods interleaved and repeated (A B A B, `rounds` rounds); prints the median
// and the spread (min .. max) of the per-round means, and the ratio of the medians.
// Not a test: a plain program. Run: vadop_chain_bench [cases per chain length, default 300]
// [rounds, default 5].
#include "chain_scenes.h"

#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/joint_chain.h"
#include "vadop/time_of_impact.h"

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Prepared {
  vadop::PreparedShape sa, sb;
  vadop::LinkChain ca, cb;
  vadop::Motion ma, mb;  // the links frozen on their bases' twists at t0
};

vadop::Motion frozen(const vadop::LinkChain& chain, const chain_scenes::TChain& tc) {
  const Eigen::Isometry3d x = chain.poseAt(0.0);
  return vadop::makeMotion(x.translation(), Eigen::Quaterniond(x.linear()), tc.base.linear_velocity,
                           tc.base.angular_velocity, 0.0);
}

void summarise(const std::vector<double>& v, double* median, double* lo, double* hi) {
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  *median = s[s.size() / 2];
  *lo = s.front();
  *hi = s.back();
}

}  // namespace

int main(int argc, char** argv) {
  const int cases = argc > 1 ? std::max(1, std::atoi(argv[1])) : 300;
  const int rounds = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  std::printf("joints  cases  chain us/pair (median, min..max)  twist us/pair (median, min..max)  ratio  hits chain/twist\n");
  for (int n = 2; n <= 6; ++n) {
    toi_scenes::Rng r(500 + n);
    std::vector<Prepared> scenes;
    for (int c = 0; c < cases; ++c) {
      const chain_scenes::Case k = chain_scenes::randomCase(r, n);
      const vadop::LinkChain ca = chain_scenes::ours(k.a), cb = chain_scenes::ours(k.b);
      scenes.push_back({vadop::PreparedShape(k.sa), vadop::PreparedShape(k.sb), ca, cb, frozen(ca, k.a), frozen(cb, k.b)});
    }
    std::vector<double> chain_us, twist_us;
    int chain_hits = 0, twist_hits = 0;
    for (int round = 0; round < rounds; ++round) {
      chain_hits = twist_hits = 0;
      double t = cpuSeconds();
      for (const Prepared& p : scenes) chain_hits += vadop::timeOfImpact(p.sa, p.ca, p.sb, p.cb, 0.0, 2.0).hit;
      chain_us.push_back(1e6 * (cpuSeconds() - t) / cases);
      t = cpuSeconds();
      for (const Prepared& p : scenes) twist_hits += vadop::timeOfImpact(p.sa, p.ma, p.sb, p.mb, 0.0, 2.0).hit;
      twist_us.push_back(1e6 * (cpuSeconds() - t) / cases);
    }
    double cm, clo, chi, tm, tlo, thi;
    summarise(chain_us, &cm, &clo, &chi);
    summarise(twist_us, &tm, &tlo, &thi);
    std::printf("%6d  %5d  %8.1f (%.1f .. %.1f)  %8.1f (%.1f .. %.1f)  %5.1fx  %d/%d\n", n, cases, cm, clo, chi, tm, tlo,
                thi, cm / tm, chain_hits, twist_hits);
  }
  return 0;
}
