#pragma once
// A 256-bit binary feature descriptor (ORB/BRIEF), the unit the vocabulary works on.
//
// Bytes are kept in the order OpenCV writes them (row of a CV_8UC1 Mat of 32 columns), so a
// descriptor read from a DBoW2/DBoW3 file, an LCM keyframe_t or cv::ORB compares equal byte
// for byte. Distances are Hamming distances (count of differing bits, 0..256), computed as four
// 64-bit popcounts; the byte order inside a word does not change a popcount.

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/expected.h"

// The loops that compute many Hamming distances are compiled twice on x86-64: with the POPCNT
// instruction, and for the baseline ISA (which lacks it and gets a bit-twiddling popcount);
// the dynamic loader picks the clone the CPU supports (GCC/Clang function multi-versioning).
// Quantising an image became 2.5x faster (docs/place-recognition.md).
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define EVERMAP_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define EVERMAP_POPCNT_CLONES
#endif

namespace evermap::bow {

inline constexpr int kDescriptorBytes = 32;
inline constexpr int kDescriptorBits = 8 * kDescriptorBytes;

struct alignas(32) Descriptor {
  std::array<uint8_t, kDescriptorBytes> bytes{};

  bool bit(int i) const { return (bytes[i >> 3] >> (i & 7)) & 1u; }
  void setBit(int i) { bytes[i >> 3] = static_cast<uint8_t>(bytes[i >> 3] | (1u << (i & 7))); }
  friend bool operator==(const Descriptor&, const Descriptor&) = default;
};

inline int hammingDistance(const Descriptor& a, const Descriptor& b) {
  uint64_t wa[4], wb[4];
  std::memcpy(wa, a.bytes.data(), sizeof(wa));
  std::memcpy(wb, b.bytes.data(), sizeof(wb));
  return std::popcount(wa[0] ^ wb[0]) + std::popcount(wa[1] ^ wb[1]) +
         std::popcount(wa[2] ^ wb[2]) + std::popcount(wa[3] ^ wb[3]);
}

// The rows of a CV_8UC1 matrix with 32 columns (what cv::ORB computes). An empty matrix gives
// no descriptors; any other type or width is an error naming `what`.
Expected<std::vector<Descriptor>> descriptorsFromMat(const cv::Mat& mat, const char* what);
// The inverse: an N x 32 CV_8UC1 matrix.
cv::Mat descriptorsToMat(const std::vector<Descriptor>& descriptors);
// From packed bytes (e.g. keyframe_t::descriptors, 32 bytes per feature).
Descriptor descriptorFromBytes(const uint8_t* bytes);

}  // namespace evermap::bow
