#pragma once
// Frames dropped as vo-proc drops them behind its queue when the CPU is shared (issue 46): live,
// a frame that waits behind a slow one is lost, alone or in a burst when the other core is
// busy for a while. evermap-slam-run --drop-frames F replays that offline, seeded, so that what
// a lost frame costs the map can be measured and compared.
//
// A drop starts at a kept frame with probability q and takes `burst_frames` frames with
// probability `burst_probability` (else one). Runs of kept frames are geometric, so over a
// long run the fraction dropped is L q / (1 - q + L q) for a mean drop length L; q is chosen to
// make it `fraction`. Or the very frames a live vo-proc dropped (`utimes`, from its log's
// "dropped behind the queue: frame U" lines; --drop-utimes), so that a live run's map can be
// told apart into what its drops cost and what its timing did.

#include <cstdint>
#include <filesystem>
#include <random>
#include <unordered_set>
#include <vector>

#include "core/common/expected.h"

namespace evermap::slam_run {

struct FrameDropOptions {
  double fraction = 0.0;  // of the stereo/RGB-D frames, over a long run; 0: none
  double burst_probability = 0.3;
  int burst_frames = 5;  // 250 ms at 20 Hz: a core busy for a quarter second
  uint64_t seed = 1;
  std::vector<int64_t> utimes;  // frames dropped by their utime, besides `fraction`'s

  Status validate() const;
};

// The frame times of `file`: vo-proc's "dropped behind the queue: frame U" lines (a deputy's
// vo-proc.log as it is) or lines holding one integer; other lines are skipped. None is fine
// for a vo-proc log whose summary says it dropped nothing. Errors: the file cannot be read; no
// frame time and no such summary; a time before the one above it (the log of several runs).
Expected<std::vector<int64_t>> readDroppedFrames(const std::filesystem::path& file);

class FrameDropper {
 public:
  explicit FrameDropper(const FrameDropOptions& options = {});
  // Whether the next frame (taken at `utime`) is dropped.
  bool drop(int64_t utime);
  int64_t dropped() const { return dropped_; }
  int64_t namedDropped() const { return named_dropped_; }  // by FrameDropOptions::utimes
  int64_t frames() const { return frames_; }

 private:
  double burst_probability_;
  int burst_frames_;
  double start_probability_ = 0.0;
  std::mt19937_64 rng_;
  std::unordered_set<int64_t> utimes_;
  int remaining_ = 0;  // frames of the current drop still to go
  int64_t dropped_ = 0;
  int64_t named_dropped_ = 0;
  int64_t frames_ = 0;
};

}  // namespace evermap::slam_run
