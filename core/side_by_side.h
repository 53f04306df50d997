#pragma once
// Independent jobs shared among threads: what verify (a session's videos), the report's sync
// self-check and the intrinsics (a session's cameras) do with the machine's cores.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace pvcap {

// Runs job(i, worker) for every i in [0, count), on at most `most_threads` threads and no more
// than the machine's cores or the jobs (the caller's thread is worker 0; `worker` lets a caller keep
// state per thread, such as a reader). The first exception a job throws stops the other threads at
// their next job and is rethrown here, once all have stopped.
template <typename Job>
void run_side_by_side(std::size_t count, std::size_t most_threads, Job&& job) {
  const std::size_t threads = std::min({std::size_t(std::max(1u, std::thread::hardware_concurrency())),
                                        std::max<std::size_t>(most_threads, 1), std::max<std::size_t>(count, 1)});
  std::atomic<std::size_t> next{0};
  std::mutex mutex;  // guards failure
  std::exception_ptr failure;
  auto work = [&](std::size_t worker) {
    try {
      for (std::size_t i = next++; i < count; i = next++) job(i, worker);
    } catch (...) {
      const std::lock_guard lock(mutex);
      if (!failure) failure = std::current_exception();
      next = count;  // the others stop at their next job
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace pvcap
