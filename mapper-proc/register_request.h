#pragma once
// The REGISTER_REQUEST the Mapper and the Localizer send for their keyframe in flight.

#include <cstdint>

#include <evermap/register_request_t.hpp>

namespace evermap::mapper {

// A request about `keyframe_utime`: in MODE_NODE against node `target`, in MODE_GLOBAL an
// appearance search on `floor` (-1: every floor).
inline register_request_t makeRegisterRequest(int64_t request_id, int64_t keyframe_utime,
                                              int8_t mode, int64_t target, int floor, int session) {
  register_request_t r{};
  r.utime = keyframe_utime;
  r.request_id = request_id;
  r.keyframe_utime = keyframe_utime;
  r.mode = mode;
  r.target_node_id = mode == register_request_t::MODE_NODE ? target : -1;
  r.floor = floor;
  r.session = session;
  return r;
}

}  // namespace evermap::mapper
