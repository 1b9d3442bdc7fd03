#include "core/messages/image_codec.h"

#include <array>
#include <cstdlib>
#include <cstring>
#include <memory>

#include <zstd.h>

#include <opencv2/imgcodecs.hpp>

#include <evermap/image_t.hpp>

namespace evermap::messages {
namespace {

constexpr std::array<uint8_t, 8> kPngSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// zstd level 1: on evermap's images the higher levels make larger frames (their matches cost
// more than the residuals' Huffman coding saves) and encode 2-4x slower.
constexpr int kZstdLevel = 1;

enum Predictor : uint8_t { kLeft = 0, kUp = 1, kAverage = 2, kGradient = 3, kPredictors = 4 };

bool isPng(const std::vector<uint8_t>& bytes) {
  return bytes.size() >= kPngSignature.size() &&
         std::memcmp(bytes.data(), kPngSignature.data(), kPngSignature.size()) == 0;
}

// Width and height from a PNG's IHDR chunk (bytes 16..23, big-endian), read before decoding
// so a message cannot make the decoder allocate more than it announced.
bool pngSize(const std::vector<uint8_t>& bytes, int64_t* width, int64_t* height) {
  if (bytes.size() < 24 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) return false;
  auto be32 = [&bytes](size_t at) {
    return (int64_t{bytes[at]} << 24) | (int64_t{bytes[at + 1]} << 16) |
           (int64_t{bytes[at + 2]} << 8) | int64_t{bytes[at + 3]};
  };
  *width = be32(16);
  *height = be32(20);
  return true;
}

// ---- Predictor rows ----

// The residuals of `row` (above: the row over it, zeros for the first) under predictor p.
void residuals(const uint8_t* row, const uint8_t* above, int width, Predictor p, uint8_t* out) {
  int a = 0, c = 0;
  for (int i = 0; i < width; ++i) {
    const int b = above[i];
    int predicted = a;
    if (p == kUp) predicted = b;
    if (p == kAverage) predicted = (a + b) >> 1;
    if (p == kGradient) predicted = a + b - c;
    out[i] = static_cast<uint8_t>(row[i] - predicted);
    a = row[i];
    c = b;
  }
}

int cost(const uint8_t* r, int width) {
  int sum = 0;
  for (int i = 0; i < width; ++i) sum += std::abs(static_cast<int8_t>(r[i]));
  return sum;
}

// The image as predictor rows: each row's best predictor when `adaptive`, else left for all.
std::vector<uint8_t> predictorRows(const cv::Mat& image, bool adaptive) {
  const int w = image.cols;
  std::vector<uint8_t> out(static_cast<size_t>(w + 1) * image.rows);
  const std::vector<uint8_t> zeros(w, 0);
  std::vector<uint8_t> trial(w);
  for (int r = 0; r < image.rows; ++r) {
    const uint8_t* above = r > 0 ? image.ptr(r - 1) : zeros.data();
    uint8_t* dst = out.data() + static_cast<size_t>(r) * (w + 1);
    Predictor best = kLeft;
    residuals(image.ptr(r), above, w, kLeft, dst + 1);
    if (adaptive) {
      int best_cost = cost(dst + 1, w);
      for (uint8_t p = kUp; p < kPredictors; ++p) {
        residuals(image.ptr(r), above, w, static_cast<Predictor>(p), trial.data());
        const int c = cost(trial.data(), w);
        if (c < best_cost) {
          best_cost = c;
          best = static_cast<Predictor>(p);
          std::memcpy(dst + 1, trial.data(), w);
        }
      }
    }
    dst[0] = best;
  }
  return out;
}

// One row back from its residuals; false for an unknown predictor.
bool restoreRow(const uint8_t* in, const uint8_t* above, int width, uint8_t* row) {
  const uint8_t* r = in + 1;
  switch (in[0]) {
    case kLeft: {
      uint8_t a = 0;
      for (int i = 0; i < width; ++i) row[i] = a = static_cast<uint8_t>(a + r[i]);
      return true;
    }
    case kUp:
      for (int i = 0; i < width; ++i) row[i] = static_cast<uint8_t>(r[i] + above[i]);
      return true;
    case kAverage: {
      int a = 0;
      for (int i = 0; i < width; ++i) {
        a = (r[i] + ((a + above[i]) >> 1)) & 0xff;
        row[i] = static_cast<uint8_t>(a);
      }
      return true;
    }
    case kGradient: {
      // x[i] = r[i] + b[i] - b[i-1] + x[i-1]: the up differences, then a running sum.
      int c = 0;
      for (int i = 0; i < width; ++i) {
        row[i] = static_cast<uint8_t>(r[i] + above[i] - c);
        c = above[i];
      }
      uint8_t a = 0;
      for (int i = 0; i < width; ++i) row[i] = a = static_cast<uint8_t>(a + row[i]);
      return true;
    }
    default:
      return false;
  }
}

// ---- zstd ----

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};

// One context per thread, reused (creating one allocates ~100 KB-1 MB).
ZSTD_CCtx* compressContext() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxFree> ctx(ZSTD_createCCtx());
  return ctx.get();
}
ZSTD_DCtx* decompressContext() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxFree> ctx(ZSTD_createDCtx());
  return ctx.get();
}

Expected<std::vector<uint8_t>> compress(const std::vector<uint8_t>& raw, const std::string& what) {
  std::vector<uint8_t> out(ZSTD_compressBound(raw.size()));
  const size_t n = ZSTD_compressCCtx(compressContext(), out.data(), out.size(), raw.data(),
                                     raw.size(), kZstdLevel);
  if (ZSTD_isError(n))
    return makeError(what, ": zstd encoding failed (", ZSTD_getErrorName(n), ")");
  out.resize(n);
  return out;
}

Expected<EncodedImage> encodeZstd(const cv::Mat& image, const std::string& what) {
  auto adaptive = compress(predictorRows(image, true), what);
  if (!adaptive) return adaptive.error();
  auto left = compress(predictorRows(image, false), what);
  if (!left) return left.error();
  EncodedImage e;
  e.pixelformat = evermap::image_t::FORMAT_ZSTD;
  e.data = std::move(left->size() < adaptive->size() ? *left : *adaptive);
  return e;
}

Expected<cv::Mat> decodeZstd(int width, int height, const std::vector<uint8_t>& data,
                             const std::string& what) {
  const size_t need = static_cast<size_t>(width + 1) * height;
  const unsigned long long content = ZSTD_getFrameContentSize(data.data(), data.size());
  if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN) {
    return makeError(what, ": pixelformat ZSTD but the data is not a zstd frame of known size");
  }
  if (content != need) {
    return makeError(what, ": the zstd frame holds ", content, " bytes, ", width, "x", height,
                     " needs ", need);
  }
  std::vector<uint8_t> rows(need);
  const size_t n =
      ZSTD_decompressDCtx(decompressContext(), rows.data(), need, data.data(), data.size());
  if (ZSTD_isError(n) || n != need) {
    return makeError(what, ": corrupt zstd frame (",
                     ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short", ")");
  }
  cv::Mat image(height, width, CV_8UC1);
  const std::vector<uint8_t> zeros(width, 0);
  for (int r = 0; r < height; ++r) {
    const uint8_t* above = r > 0 ? image.ptr(r - 1) : zeros.data();
    const uint8_t* in = rows.data() + static_cast<size_t>(r) * (width + 1);
    if (!restoreRow(in, above, width, image.ptr(r))) {
      return makeError(what, ": row ", r, " has predictor ", int{in[0]}, " (0..3)");
    }
  }
  return image;
}

// ---- PNG and raw ----

Expected<EncodedImage> encodePng(const cv::Mat& image, const std::string& what) {
  EncodedImage e;
  e.pixelformat = evermap::image_t::FORMAT_PNG;
  try {
    if (!cv::imencode(".png", image, e.data)) return makeError(what, ": PNG encoding failed");
  } catch (const cv::Exception& ex) {
    return makeError(what, ": PNG encoding failed (", ex.msg, ")");
  }
  return e;
}

Expected<cv::Mat> decodePng(int width, int height, int row_stride, const std::vector<uint8_t>& data,
                            const std::string& what) {
  if (row_stride != 0) return makeError(what, ": row_stride must be 0 for PNG, is ", row_stride);
  int64_t w = 0, h = 0;
  if (!isPng(data) || !pngSize(data, &w, &h)) {
    return makeError(what, ": pixelformat PNG but the data is not a PNG");
  }
  if (w != width || h != height) {
    return makeError(what, ": the PNG is ", w, "x", h, ", the message says ", width, "x", height);
  }
  auto image = decodeImageFile(data, what);
  if (!image) return image.error();
  if (image->cols != width || image->rows != height) {
    return makeError(what, ": decoded ", image->cols, "x", image->rows, ", the message says ",
                     width, "x", height);
  }
  return image;
}

Expected<cv::Mat> decodeGray8(int width, int height, int row_stride,
                              const std::vector<uint8_t>& data, const std::string& what) {
  if (row_stride < width) {
    return makeError(what, ": row_stride ", row_stride, " is less than width ", width);
  }
  const int64_t need = int64_t{row_stride} * height;
  if (static_cast<int64_t>(data.size()) != need) {
    return makeError(what, ": gray8 ", width, "x", height, " with stride ", row_stride, " needs ",
                     need, " bytes, has ", data.size());
  }
  cv::Mat image(height, width, CV_8UC1);
  for (int r = 0; r < height; ++r) {
    std::memcpy(image.ptr(r), data.data() + static_cast<size_t>(r) * row_stride, width);
  }
  return image;
}

}  // namespace

const std::vector<std::pair<std::string, ImageEncoding>>& imageEncodingNames() {
  static const std::vector<std::pair<std::string, ImageEncoding>> names = {
      {"zstd", ImageEncoding::kZstd},
      {"png", ImageEncoding::kPng},
      {"gray8", ImageEncoding::kGray8}};
  return names;
}

const char* toString(ImageEncoding e) {
  for (const auto& [name, value] : imageEncodingNames()) {
    if (value == e) return name.c_str();
  }
  return "?";
}

Expected<EncodedImage> encodeImage(const cv::Mat& image, ImageEncoding encoding,
                                   const std::string& what) {
  if (image.empty() || image.type() != CV_8UC1) {
    return makeError(what, ": must be a non-empty 8-bit gray image");
  }
  if (encoding == ImageEncoding::kPng) return encodePng(image, what);
  if (encoding == ImageEncoding::kZstd) return encodeZstd(image, what);
  EncodedImage e;
  e.pixelformat = evermap::image_t::FORMAT_GRAY8;
  e.row_stride = image.cols;
  e.data.resize(static_cast<size_t>(image.cols) * image.rows);
  for (int r = 0; r < image.rows; ++r) {
    std::memcpy(e.data.data() + static_cast<size_t>(r) * image.cols, image.ptr(r), image.cols);
  }
  return e;
}

Expected<cv::Mat> decodeImage(int32_t pixelformat, int32_t width, int32_t height,
                              int32_t row_stride, const std::vector<uint8_t>& data,
                              const std::string& what) {
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide) {
    return makeError(what, ": size ", width, "x", height, " is not in 1..", kMaxImageSide);
  }
  switch (pixelformat) {
    case evermap::image_t::FORMAT_GRAY8:
      return decodeGray8(width, height, row_stride, data, what);
    case evermap::image_t::FORMAT_PNG:
      return decodePng(width, height, row_stride, data, what);
    case evermap::image_t::FORMAT_ZSTD:
      if (row_stride != 0) {
        return makeError(what, ": row_stride must be 0 for ZSTD, is ", row_stride);
      }
      return decodeZstd(width, height, data, what);
    default:
      return makeError(what, ": unknown pixelformat ", pixelformat);
  }
}

Expected<cv::Mat> decodeImageFile(const std::vector<uint8_t>& bytes, const std::string& what) {
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return makeError(what, ": cannot decode the image (", e.msg, ")");
  }
  if (image.empty()) return makeError(what, ": corrupt or unsupported image data");
  if (image.type() != CV_8UC1) {
    return makeError(what, ": not an 8-bit gray image (", image.channels(), " channels, depth ",
                     image.depth(), ")");
  }
  return image;
}

}  // namespace evermap::messages
