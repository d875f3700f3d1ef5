#include "vadop/detail/parallel_for.h"
#include "vadop/world.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace vadop::detail {

int threadCount(int configured) {
  // Asked once: glibc reads /sys for it at every call (a monitor cycle asks several times).
  static const int hardware = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return configured > 0 ? configured : hardware;
}

namespace {

// One call's iterations, shared by the threads that run it: each takes the next `chunk` of
// indices until none is left; the exception of the smallest index that threw is kept.
struct Job {
  size_t n = 0;
  size_t chunk = 1;
  const std::function<void(size_t)>* f = nullptr;
  // On a cache line of its own: every take writes it, and the fields above, which every take
  // reads, would otherwise move between the cores with it.
  alignas(64) std::atomic<size_t> next{0};
  alignas(64) std::mutex error_lock;
  size_t error_at = 0;
  std::exception_ptr error;

  void run() {
    const size_t count = n, step = chunk;
    const std::function<void(size_t)>& body = *f;
    for (;;) {
      const size_t begin = next.fetch_add(step);
      if (begin >= count) return;
      const size_t end = std::min(begin + step, count);
      for (size_t k = begin; k < end; ++k) {
        try {
          body(k);
        } catch (...) {
          const std::lock_guard<std::mutex> lock(error_lock);
          if (k < error_at) {
            error_at = k;
            error = std::current_exception();
          }
        }
      }
    }
  }
};

// Set on every thread while it runs a call's iterations: a call made from inside an iteration
// runs on its thread alone (no nesting: the pool serves one call at a time).
thread_local bool tl_inside_call = false;

// ParallelBatch objects alive, on any thread.
std::atomic<int> open_batches{0};

void runInside(Job& job) {
  const bool outer = tl_inside_call;
  tl_inside_call = true;
  job.run();
  tl_inside_call = outer;
}

// Workers kept between calls: a cycle makes about ten calls of a few milliseconds each, and
// starting threads for each cost ~70 us a call on the 2-core machine. A worker that finishes
// a job spins briefly for the next (the calls of a cycle follow each other within
// microseconds) and then sleeps. One call at a time uses the pool; a second caller meanwhile
// (another thread of the process) starts threads of its own, as every call did before.
class WorkerPool {
 public:
  static WorkerPool& instance() {
    static WorkerPool pool;
    return pool;
  }

  ~WorkerPool() {
    {
      const std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
      ++generation_;
      generation_spin_.store(generation_, std::memory_order_release);
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  std::unique_lock<std::mutex> tryAcquire() { return std::unique_lock<std::mutex>(call_, std::try_to_lock); }

  // Runs `job` on this thread and `helpers` workers (started on first need); returns when all
  // are done with it. The caller holds tryAcquire()'s lock.
  void run(Job& job, size_t helpers) {
    {
      std::unique_lock<std::mutex> lock(m_);
      while (threads_.size() < helpers) {
        const size_t index = threads_.size();
        try {
          threads_.emplace_back([this, index] { work(index); });
        } catch (...) {
          break;  // no thread to be had: fewer helpers
        }
      }
      helpers = std::min(helpers, threads_.size());
      job_ = &job;
      wanted_ = helpers;
      done_.store(0, std::memory_order_relaxed);
      generation_spin_.store(generation_ + 1, std::memory_order_release);
      ++generation_;
    }
    wake_.notify_all();
    runInside(job);
    // The helpers finish within microseconds of this thread when the work is balanced: wait
    // for them spinning a little before sleeping.
    const auto spin_until = std::chrono::steady_clock::now() + std::chrono::microseconds(kBatchSpinMicros);
    while (done_.load(std::memory_order_acquire) != helpers && std::chrono::steady_clock::now() < spin_until) {
      std::this_thread::yield();
    }
    std::unique_lock<std::mutex> lock(m_);
    finished_.wait(lock, [&] { return done_.load(std::memory_order_acquire) == wanted_; });
    job_ = nullptr;
  }

 private:
  WorkerPool() = default;

  void work(size_t index) {
    uint64_t seen = 0;
    for (;;) {
      // Spin a little for the next call before sleeping on the lock.
      const auto spun_from = std::chrono::steady_clock::now();
      while (generation_spin_.load(std::memory_order_acquire) == seen &&
             std::chrono::steady_clock::now() - spun_from < std::chrono::microseconds(spinMicros())) {
        std::this_thread::yield();
      }
      Job* job = nullptr;
      {
        std::unique_lock<std::mutex> lock(m_);
        wake_.wait(lock, [&] { return generation_ != seen; });
        seen = generation_;
        if (stop_) return;
        if (index >= wanted_) continue;  // this call wants fewer workers
        job = job_;
      }
      runInside(*job);
      done_.fetch_add(1, std::memory_order_acq_rel);
      // Through the lock: the caller either sees the count before it sleeps or is woken.
      { const std::lock_guard<std::mutex> lock(m_); }
      finished_.notify_one();
    }
  }

  // How long a worker spins for the next call: within an open ParallelBatch long enough for
  // the gaps between a prediction's calls, else only for calls in a row (parallel_for.h).
  // Through ROS transport at 1,000 robots in one array at 30 Hz the node took 15.8-15.9% of a
  // core with every wait at 200 us, 14.6-14.7% at 30 us; but the cycle (in-process bench) took
  // up to 10% longer at 30 us, a prediction's calls meeting sleeping workers.
  static constexpr int kBatchSpinMicros = 200, kSpinMicros = 30;
  static int spinMicros() { return open_batches.load(std::memory_order_relaxed) > 0 ? kBatchSpinMicros : kSpinMicros; }

  std::mutex call_;  // one call at a time
  std::mutex m_;
  std::condition_variable wake_, finished_;
  std::vector<std::thread> threads_;
  Job* job_ = nullptr;
  size_t wanted_ = 0;
  std::atomic<size_t> done_{0};  // helpers finished with the current job
  uint64_t generation_ = 0;
  std::atomic<uint64_t> generation_spin_{0};  // generation_, readable without the lock
  bool stop_ = false;
};

}  // namespace

void parallelFor(int threads, size_t n, size_t min_per_thread, size_t chunk, const std::function<void(size_t)>& f) {
  const size_t workers = std::min(static_cast<size_t>(std::max(threads, 1)), n / std::max<size_t>(min_per_thread, 1));
  if (workers <= 1 || tl_inside_call) {
    // One thread's worth, or a call from inside another call's iteration: here, in order.
    for (size_t k = 0; k < n; ++k) f(k);
    return;
  }
  Job job;
  job.n = n;
  job.chunk = std::max<size_t>(chunk, 1);
  job.f = &f;
  job.error_at = n;
  WorkerPool& pool = WorkerPool::instance();
  if (auto lock = pool.tryAcquire(); lock.owns_lock()) {
    pool.run(job, workers - 1);
  } else {
    std::vector<std::thread> own;
    own.reserve(workers - 1);
    try {
      for (size_t i = 1; i < workers; ++i) own.emplace_back([&job] { runInside(job); });
    } catch (...) {
      // No thread to be had: this one does the rest.
    }
    runInside(job);
    for (std::thread& t : own) t.join();
  }
  if (job.error) std::rethrow_exception(job.error);
}

ParallelBatch::ParallelBatch() { open_batches.fetch_add(1, std::memory_order_relaxed); }
ParallelBatch::~ParallelBatch() { open_batches.fetch_sub(1, std::memory_order_relaxed); }

}  // namespace vadop::detail

namespace vadop {

int threadCount(int configured) { return detail::threadCount(configured); }

void parallelFor(int threads, size_t n, size_t min_per_thread, size_t chunk, const std::function<void(size_t)>& f) {
  detail::parallelFor(threads, n, min_per_thread, chunk, f);
}

}  // namespace vadop
