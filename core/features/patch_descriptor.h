#pragma once
// The patch descriptor FOVIS matches frames with (Huang et al. 2011, section 3.4): the 9x9
// pixels around a corner at its pyramid level, offset so that their mean is 128 (robust to a
// change of brightness), compared by the sum of absolute differences. The 81st pixel (the
// bottom-right corner) is left out so a descriptor is five 16-byte vectors.

#include <array>
#include <cstdint>

#include <opencv2/core.hpp>

namespace evermap::core {

inline constexpr int kPatchRadius = 4;  // 9x9 patch
inline constexpr int kPatchBytes = 80;

struct alignas(16) PatchDescriptor {
  std::array<uint8_t, kPatchBytes> bytes{};
};

// The descriptor of the patch centred on integer pixel (u, v) of `image` (CV_8UC1).
// Precondition: the patch lies inside the image (kPatchRadius from every border); an
// always-on check aborts otherwise.
PatchDescriptor patchDescriptor(const cv::Mat& image, int u, int v);

// Sum of absolute differences, in [0, 80 * 255].
int patchSad(const PatchDescriptor& a, const PatchDescriptor& b);

}  // namespace evermap::core
