#include "core/common/parallel_pair.h"

#include <cstdio>
#include <cstdlib>

namespace evermap::core {

ParallelPair::ParallelPair(int threads) {
  if (threads != 1 && threads != 2) {
    std::fprintf(stderr, "evermap: ParallelPair: threads %d is not 1 or 2\n", threads);
    std::abort();
  }
  if (threads == 2) worker_ = std::thread([this] { work(); });
}

ParallelPair::~ParallelPair() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  worker_.join();
}

void ParallelPair::run(const std::function<void()>& first, const std::function<void()>& second) {
  if (!worker_.joinable()) {
    first();
    second();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    task_ = &second;
    error_ = nullptr;
  }
  wake_.notify_one();
  std::exception_ptr first_error;
  try {
    first();
  } catch (...) {
    first_error = std::current_exception();
  }
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return task_ == nullptr; });
  if (first_error) std::rethrow_exception(first_error);
  if (error_) std::rethrow_exception(error_);
}

void ParallelPair::work() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || task_ != nullptr; });
    if (stop_) return;
    const std::function<void()>* task = task_;
    lock.unlock();
    std::exception_ptr error;
    try {
      (*task)();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    error_ = error;
    task_ = nullptr;
    done_.notify_one();
  }
}

}  // namespace evermap::core
