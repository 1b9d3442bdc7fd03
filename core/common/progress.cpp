#include "core/common/progress.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

namespace evermap {
namespace {

// "42 s", "3 min 20 s", "2 h 05 min": what a person reads at a glance.
std::string duration(double s) {
  const auto total = static_cast<int64_t>(std::llround(std::max(0.0, s)));
  std::ostringstream o;
  if (total < 60) {
    o << total << " s";
  } else if (total < 3600) {
    o << total / 60 << " min " << total % 60 << " s";
  } else {
    const int64_t min = (total % 3600) / 60;
    o << total / 3600 << " h " << (min < 10 ? "0" : "") << min << " min";
  }
  return o.str();
}

}  // namespace

ProgressReporter::ProgressReporter(std::string label, std::string steps_name, Sink sink,
                                   double period_s, Clock clock)
    : label_(std::move(label)),
      steps_name_(std::move(steps_name)),
      sink_(std::move(sink)),
      period_s_(period_s),
      clock_(std::move(clock)),
      start_s_(clock_()),
      last_s_(start_s_) {}

bool ProgressReporter::update(const Progress& p) {
  const double now = clock_();
  if (now - last_s_ < period_s_) return false;
  last_s_ = now;
  sink_(line(p, now - start_s_));
  return true;
}

void ProgressReporter::report(const Progress& p) {
  last_s_ = clock_();
  sink_(line(p, last_s_ - start_s_));
}

bool ProgressReporter::updateText(const std::string& text) {
  const double now = clock_();
  if (now - last_s_ < period_s_) return false;
  last_s_ = now;
  sink_(label_ + ": " + text);
  return true;
}

void ProgressReporter::reportText(const std::string& text) {
  last_s_ = clock_();
  sink_(label_ + ": " + text);
}

std::string ProgressReporter::line(const Progress& p, double wall_s) const {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  o << label_ << ": data " << p.data_done_s;
  if (p.data_total_s > 0.0) o << " / " << p.data_total_s;
  o << " s";
  const double fraction = p.fraction >= 0.0      ? std::min(1.0, p.fraction)
                          : p.data_total_s > 0.0 ? std::min(1.0, p.data_done_s / p.data_total_s)
                                                 : -1.0;
  if (fraction >= 0.0) o << " (" << static_cast<int>(std::floor(100.0 * fraction)) << "%)";
  o << ", " << p.steps << " " << steps_name_;
  if (p.nodes >= 0) o << ", " << p.nodes << " nodes";
  if (wall_s > 0.0 && p.data_done_s > 0.0) {
    o.precision(2);
    o << ", " << p.data_done_s / wall_s << "x real time";
  }
  if (wall_s > 0.0 && fraction > 0.0)
    o << ", " << duration(wall_s * (1.0 - fraction) / fraction) << " left";
  return o.str();
}

double ProgressReporter::steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void printToStderr(const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); }

}  // namespace evermap
