#include "vadop/detail/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace vadop::detail {

int threadCount(int configured) {
  return configured > 0 ? configured : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

void parallelFor(int threads, size_t n, size_t min_per_thread, size_t chunk, const std::function<void(size_t)>& f) {
  const size_t workers = std::min(static_cast<size_t>(std::max(threads, 1)), n / std::max<size_t>(min_per_thread, 1));
  if (workers <= 1) {
    for (size_t k = 0; k < n; ++k) f(k);
    return;
  }
  chunk = std::max<size_t>(chunk, 1);
  std::atomic<size_t> next{0};
  std::mutex error_lock;
  size_t error_at = n;
  std::exception_ptr error;
  auto work = [&]() {
    for (;;) {
      const size_t begin = next.fetch_add(chunk);
      if (begin >= n) return;
      const size_t end = std::min(begin + chunk, n);
      for (size_t k = begin; k < end; ++k) {
        try {
          f(k);
        } catch (...) {
          const std::lock_guard<std::mutex> lock(error_lock);
          if (k < error_at) {
            error_at = k;
            error = std::current_exception();
          }
        }
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  try {
    for (size_t i = 1; i < workers; ++i) pool.emplace_back(work);
  } catch (...) {
    // No thread to be had: this one does the rest.
  }
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace vadop::detail
