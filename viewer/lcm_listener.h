#pragma once
// The viewer on LCM: subscribes (read-only, it publishes nothing) to MAP_GRAPH, POSE, FLOOR,
// MAPPER_STATS, REGISTER_RESULT, DEPUTY_STATUS, VO_DELTA, KEYFRAME and STEREO through a
// messages::Inbox (core/messages/inbox.h: one checked decoding path, the fragment guard,
// bounded queues, exceptions caught, every drop counted and logged in one line) and hands
// each message to ViewerState, which posts the page's texts on the Board.
//
// Load shedding on the LCM side: the queues are short (the viewer shows the newest state, it
// needs no backlog: LCM drops the oldest when the viewer falls behind), and a STEREO image is
// decoded only when one is due (at most one per image_period_s of wall time, display only),
// scaled down and sent as JPEG with the newest KEYFRAME's features.
// Threading: everything runs inside lcm.handle() on the caller's thread.

#include <chrono>
#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/common/expected.h"
#include "core/messages/inbox.h"
#include "viewer/board.h"
#include "viewer/viewer_state.h"

namespace evermap::viewer {

struct LcmListenerOptions {
  ViewerStateOptions state;
  // Seconds of wall time between two images sent to the page (0: every STEREO frame).
  double image_period_s = 0.5;
  // Width of the image sent to the page, pixels (larger images are scaled down).
  int image_width = 320;
  // The input boundary. The time guard is off: the viewer shows what arrives, and a wrong
  // stamp only misplaces one point of a plot.
  messages::Inbox::Options input = defaultInput();

  static messages::Inbox::Options defaultInput() {
    messages::Inbox::Options o;
    o.process = "evermap-viewer";
    o.queue_capacity = 30;
    o.time.window_s = 0.0;
    return o;
  }
  Status validate() const;
};

class LcmListener {
 public:
  // `lcm` and `board` must outlive the listener.
  LcmListener(lcm::LCM& lcm, Board& board, const LcmListenerOptions& options);

  // Posts the viewer's own counts (per channel received and dropped, plus `extra` JSON
  // members such as the web server's) on the board.
  void postCounts(const std::string& extra_members);
  const messages::Inbox& inbox() const { return inbox_; }
  const ViewerState& state() const { return state_; }
  int64_t imagesSent() const { return images_sent_; }

 private:
  Status onStereo(const void* data, int64_t size);

  Board& board_;
  LcmListenerOptions o_;
  ViewerState state_;
  std::chrono::steady_clock::time_point next_image_{};
  int64_t images_sent_ = 0;
  messages::Inbox inbox_;  // last: its handlers use the members above
};

}  // namespace evermap::viewer
