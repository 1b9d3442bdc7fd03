#pragma once
// Progress of long work (a log replayed, a run simulated, sessions rendered): one line at most
// every `period_s` of wall time, so that nothing long is silent. The clock is injected (tests
// drive it by hand); the work itself never reads it: it only decides when a line is printed.

#include <cstdint>
#include <functional>
#include <string>

namespace evermap {

// Where the work is. Data time is the time of the messages (simulated or logged).
struct Progress {
  double data_done_s = 0.0;
  double data_total_s = 0.0;  // <= 0: not known
  // The part of the work done, 0..1, when the data's total time is not known ahead (the events
  // read of a log's count); < 0: data_done_s / data_total_s. Neither known: no percentage and
  // no time left.
  double fraction = -1.0;
  int64_t steps = 0;   // frames, messages or steps: what `steps_name` says
  int64_t nodes = -1;  // graph nodes; < 0: not shown
};

// The programs' period: the reporter is asked once a step (a frame, a message, a texture), and
// a step can take a second or two on a loaded machine, so 8 s keeps the gaps under 10 s.
inline constexpr double kProgressPeriodS = 8.0;

class ProgressReporter {
 public:
  using Clock = std::function<double()>;  // seconds, monotonic
  using Sink = std::function<void(const std::string&)>;

  // `label` starts each line (the program's name), `steps_name` names Progress::steps
  // ("frames", "messages"). `sink` receives each line without its newline.
  ProgressReporter(std::string label, std::string steps_name, Sink sink,
                   double period_s = kProgressPeriodS, Clock clock = steadySeconds);

  // Prints a line when `period_s` has passed since the last one (or since construction).
  // Returns whether it printed.
  bool update(const Progress& p);
  // Prints a line now (the end of a part of the work, say).
  void report(const Progress& p);
  // The same for a stage without data time (setting up): "LABEL: TEXT".
  bool updateText(const std::string& text);
  void reportText(const std::string& text);
  // The line for `p` after `wall_s` seconds of work:
  //   "LABEL: data 12.0 / 60.0 s (20%), 240 frames, 3 nodes, 1.50x real time, 32 s left"
  // (the rate is data time per wall time; the time left is at the rate so far).
  std::string line(const Progress& p, double wall_s) const;

  // The steady clock, seconds.
  static double steadySeconds();

 private:
  std::string label_;
  std::string steps_name_;
  Sink sink_;
  double period_s_;
  Clock clock_;
  double start_s_;
  double last_s_;
};

// A sink that writes each line to stderr.
void printToStderr(const std::string& line);

}  // namespace evermap
