// detail::parallelFor: every index once, exceptions, nesting, concurrent callers, threads kept
// between calls, and batches (ParallelBatch) losing no call.
#include "vadop/detail/parallel_for.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

using vadop::detail::parallelFor;

namespace {

// Runs parallelFor and checks that each index ran exactly once; returns the threads seen.
std::set<std::thread::id> runOnce(int threads, size_t n, size_t min_per_thread, size_t chunk) {
  std::vector<std::atomic<int>> count(n);
  std::mutex lock;
  std::set<std::thread::id> seen;
  parallelFor(threads, n, min_per_thread, chunk, [&](size_t k) {
    count[k].fetch_add(1);
    const std::lock_guard<std::mutex> guard(lock);
    seen.insert(std::this_thread::get_id());
  });
  for (size_t k = 0; k < n; ++k) EXPECT_EQ(count[k].load(), 1) << "index " << k << " of " << n;
  return seen;
}

}  // namespace

TEST(ParallelFor, EveryIndexExactlyOnce) {
  for (int threads : {1, 2, 3, 8}) {
    for (size_t n : {0u, 1u, 7u, 64u, 1000u, 4097u}) {
      for (size_t chunk : {1u, 8u, 1024u}) runOnce(threads, n, 4, chunk);
    }
  }
}

TEST(ParallelFor, SmallestThrowingIndexIsRethrownAfterEveryIndexRan) {
  for (int round = 0; round < 50; ++round) {
    std::vector<std::atomic<int>> count(500);
    try {
      parallelFor(4, 500, 1, 3, [&](size_t k) {
        count[k].fetch_add(1);
        if (k == 77 || k == 300 || k == 499) throw std::runtime_error(std::to_string(k));
      });
      FAIL() << "nothing thrown";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "77");
    }
    for (auto& c : count) ASSERT_EQ(c.load(), 1);
  }
}

TEST(ParallelFor, CallsFromInsideAnIterationRunThere) {
  std::vector<std::atomic<int>> count(64 * 64);
  parallelFor(4, 64, 1, 1, [&](size_t i) {
    const std::thread::id outer = std::this_thread::get_id();
    parallelFor(4, 64, 1, 1, [&](size_t j) {
      EXPECT_EQ(std::this_thread::get_id(), outer);
      count[64 * i + j].fetch_add(1);
    });
  });
  for (auto& c : count) ASSERT_EQ(c.load(), 1);
}

TEST(ParallelFor, ConcurrentCallersEachGetEveryIndexOnce) {
  std::vector<std::thread> callers;
  std::atomic<int> failures{0};
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&failures] {
      for (int round = 0; round < 200; ++round) {
        const size_t n = 100 + round;
        std::vector<std::atomic<int>> count(n);
        parallelFor(3, n, 1, 4, [&](size_t k) { count[k].fetch_add(1); });
        for (auto& x : count) failures += x.load() != 1;
      }
    });
  }
  for (auto& t : callers) t.join();
  EXPECT_EQ(failures.load(), 0);
}

// The calls of one thread reuse the same helper threads (what makes a call cheap): over many
// calls no more helpers appear than the most threads asked for at once, minus this one.
TEST(ParallelFor, HelperThreadsAreKeptBetweenCalls) {
  std::set<std::thread::id> helpers;
  auto call = [&](int threads) {
    std::mutex lock;
    std::set<std::thread::id> seen;
    parallelFor(threads, 400, 1, 1, [&](size_t) {
      // A few microseconds each, so that the helpers take part.
      const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(5);
      while (std::chrono::steady_clock::now() < until) {
      }
      const std::lock_guard<std::mutex> guard(lock);
      seen.insert(std::this_thread::get_id());
    });
    seen.erase(std::this_thread::get_id());
    EXPECT_LE(seen.size(), static_cast<size_t>(threads - 1));
    helpers.insert(seen.begin(), seen.end());
  };
  for (int k = 0; k < 40; ++k) call(3);
  for (int k = 0; k < 40; ++k) call(2);
  EXPECT_GE(helpers.size(), 1u);
  EXPECT_LE(helpers.size(), 2u) << "helpers started anew for calls";
}

// Workers spin for the next call longer while a batch is open and stop spinning the moment the
// last one closes (a changing exit condition of their wait): no call may be lost or wait for
// ever whether it comes right after the previous one, after the workers went to sleep, while
// batches open and close on two threads, or nested.
TEST(ParallelFor, BatchesLoseNoCall) {
  using vadop::detail::ParallelBatch;
  const auto pause = [](int micros) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(micros);
    while (std::chrono::steady_clock::now() < until) {
    }
  };
  for (int gap : {0, 20, 100, 400, 2000}) {
    {
      const ParallelBatch batch;
      for (int k = 0; k < 20; ++k) {
        runOnce(2, 256, 1, 4);
        pause(gap);
      }
      {
        const ParallelBatch nested;
        runOnce(3, 256, 1, 4);
      }
      runOnce(2, 256, 1, 4);
    }
    for (int k = 0; k < 20; ++k) {
      runOnce(2, 256, 1, 4);
      pause(gap);
    }
  }
  std::thread other([&] {
    for (int k = 0; k < 200; ++k) {
      const ParallelBatch batch;
      runOnce(2, 128, 1, 4);
    }
  });
  for (int k = 0; k < 200; ++k) {
    if (k % 2 == 0) {
      const ParallelBatch batch;
      runOnce(2, 128, 1, 4);
    } else {
      runOnce(2, 128, 1, 4);
    }
  }
  other.join();
}
