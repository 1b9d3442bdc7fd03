#pragma once
// Internal to the data-set converters (to_lcm.h): the time ordering of the events of a log.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/camera/calibration.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "tools/datasets/to_lcm.h"
#include "tools/lcmlog/log_writer.h"

namespace evermap::datasets::detail {

// The order of events with equal utime (to_lcm.h): IMU, ground truth, images.
enum class EventKind : uint8_t { kImu = 0, kGroundTruth = 1, kStereo = 2 };

struct PendingEvent {
  int64_t utime;
  EventKind kind;
  size_t index;  // into the converter's table of that kind
};

inline void sortByTime(std::vector<PendingEvent>* events) {
  std::stable_sort(events->begin(), events->end(),
                   [](const PendingEvent& a, const PendingEvent& b) {
                     return a.utime != b.utime ? a.utime < b.utime : a.kind < b.kind;
                   });
}

// STEREO_CALIB at `utime` when the repeat is due (channels::CalibrationRepeat): called at the
// log's first stamp and before every stereo pair.
inline Status writeCalibrationIfDue(messages::LogWriter& writer,
                                    channels::CalibrationRepeat& repeat,
                                    const core::StereoCalibration& calibration, int64_t utime) {
  if (!repeat.due(utime)) return Ok{};
  return writer.write(channels::kStereoCalib, utime, messages::toMsg(calibration, utime));
}

// Opens the log at `output` and writes STEREO_CALIB at the first event's time `first_utime`.
inline Expected<messages::LogWriter> openStereoLog(const std::filesystem::path& output,
                                                   channels::CalibrationRepeat& repeat,
                                                   const core::StereoCalibration& calibration,
                                                   int64_t first_utime) {
  auto writer = messages::LogWriter::open(output);
  if (!writer) return writer.error();
  if (Status s = writeCalibrationIfDue(*writer, repeat, calibration, first_utime); !s)
    return s.error();
  return writer;
}

// Writes `events` in order, each with `write` (Status(const PendingEvent&)), then commits the
// log. Returns `summary` with the log's message counts and size.
template <typename WriteEvent>
Expected<ConversionSummary> writeEvents(messages::LogWriter& writer,
                                        const std::vector<PendingEvent>& events,
                                        ConversionSummary summary, WriteEvent write) {
  for (const PendingEvent& e : events) {
    if (Status s = write(e); !s) return s.error();
  }
  summary.messages = writer.counts();
  summary.bytes = writer.bytes();
  if (Status s = writer.commit(); !s) return s.error();
  return summary;
}

}  // namespace evermap::datasets::detail
