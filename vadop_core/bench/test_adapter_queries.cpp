// The peers' single-body queries (FCL's and Bullet's trees behind vadop::BroadPhase): for
// random spheres, after an update and changes (few, and enough for BroadPhase's index of
// changed bodies), every query within the frame lists every body whose frame box (unchanged)
// or current swept box (changed) overlaps the query's, hence every body the narrow phase finds
// a contact with; never itself, never a removed body; and nothing whose box stays clear of the
// query's by more than single-precision rounding (Bullet holds floats).
#include "bench_adapters.h"
#include "bench_world.h"
#include "vadop/distance.h"  // PreparedShape (internal: src/)
#include "vadop/time_of_impact.h"
#include "vadop/vadop.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>
#include <vector>

namespace {

using vadop_bench::Box;

vadop::Motion moving(const Eigen::Vector3d& p, const Eigen::Vector3d& v) {
  return vadop::makeMotion(p, Eigen::Quaterniond::Identity(), v, Eigen::Vector3d::Zero());
}

bool near(const Box& a, const Box& b, double slack) {
  return (a.lo.array() <= b.hi.array() + slack).all() && (b.lo.array() <= a.hi.array() + slack).all();
}

TEST(AdapterQueries, CompleteAndBoundedForFclAndBullet) {
  size_t queries = 0, contacts = 0;
  for (int changes : {10, 200}) {
    for (int which = 0; which < 3; ++which) {
      std::unique_ptr<vadop_bench::TimedBroadPhase> bp =
          which == 0   ? vadop_bench::makeFclBroadPhase(vadop_bench::FclMode::kRefit, vadop_bench::BoxKind::kSwept)
          : which == 1 ? vadop_bench::makeFclBroadPhase(vadop_bench::FclMode::kRebuild, vadop_bench::BoxKind::kSwept)
                       : vadop_bench::makeBulletBroadPhase();
      const std::string name = bp->name();
      std::mt19937_64 rng(7 + changes);
      std::uniform_real_distribution<double> pos(-15.0, 15.0), vel(-4.0, 4.0);
      const int n = 600;
      const auto sphere = std::make_shared<const vadop::Shape>(vadop::makeSphere(0.5));
      std::vector<vadop::Motion> frame(n), cur(n);
      for (int i = 0; i < n; ++i) {
        frame[i] = cur[i] = moving({pos(rng), pos(rng), pos(rng)}, {vel(rng), vel(rng), vel(rng)});
        ASSERT_EQ(bp->add(sphere, frame[i]), static_cast<vadop::BodyId>(i));
      }
      bp->update(0.0, 1.0);
      std::vector<char> changed(n, 0), alive(n, 1);
      for (int k = 0; k < changes; ++k) {
        const int i = static_cast<int>(rng() % n);
        cur[i] = moving(cur[i].positionAt(0.2), {vel(rng), vel(rng), vel(rng)});
        cur[i].t_ref = 0.2;
        bp->setMotion(i, cur[i]);
        changed[i] = 1;
      }
      for (int i : {11, 12, 13}) {
        bp->remove(i);
        alive[i] = 0;
      }
      const vadop::PreparedShape prepared(*sphere);
      for (const auto& [t0, t1] : {std::pair<double, double>{0.2, 0.5}, {0.3, 1.0}, {0.0, 1.0}}) {
        for (int q = 20; q < 80; ++q) {
          if (!alive[q]) continue;
          std::vector<vadop::BodyId> got;
          bp->query(q, t0, t1, got);
          ++queries;
          const std::set<vadop::BodyId> answer(got.begin(), got.end());
          EXPECT_EQ(answer.count(q), 0u) << name;
          double qb[6];
          vadop::SweptBody(*sphere, cur[q], t0, t1).box(qb);
          const Box qbox{Eigen::Vector3d(qb[0], qb[1], qb[2]), Eigen::Vector3d(qb[3], qb[4], qb[5])};
          for (int j = 0; j < n; ++j) {
            if (j == q) continue;
            if (!alive[j]) {
              EXPECT_EQ(answer.count(j), 0u) << name << ": removed body " << j;
              continue;
            }
            // An unchanged body: its frame box; a changed one: its swept box over the window
            // (must be listed) and over the rest of the frame (may be listed).
            Box must, may;
            if (changed[j]) {
              must = vadop_bench::sweptBox(cur[j], 0.5, t0, t1);
              may = vadop_bench::sweptBox(cur[j], 0.5, std::min(t0, 0.2), 1.0);
            } else {
              must = may = vadop_bench::sweptBox(frame[j], 0.5, 0.0, 1.0);
            }
            if (near(qbox, must, -1e-9)) EXPECT_EQ(answer.count(j), 1u) << name << " misses " << j << " query " << q;
            if (!near(qbox, may, 1e-5 * 32.0)) EXPECT_EQ(answer.count(j), 0u) << name << " lists far " << j;
            const vadop::TimeOfImpact hit = vadop::timeOfImpact(prepared, cur[q], prepared, cur[j], t0, t1);
            if (hit.hit) {
              ++contacts;
              EXPECT_EQ(answer.count(j), 1u) << name << " misses contact " << j << " query " << q;
            }
          }
        }
      }
    }
  }
  EXPECT_GT(contacts, 100u);  // not vacuous
  std::printf("%zu queries, %zu contacts\n", queries, contacts);
}

}  // namespace
