#pragma once
// What a floor plan is made of (evermap-map-export): the map store's nodes at their current
// poses (core/map/store_reader.h) and each node's keyframe from loopclose-proc's place store
// (core/bow/place_store.h, table keyframes: utime -> encoded keyframe_t), both opened read-only.
//
// A node's pose is world_T_body; its keyframe's points are in the rectified left camera's frame
// (keyframe_t.points). The camera's mounting body_T_cam is the one the mapper latched from
// STEREO_CALIB (rectified left camera) or RGBD_CALIB: neither store holds it, so it is given
// (from a log's calibration message or the simulator's camera). Then
//   p_map = world_T_body * body_T_cam * p_cam.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <sqlite3.h>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/map/map_snapshot.h"
#include "tools/map-export/occupancy_grid.h"

namespace evermap::map_export {

// loopclose-proc's place store, read-only: its keyframes by utime.
class KeyframeReader {
 public:
  static Expected<KeyframeReader> open(const std::filesystem::path& file);
  KeyframeReader(KeyframeReader&& o) noexcept;
  KeyframeReader& operator=(KeyframeReader&& o) noexcept;
  KeyframeReader(const KeyframeReader&) = delete;
  KeyframeReader& operator=(const KeyframeReader&) = delete;
  ~KeyframeReader();

  // The keyframe's points (left camera frame, metres); nullopt when none has that utime; an
  // error when its bytes do not decode or validate.
  Expected<std::optional<std::vector<core::Vec3>>> points(int64_t utime) const;
  // Rows and bytes of the keyframes table's messages.
  Expected<std::pair<int64_t, int64_t>> keyframeBytes() const;

 private:
  KeyframeReader(sqlite3* db, std::filesystem::path file) : db_(db), file_(std::move(file)) {}
  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
};

// One node, placed, with its keyframe's points in the map frame.
struct NodeScan {
  int64_t node = 0;
  int session = 0;
  int floor = 0;
  core::SE3d world_T_body;
  Scan scan;  // camera and points, map frame
};

struct ScanSet {
  std::vector<NodeScan> nodes;  // those whose keyframe was found and valid
  int64_t errors = 0;           // nodes left out (each one line in messages)
  std::vector<std::string> messages;
};

// Which way is up in the map frame: z (the mapper's body frame, gravity-aligned with an IMU),
// or -y (a body that is the camera itself, y down: evermap-kitti2lcm's logs, no IMU).
enum class UpAxis { kZ, kMinusY };
// The rotation that takes the map frame to the plans' frame (z up).
core::SE3d planTMap(UpAxis up);

// Every node of `map` with its keyframe's points, in the plans' frame (plan_T_map * map); a
// node without a keyframe, or with a pose or point that is not finite, is one message and
// counted, not fatal for the others.
ScanSet loadScans(const map::MapSnapshot& map, const KeyframeReader& keyframes,
                  const core::SE3d& body_T_cam, const core::SE3d& plan_T_map = {});

}  // namespace evermap::map_export
