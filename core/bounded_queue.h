#pragma once
// A bounded multi-producer queue whose producers never wait: try_push fails
// when full and the caller counts the drop. Consumers may wait with a timeout.
// The lock is held only to move an element, so a device thread is delayed by
// nanoseconds, never by the consumer's work.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace pvcap {

template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity) {}

  // Returns false (and leaves `item` untouched) when full or closed.
  bool try_push(T& item) {
    {
      std::lock_guard lock(mu_);
      if (closed_ || items_.size() >= capacity_) return false;
      items_.push_back(std::move(item));
      if (items_.size() > high_water_) high_water_ = items_.size();
    }
    cv_.notify_one();
    return true;
  }

  // Waits up to `timeout` for an item; empty when the wait ran out, or when the queue is
  // closed and drained.
  std::optional<T> pop_for(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    // A zero timeout only looks: a wait, even one already timed out, is a futex call (workers look at
    // their losses and probes queues once per frame).
    if (timeout.count() > 0) cv_.wait_for(lock, timeout, [&] { return !items_.empty() || closed_; });
    if (items_.empty()) return std::nullopt;
      // GCC 12 reports moving a nested optional<vector> out of a deque as "used uninitialized"
      // (a known false positive at -O2); the element is fully constructed.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
    std::optional<T> item(std::in_place, std::move(items_.front()));
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
    items_.pop_front();
    return item;
  }

  // After close, pushes fail and consumers drain what is left.
  void close() {
    {
      std::lock_guard lock(mu_);
      closed_ = true;
    }
    cv_.notify_all();
  }

  bool closed() const {
    std::lock_guard lock(mu_);
    return closed_;
  }
  bool closed_and_empty() const {
    std::lock_guard lock(mu_);
    return closed_ && items_.empty();
  }
  std::size_t size() const {
    std::lock_guard lock(mu_);
    return items_.size();
  }
  std::size_t high_water() const {
    std::lock_guard lock(mu_);
    return high_water_;
  }

 private:
  const std::size_t capacity_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<T> items_;
  std::size_t high_water_ = 0;
  bool closed_ = false;
};

}  // namespace pvcap
