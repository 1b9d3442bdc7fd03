#pragma once
// The generic check of an LCM buffer before lcm-gen's decoder sees it.
//
// lcm-gen's C++ decoders (LCM 1.3.1) resize every variable-length array to the length the
// message claims before they check that the bytes are there, and lcm_coretypes.h computes an
// array's byte count in `int` (`sizeof(int64_t) * elements` overflows for 2^28 doubles): a
// 262-byte message claiming 2^28 distortion values made vo-proc allocate 2 GB and read past
// the buffer. A string length of 0 makes the decoder call `assign(p, -1)` (std::length_error).
//
// checkWire() walks the buffer along the type's layout, generated from lcmtypes/*.lcm for
// every type (<evermap/wire_layout.hpp>, cmake/lcm_wire_layout.py), without allocating:
// the type hash, then every member, every array dimension non-negative and no larger than
// the bytes left, every element's bytes present, every string length in [1, bytes left].
// Only then may the decoder run: what it allocates is bounded by the size of the buffer.

#include <cstdint>
#include <optional>

#include <evermap/wire_layout.hpp>

#include "core/common/expected.h"

namespace evermap::messages {

// The buffer's bytes used by one message of kTypes[type], hash included, or an Error naming
// the member (e.g. "camera_calib_t.left.num_distortion = 268435456: 2147483648 bytes of
// distortion, 180 left"). `hash` is the type's fingerprint (Msg::getHash()).
Expected<int64_t> checkWire(int type, int64_t hash, const void* data, int64_t size);

template <typename Msg>
Expected<int64_t> checkWire(const void* data, int64_t size) {
  return checkWire(wire::Layout<Msg>::kType, Msg::getHash(), data, size);
}

// The `int64_t utime` every evermap type has first (DESIGN.md section 2), read from a buffer of
// at least 16 bytes (after the 8-byte hash, big-endian); nullopt for a shorter one.
std::optional<int64_t> leadingUtime(const void* data, int64_t size);

}  // namespace evermap::messages
