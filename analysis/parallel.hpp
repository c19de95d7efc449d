#pragma once
// Runs independent pieces of a statistics summary (the k(k-1)/2 pairs of pairwise tests and
// post-hoc p-values) on the machine's cores. Each index is computed by the same code as in a
// serial loop and writes only its own slot, so results are identical to the serial order's
// whatever the thread count (tests/analysis compares both).
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace palplab::analysis {

// Threads parallel_for uses at most (0 = std::thread::hardware_concurrency()); 1 = serial.
// Set by tests to compare the serial and parallel results.
inline std::atomic<unsigned>& analysis_threads() {
  static std::atomic<unsigned> n{0};
  return n;
}

// f(i) for i in [0, n), by up to analysis_threads() threads taking indices in turn; runs
// serially below `min_parallel` items. If any f(i) throws, the exception of the lowest such i
// is rethrown after every thread has stopped (the one a serial loop would throw: indices are
// taken in increasing order, so every lower index was taken and runs to its end).
template <class F>
void parallel_for(std::size_t n, const F& f, std::size_t min_parallel = 8) {
  unsigned threads = analysis_threads().load();
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, n));
  if (threads <= 1 || n < min_parallel) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::size_t error_index = n;
  std::mutex error_mutex;
  auto work = [&] {
    for (std::size_t i; !failed.load() && (i = next.fetch_add(1)) < n;) {
      try {
        f(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (i < error_index) {
          error_index = i;
          error = std::current_exception();
        }
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace palplab::analysis
