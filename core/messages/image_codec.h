#pragma once
// The one encoder and decoder of evermap's gray images (image_t's data; the converters, the
// renderer, vo-proc and the tools all go through it, by way of convert.h's toMsg/fromMsg).
//
// Encodings (image_t.pixelformat):
//   FORMAT_GRAY8  raw rows (row_stride bytes apart);
//   FORMAT_PNG    a PNG file (OpenCV's libpng), written only when asked: other tools read it;
//   FORMAT_ZSTD   the default: a zstd frame (level 1) of `height` rows, each one predictor byte
//                 and `width` residuals r = pixel - prediction (mod 256). Predictors, from the
//                 left pixel a, the one above b and the one above-left c (0 outside the image):
//                 0 a, 1 b, 2 (a + b) / 2 (floor), 3 a + b - c (mod 256). The encoder picks a
//                 row's predictor by the smallest sum of |r| and keeps the smaller of that frame
//                 and the all-left one. Lossless; decodes ~7x faster than PNG at about PNG's
//                 size (docs/results/pipeline.md, 2026-11-29).
//
// Decoding never trusts the data: sizes are checked before anything is allocated (the PNG's
// header, the zstd frame's content size against height * (width + 1)), and every error is
// one line that names `what`.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/expected.h"

namespace evermap::messages {

enum class ImageEncoding {
  kGray8,  // raw bytes, row_stride == width
  kPng,    // lossless PNG of the gray image (readable by other tools)
  kZstd,   // lossless, predictor rows in a zstd frame (the default)
};
// Each encoding's name, as options and output take it: zstd, png, gray8.
const std::vector<std::pair<std::string, ImageEncoding>>& imageEncodingNames();
const char* toString(ImageEncoding e);

// Largest width or height a received image may claim (pixels): bounds the memory a
// malformed message can make a receiver allocate.
inline constexpr int kMaxImageSide = 16384;

// An image's data as image_t carries it.
struct EncodedImage {
  int32_t pixelformat = 0;  // image_t::FORMAT_*
  int32_t row_stride = 0;   // width for FORMAT_GRAY8, else 0
  std::vector<uint8_t> data;
};

// `image` must be CV_8UC1 and non-empty (else an error naming `what`).
Expected<EncodedImage> encodeImage(const cv::Mat& image, ImageEncoding encoding,
                                   const std::string& what);

// The width x height CV_8UC1 image of `data` in `pixelformat` (row_stride as image_t's). The
// size must be in 1..kMaxImageSide and match what the data says.
Expected<cv::Mat> decodeImage(int32_t pixelformat, int32_t width, int32_t height,
                              int32_t row_stride, const std::vector<uint8_t>& data,
                              const std::string& what);

// An image file's bytes (any format OpenCV reads) as an 8-bit gray image.
Expected<cv::Mat> decodeImageFile(const std::vector<uint8_t>& bytes, const std::string& what);

}  // namespace evermap::messages
