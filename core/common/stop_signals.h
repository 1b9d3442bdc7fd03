#pragma once
// SIGINT and SIGTERM for a process's main loop, without a handler or a global flag: the
// constructor blocks both (threads started afterwards inherit the mask), and requested()
// polls for a pending one without waiting. Construct it in main() before starting threads.
//
//   StopSignals stop;
//   while (!stop.requested()) lcm.handleTimeout(200);

#include <csignal>

namespace evermap {

class StopSignals {
 public:
  StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  // True once SIGINT or SIGTERM has arrived (it stays true).
  bool requested();

 private:
  sigset_t set_;
  bool seen_ = false;
};

}  // namespace evermap
