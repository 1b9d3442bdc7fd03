#pragma once
// A bounded first-in first-out queue between the thread that receives frames and the one that
// processes them. When it is full, push() drops the *oldest* element and counts it: a visual
// odometry process that falls behind should work on the newest images, not on a growing
// backlog (DESIGN.md: "drops the oldest frames (bounded queue) and counts them").
//
// With Full::kWait instead, push() waits for room: an offline reader that runs ahead of its
// consumer by at most `capacity` elements and loses none (evermap-slam-run).
//
// Thread-safe: any number of producers and consumers.

#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <mutex>
#include <optional>
#include <utility>

namespace evermap::vo {

template <typename T>
class BoundedQueue {
 public:
  enum class Full { kDropOldest, kWait };

  // Contract: capacity >= 1 (checked, aborts otherwise).
  explicit BoundedQueue(size_t capacity, Full when_full = Full::kDropOldest)
      : capacity_(capacity), when_full_(when_full) {
    if (capacity == 0) {
      std::fputs("evermap: BoundedQueue capacity must be positive\n", stderr);
      std::abort();
    }
  }

  // Appends; when full, the oldest element is dropped first (moved to *dropped when given).
  // Returns false (and drops the element) after close().
  bool push(T value, std::optional<T>* dropped = nullptr) {
    if (dropped != nullptr) dropped->reset();
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (when_full_ == Full::kWait)
        room_.wait(lock, [this] { return closed_ || items_.size() < capacity_; });
      if (closed_) return false;
      if (items_.size() >= capacity_) {
        if (dropped != nullptr) *dropped = std::move(items_.front());
        items_.pop_front();
        ++dropped_;
      }
      items_.push_back(std::move(value));
      ++pushed_;
    }
    ready_.notify_one();
    return true;
  }

  // Waits for an element; nullopt once the queue is closed and empty.
  std::optional<T> pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [this] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    T value = std::move(items_.front());
    items_.pop_front();
    lock.unlock();
    room_.notify_one();
    return value;
  }

  // Wakes every waiting pop(); elements already queued can still be popped.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }

  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }
  int64_t dropped() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return dropped_;
  }
  int64_t pushed() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pushed_;
  }

 private:
  const size_t capacity_;
  const Full when_full_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable room_;  // Full::kWait: an element was popped
  std::deque<T> items_;
  bool closed_ = false;
  int64_t dropped_ = 0;
  int64_t pushed_ = 0;
};

}  // namespace evermap::vo
