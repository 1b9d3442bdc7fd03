#pragma once
// The floor plans of a folder evermap-map-export wrote (docs/floor-plans.md), for the page:
// each floor-N.yaml and its image, read as ROS map_server reads them (p = (255 - v) / 255, or
// v / 255 with negate; occupied above occupied_thresh, free below free_thresh, else unknown),
// sent as one "plans" text (docs/viewer.md). The page draws the current floor's plan under
// the graph. A new export into the folder (after a loop closure moved nodes, the walls move
// with them) is picked up within PlanWatcher's period.
//
// A plan that cannot be read (a missing image, a malformed YAML or PGM, a size that does not
// match) is one line on stderr naming its file, counted, and left out; the other floors are
// shown.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/common/expected.h"
#include "viewer/board.h"

namespace evermap::viewer {

class WebServer;

// One floor's plan: cells row by row from the bottom (the map frame's y grows up the rows),
// each 0 unknown, 1 free, 2 occupied.
struct PlanImage {
  int floor = 0;
  double resolution_m = 0.0;
  double origin_x = 0.0, origin_y = 0.0, origin_yaw = 0.0;  // the bottom-left cell's corner
  int width = 0, height = 0;
  std::vector<uint8_t> cells;
};

// Reads floor-N.yaml (map_server's keys) and the PGM it names (P5, maxval up to 255). The
// error names the file and what is wrong.
Expected<PlanImage> readPlan(const std::filesystem::path& yaml);

// The "plans" text: per floor, its frame and its cells run-length coded ("u12f30o2...": a
// code, u unknown, f free, o occupied, then its run's length).
std::string plansText(const std::vector<PlanImage>& plans, const std::string& dir, int64_t refused);

class PlanFolder {
 public:
  explicit PlanFolder(std::filesystem::path dir) : dir_(std::move(dir)) {}
  // The "plans" text when the folder's plans changed since the last call (a file added,
  // removed or rewritten; always on the first call), else empty.
  std::optional<std::string> poll();
  int64_t refused() const { return refused_; }  // plans that could not be read, in all

 private:
  std::filesystem::path dir_;
  std::string last_listing_;  // names, sizes and times of the plan files last read
  bool polled_ = false;
  int64_t refused_ = 0;
};

// Polls a PlanFolder on a thread of its own every `period_s` and posts its text on the board
// (Topic::kPlans), waking the web server. Stops and joins when destroyed.
class PlanWatcher {
 public:
  PlanWatcher(std::filesystem::path dir, Board& board, WebServer& server, double period_s);
  ~PlanWatcher();
  PlanWatcher(const PlanWatcher&) = delete;
  PlanWatcher& operator=(const PlanWatcher&) = delete;

 private:
  void run();
  PlanFolder folder_;
  Board& board_;
  WebServer& server_;
  double period_s_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace evermap::viewer
