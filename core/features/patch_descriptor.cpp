#include "core/features/patch_descriptor.h"

#include <emmintrin.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace evermap::core {

PatchDescriptor patchDescriptor(const cv::Mat& image, int u, int v) {
  constexpr int r = kPatchRadius;
  if (image.type() != CV_8UC1 || u < r || v < r || u >= image.cols - r || v >= image.rows - r) {
    std::fprintf(stderr, "evermap: patchDescriptor at (%d, %d) outside a %dx%d image\n", u, v,
                 image.cols, image.rows);
    std::abort();
  }
  PatchDescriptor d;
  int sum = 0;
  int n = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const uint8_t* row = image.ptr<uint8_t>(v + dy) + u;
    for (int dx = -r; dx <= r && n < kPatchBytes; ++dx) {
      d.bytes[static_cast<size_t>(n++)] = row[dx];
      sum += row[dx];
    }
  }
  const int offset = 128 - (sum + kPatchBytes / 2) / kPatchBytes;
  for (uint8_t& b : d.bytes) b = static_cast<uint8_t>(std::clamp(b + offset, 0, 255));
  return d;
}

int patchSad(const PatchDescriptor& a, const PatchDescriptor& b) {
  __m128i acc = _mm_setzero_si128();
  for (int i = 0; i < kPatchBytes; i += 16) {
    const __m128i x = _mm_load_si128(reinterpret_cast<const __m128i*>(a.bytes.data() + i));
    const __m128i y = _mm_load_si128(reinterpret_cast<const __m128i*>(b.bytes.data() + i));
    acc = _mm_add_epi64(acc, _mm_sad_epu8(x, y));
  }
  return _mm_cvtsi128_si32(acc) + _mm_extract_epi16(acc, 4);
}

}  // namespace evermap::core
