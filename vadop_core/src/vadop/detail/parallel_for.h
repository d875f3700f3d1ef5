// Runs independent iterations on a few threads (this one included): the narrow phase's pairs,
// the broad phase's bodies and cells, the monitor's bodies. Nothing is shared between
// iterations but what the caller shares. The threads are kept between calls (a process-wide
// pool, started on first need): starting threads for each call cost ~70 us on the 2-core
// machine, and a monitor cycle makes about ten calls (0.7 ms of a 1,000-body cycle of 4.7).
#pragma once

#include <cstddef>
#include <functional>

namespace vadop::detail {

// A configured thread count resolved: 0 means one per hardware thread; at least 1.
int threadCount(int configured);

// f(k) for k in [0, n) on up to `threads` threads, `chunk` consecutive k at a time (costs that
// vary by orders of magnitude balance out); on this thread alone when n < 2 * min_per_thread.
// Every k runs even when some throw; then the exception of the smallest k that threw is
// rethrown. A thread that cannot be started leaves its share to the others. A call made from
// inside an iteration runs on that thread alone; a call while another thread's call holds the
// pool starts threads of its own.
void parallelFor(int threads, size_t n, size_t min_per_thread, size_t chunk, const std::function<void(size_t)>& f);

// A run of parallelFor calls with short serial gaps between them (a world's prediction: about
// ten calls tens of microseconds apart). While one is open on any thread, the pool's workers
// wait for the next call spinning for up to 200 us; otherwise for 30 us, and they stop spinning
// the moment the last one closes: the caller's serial work after a run (the monitor's
// registry, messages, publishing) is not shared with a worker yielding on the other core.
class ParallelBatch {
 public:
  ParallelBatch();
  ~ParallelBatch();
  ParallelBatch(const ParallelBatch&) = delete;
  ParallelBatch& operator=(const ParallelBatch&) = delete;
};

// The blocks [begin, end) that split [0, n) into at most `blocks` parts of nearly equal size,
// in order (for work whose per-block results are merged in block order).
inline size_t blockBegin(size_t n, size_t blocks, size_t b) { return n * b / blocks; }

}  // namespace vadop::detail
