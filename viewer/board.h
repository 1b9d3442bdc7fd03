#pragma once
// The board between the LCM side of the viewer and its web server: the latest text of each
// topic (the map, the pose, the statistics, ...), each with a version that grows by one per
// post. A client remembers the version it has of each topic and asks for the next topic it
// lacks; what it missed while it was slow is gone, and only the newest is sent. So a slow
// client costs frames, never memory or LCM time: the board holds one text per topic, shared
// (not copied) by every client that is sending it.
//
// Threading: post() on one thread (LCM), next() on another (the web server); a mutex guards
// the slots, held only to swap or copy a shared pointer.

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace evermap::viewer {

enum class Topic : int {
  kGraph = 0,  // MAP_GRAPH, as nodes, edges and floors
  kPose,       // POSE
  kFloor,      // FLOOR
  kStats,      // MAPPER_STATS
  kHistory,    // nodes and component times against message time
  kRegister,   // REGISTER_RESULT counts and the latest
  kDeputy,     // DEPUTY_STATUS of every host
  kVo,         // VO_DELTA status
  kImage,      // the left image of STEREO, decimated, with the KEYFRAME features
  kViewer,     // the viewer's own counts (received, dropped, clients)
  kLog,        // --log: the log's span, the position, playing or not
  kPlans,      // --plans: the floor plans of evermap-map-export's folder (plan_folder.h)
  kCount
};
inline constexpr int kTopicCount = static_cast<int>(Topic::kCount);
const char* topicName(Topic t);

class Board {
 public:
  using Text = std::shared_ptr<const std::string>;
  // Versions a client holds, one per topic (0: none yet).
  using Seen = std::array<uint64_t, kTopicCount>;

  struct Item {
    Topic topic;
    uint64_t version;
    Text text;
    uint64_t skipped;  // versions of this topic the client never got
  };

  void post(Topic topic, std::string text);
  // The next topic after `after` (round robin, so a fast topic never starves the others) whose
  // version is newer than `seen`; `seen` is updated. Nothing when the client is up to date.
  std::optional<Item> next(Seen* seen, int after) const;
  uint64_t version(Topic topic) const;

 private:
  struct Slot {
    uint64_t version = 0;
    Text text;
  };
  mutable std::mutex mutex_;
  std::array<Slot, kTopicCount> slots_;
};

}  // namespace evermap::viewer
