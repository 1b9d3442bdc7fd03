#include "core/messages/rgbd_convert.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace evermap::messages {
namespace {

constexpr uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// Width, height, bit depth and colour type of a PNG (its IHDR chunk), read before decoding.
struct PngHeader {
  int64_t width = 0, height = 0;
  int bit_depth = 0, colour_type = -1;
};

bool pngHeader(const std::vector<uint8_t>& b, PngHeader* h) {
  if (b.size() < 26 || std::memcmp(b.data(), kPngSignature, 8) != 0 ||
      std::memcmp(b.data() + 12, "IHDR", 4) != 0) {
    return false;
  }
  auto be32 = [&b](size_t at) {
    return (int64_t{b[at]} << 24) | (int64_t{b[at + 1]} << 16) | (int64_t{b[at + 2]} << 8) |
           int64_t{b[at + 3]};
  };
  h->width = be32(16);
  h->height = be32(20);
  h->bit_depth = b[24];
  h->colour_type = b[25];
  return true;
}

Expected<cv::Mat> decodeDepth(const evermap::rgbd_image_t& msg, const std::string& what) {
  if (msg.depth_size < 0 || static_cast<size_t>(msg.depth_size) != msg.depth_data.size()) {
    return makeError(what, ": depth_size ", msg.depth_size, " but ", msg.depth_data.size(),
                     " depth bytes");
  }
  if (msg.depth_format == evermap::rgbd_image_t::DEPTH_U16) {
    const int64_t need = int64_t{msg.depth_width} * msg.depth_height * 2;
    if (msg.depth_size != need) {
      return makeError(what, ": depth DEPTH_U16 ", msg.depth_width, "x", msg.depth_height,
                       " needs ", need, " bytes, has ", msg.depth_size);
    }
    cv::Mat depth(msg.depth_height, msg.depth_width, CV_16UC1);
    const uint8_t* p = msg.depth_data.data();
    for (int r = 0; r < depth.rows; ++r) {
      auto* row = depth.ptr<uint16_t>(r);
      for (int c = 0; c < depth.cols; ++c, p += 2) {
        row[c] = static_cast<uint16_t>(p[0] | (p[1] << 8));  // little-endian on the wire
      }
    }
    return depth;
  }
  if (msg.depth_format == evermap::rgbd_image_t::DEPTH_PNG16) {
    PngHeader h;
    if (!pngHeader(msg.depth_data, &h)) {
      return makeError(what, ": depth_format DEPTH_PNG16 but the depth data is not a PNG");
    }
    if (h.width != msg.depth_width || h.height != msg.depth_height) {
      return makeError(what, ": the depth PNG is ", h.width, "x", h.height, ", the message says ",
                       msg.depth_width, "x", msg.depth_height);
    }
    if (h.bit_depth != 16 || h.colour_type != 0) {
      return makeError(what, ": the depth PNG is ", h.bit_depth, "-bit, colour type ",
                       h.colour_type, "; depth must be 16-bit gray");
    }
    cv::Mat depth;
    try {
      depth = cv::imdecode(msg.depth_data, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& e) {
      return makeError(what, ": cannot decode the depth PNG (", e.msg, ")");
    }
    if (depth.empty()) return makeError(what, ": corrupt depth PNG");
    if (depth.type() != CV_16UC1 || depth.cols != msg.depth_width ||
        depth.rows != msg.depth_height) {
      return makeError(what, ": the depth PNG decodes to ", depth.cols, "x", depth.rows,
                       " of type ", depth.type(), ", not 16-bit ", msg.depth_width, "x",
                       msg.depth_height);
    }
    return depth;
  }
  return makeError(what, ": unknown depth_format ", msg.depth_format);
}

}  // namespace

Expected<evermap::rgbd_image_t> toMsg(const RgbdFrame& f, ImageEncoding encoding) {
  const std::string what = "rgbd frame at utime " + std::to_string(f.utime);
  if (f.depth.empty() || f.depth.type() != CV_16UC1) {
    return makeError(what, ": depth must be a non-empty 16-bit one-channel image");
  }
  if (f.depth.size() != f.gray.size()) {
    return makeError(what, ": depth ", f.depth.cols, "x", f.depth.rows, " and gray ", f.gray.cols,
                     "x", f.gray.rows, " differ in size");
  }
  if (!(f.depth_scale_m > 0.0) || !std::isfinite(f.depth_scale_m)) {
    return makeError(what, ": depth_scale_m ", f.depth_scale_m, " is not positive and finite");
  }
  if (std::llabs(f.depth_utime - f.utime) > kMaxDepthOffsetUs) {
    return makeError(what, ": depth at ", f.depth_utime, " is more than ", kMaxDepthOffsetUs,
                     " us from the image");
  }
  auto gray = toMsg(f.gray, f.utime, encoding);
  if (!gray) return gray.error();
  evermap::rgbd_image_t msg;
  msg.utime = f.utime;
  msg.depth_utime = f.depth_utime;
  msg.gray = std::move(*gray);
  msg.camera = toMsg(f.camera);
  msg.depth_width = f.depth.cols;
  msg.depth_height = f.depth.rows;
  msg.depth_scale_m = f.depth_scale_m;
  if (encoding == ImageEncoding::kGray8) {
    msg.depth_format = evermap::rgbd_image_t::DEPTH_U16;
    msg.depth_data.resize(static_cast<size_t>(f.depth.total()) * 2);
    uint8_t* p = msg.depth_data.data();
    for (int r = 0; r < f.depth.rows; ++r) {
      const auto* row = f.depth.ptr<uint16_t>(r);
      for (int c = 0; c < f.depth.cols; ++c, p += 2) {
        p[0] = static_cast<uint8_t>(row[c] & 0xff);
        p[1] = static_cast<uint8_t>(row[c] >> 8);
      }
    }
  } else {
    msg.depth_format = evermap::rgbd_image_t::DEPTH_PNG16;
    try {
      if (!cv::imencode(".png", f.depth, msg.depth_data)) {
        return makeError(what, ": depth PNG encoding failed");
      }
    } catch (const cv::Exception& e) {
      return makeError(what, ": depth PNG encoding failed (", e.msg, ")");
    }
  }
  msg.depth_size = static_cast<int32_t>(msg.depth_data.size());
  return msg;
}

Expected<RgbdFrame> fromMsg(const evermap::rgbd_image_t& msg) {
  const std::string what = "rgbd_image_t at utime " + std::to_string(msg.utime);
  if (std::llabs(msg.depth_utime - msg.utime) > kMaxDepthOffsetUs) {
    return makeError(what, ": depth_utime ", msg.depth_utime, " is ",
                     (msg.depth_utime - msg.utime) / 1000.0, " ms from the image (at most ",
                     kMaxDepthOffsetUs / 1000, " ms): not one frame");
  }
  if (!(msg.depth_scale_m > 0.0) || !std::isfinite(msg.depth_scale_m)) {
    return makeError(what, ": depth_scale_m ", msg.depth_scale_m, " is not positive and finite");
  }
  auto camera = fromMsg(msg.camera);
  if (!camera) return makeError(what, ": camera: ", camera.error().message);
  // Sizes first, so nothing of the wrong size is decompressed.
  if (msg.gray.width != camera->width || msg.gray.height != camera->height) {
    return makeError(what, ": gray image ", msg.gray.width, "x", msg.gray.height,
                     ", the calibration is ", camera->width, "x", camera->height);
  }
  if (msg.depth_width != msg.gray.width || msg.depth_height != msg.gray.height) {
    return makeError(what, ": depth ", msg.depth_width, "x", msg.depth_height,
                     ", the gray image is ", msg.gray.width, "x", msg.gray.height);
  }
  auto gray = fromMsg(msg.gray);
  if (!gray) return makeError(what, ": gray: ", gray.error().message);
  auto depth = decodeDepth(msg, what);
  if (!depth) return depth.error();
  RgbdFrame f;
  f.utime = msg.utime;
  f.depth_utime = msg.depth_utime;
  f.gray = std::move(*gray);
  f.depth = std::move(*depth);
  f.depth_scale_m = msg.depth_scale_m;
  f.camera = std::move(*camera);
  return f;
}

}  // namespace evermap::messages
