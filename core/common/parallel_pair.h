#pragma once
// Two independent tasks of one step run at once on two cores: the first on the caller's
// thread, the second on a worker thread that this object starts once and reuses for every
// step (a thread started per step costs ~50-100 µs, a hand-over to a waiting one ~10 µs).
// run() returns when both are done, so the tasks may write to disjoint parts of the caller's
// data without any other synchronisation, and the result does not depend on the timing: a
// split that gives each task its own outputs and merges them in a fixed order is
// deterministic.
//
// With threads = 1 there is no worker: run() calls the first task, then the second.
//
// Threading: run() is called from one thread at a time (the owner's); the tasks must not call
// run() of the same object.

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace evermap::core {

class ParallelPair {
 public:
  // Contract: threads is 1 or 2 (aborts otherwise).
  explicit ParallelPair(int threads);
  ~ParallelPair();
  ParallelPair(const ParallelPair&) = delete;
  ParallelPair& operator=(const ParallelPair&) = delete;

  // `first` here, `second` on the worker; returns when both are done. An exception of either
  // task is rethrown here (the first task's when both throw), after both are done.
  void run(const std::function<void()>& first, const std::function<void()>& second);

  int threads() const { return worker_.joinable() ? 2 : 1; }

 private:
  void work();

  std::mutex mutex_;
  std::condition_variable wake_;  // a task for the worker, or stop
  std::condition_variable done_;  // the worker's task is done
  const std::function<void()>* task_ = nullptr;
  bool stop_ = false;
  std::exception_ptr error_;
  std::thread worker_;  // last: started once the members above exist
};

// pair->run(first, second), or both here in that order without a pair.
inline void runBoth(ParallelPair* pair, const std::function<void()>& first,
                    const std::function<void()>& second) {
  if (pair != nullptr) {
    pair->run(first, second);
    return;
  }
  first();
  second();
}

}  // namespace evermap::core
