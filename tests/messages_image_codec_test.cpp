// core/messages/image_codec: the zstd predictor rows are lossless on every kind of image and
// every predictor, PNG messages (every log written before zstd) still decode, and corrupt or
// hostile data is refused with one line naming the input, before anything large is allocated.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <zstd.h>

#include <opencv2/imgcodecs.hpp>

#include <evermap/image_t.hpp>
#include <evermap/stereo_image_t.hpp>

#include "core/messages/convert.h"
#include "core/messages/image_codec.h"
#include "image_test_util.h"
#include "test_data.h"

namespace evermap::messages {
namespace {

namespace fs = std::filesystem;

using evermap::testing::expectError;
using evermap::testing::sameImage;

// Images that make the encoder pick each predictor somewhere: noise (left), vertical stripes
// (up), smooth ramps (average, gradient), flat, and the smallest sizes.
std::vector<cv::Mat> variedImages() {
  std::vector<cv::Mat> images;
  std::mt19937 rng(3);
  cv::Mat noise(37, 53, CV_8UC1);
  for (auto it = noise.begin<uint8_t>(); it != noise.end<uint8_t>(); ++it) *it = rng() & 0xff;
  images.push_back(noise);
  cv::Mat stripes(40, 64, CV_8UC1);
  for (int r = 0; r < stripes.rows; ++r) {
    for (int c = 0; c < stripes.cols; ++c)
      stripes.at<uint8_t>(r, c) = (c * 37 + (rng() & 1)) & 0xff;
  }
  images.push_back(stripes);
  cv::Mat ramp(48, 80, CV_8UC1);
  for (int r = 0; r < ramp.rows; ++r) {
    for (int c = 0; c < ramp.cols; ++c) ramp.at<uint8_t>(r, c) = (3 * r + 5 * c + r * c / 7) & 0xff;
  }
  images.push_back(ramp);
  images.push_back(cv::Mat(16, 16, CV_8UC1, cv::Scalar(255)));
  images.push_back(cv::Mat(1, 1, CV_8UC1, cv::Scalar(7)));
  images.push_back(ramp.colRange(3, 4).clone());   // one column
  images.push_back(ramp.rowRange(5, 6).clone());   // one row
  images.push_back(ramp(cv::Rect(2, 3, 30, 20)));  // a view with a stride
  return images;
}

// The zstd frame of predictor rows `rows` (the bytes the decoder decompresses).
std::vector<uint8_t> zstdFrame(const std::vector<uint8_t>& rows) {
  std::vector<uint8_t> out(ZSTD_compressBound(rows.size()));
  out.resize(ZSTD_compress(out.data(), out.size(), rows.data(), rows.size(), 1));
  return out;
}

TEST(ImageCodec, ZstdRowsDecodeToTheSamePixelsOnEveryKindOfImage) {
  for (const cv::Mat& image : variedImages()) {
    auto encoded = encodeImage(image, ImageEncoding::kZstd, "test");
    ASSERT_TRUE(encoded.ok()) << encoded.error().message;
    EXPECT_EQ(encoded->pixelformat, evermap::image_t::FORMAT_ZSTD);
    EXPECT_EQ(encoded->row_stride, 0);
    auto back = decodeImage(encoded->pixelformat, image.cols, image.rows, 0, encoded->data, "t");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(sameImage(*back, image)) << image.cols << "x" << image.rows;
  }
}

TEST(ImageCodec, EveryPredictorByteDecodesAsDocumented) {
  // A 3x2 image written by hand with predictors 0..3 against the documented formulas.
  const int w = 3;
  const uint8_t px[2][3] = {{10, 20, 30}, {15, 40, 200}};
  for (uint8_t p = 0; p < 4; ++p) {
    std::vector<uint8_t> rows;
    for (int r = 0; r < 2; ++r) {
      rows.push_back(r == 0 ? 0 : p);
      for (int c = 0; c < w; ++c) {
        const int a = c > 0 ? px[r][c - 1] : 0;
        const int b = r > 0 ? px[r - 1][c] : 0;
        const int ul = (r > 0 && c > 0) ? px[r - 1][c - 1] : 0;
        const int predicted = r == 0   ? a
                              : p == 0 ? a
                              : p == 1 ? b
                              : p == 2 ? (a + b) / 2
                                       : a + b - ul;
        rows.push_back(static_cast<uint8_t>(px[r][c] - predicted));
      }
    }
    auto back = decodeImage(evermap::image_t::FORMAT_ZSTD, w, 2, 0, zstdFrame(rows), "t");
    ASSERT_TRUE(back.ok()) << back.error().message;
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < w; ++c) EXPECT_EQ(back->at<uint8_t>(r, c), px[r][c]) << int{p};
    }
  }
}

TEST(ImageCodec, PngMessagesOfOldLogsStillDecodeToTheSamePixels) {
  for (const cv::Mat& image : variedImages()) {
    evermap::image_t msg;  // as every log before zstd carried it
    msg.utime = 1;
    msg.width = image.cols;
    msg.height = image.rows;
    msg.pixelformat = evermap::image_t::FORMAT_PNG;
    msg.row_stride = 0;
    ASSERT_TRUE(cv::imencode(".png", image, msg.data));
    msg.size = static_cast<int32_t>(msg.data.size());
    auto back = fromMsg(msg);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(sameImage(*back, image));
  }
}

TEST(ImageCodec, StereoFramesDecodeBothImagesInAnyMixOfEncodings) {
  const auto images = variedImages();
  StereoFrame f;
  f.utime = 3;
  f.left = images[2];
  f.right = 255 - images[2];
  auto zstd = toMsg(f, ImageEncoding::kZstd);
  auto png = toMsg(f, ImageEncoding::kPng);
  ASSERT_TRUE(zstd.ok() && png.ok());
  evermap::stereo_image_t mixed = *zstd;
  mixed.right = png->right;
  for (const evermap::stereo_image_t* m : {&*zstd, &*png, &mixed}) {
    auto back = fromMsg(*m);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(sameImage(back->left, f.left));
    EXPECT_TRUE(sameImage(back->right, f.right));
  }
  mixed.right.data[mixed.right.data.size() / 2] ^= 0xff;  // the right one corrupt
  auto refused = fromMsg(mixed);
  expectError(refused, "stereo_image_t at utime 3: right: ");
}

TEST(ImageCodec, CorruptOrHostileZstdDataIsRefusedNamingTheInput) {
  const cv::Mat image = variedImages()[2];
  auto msg = toMsg(image, 42, ImageEncoding::kZstd);
  ASSERT_TRUE(msg.ok());
  evermap::image_t m = *msg;
  m.data.resize(m.data.size() / 2);  // truncated
  m.size = static_cast<int32_t>(m.data.size());
  expectError(fromMsg(m), "image_t at utime 42: corrupt zstd frame");
  m = *msg;
  m.data.assign({1, 2, 3});
  m.size = 3;
  expectError(fromMsg(m), "the data is not a zstd frame of known size");
  // A frame that would decompress to far more than the image: refused before decompressing.
  const std::vector<uint8_t> big(static_cast<size_t>(image.cols + 1) * image.rows * 1000, 0);
  m.data = zstdFrame(big);
  m.size = static_cast<int32_t>(m.data.size());
  expectError(fromMsg(m), "needs " + std::to_string((image.cols + 1) * image.rows));
  // A frame without its content size (as a stream may write it): refused, its size is unknown.
  std::vector<uint8_t> rows(static_cast<size_t>(image.cols + 1) * image.rows, 0);
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 0);
  std::vector<uint8_t> unsized(ZSTD_compressBound(rows.size()));
  unsized.resize(ZSTD_compress2(cctx, unsized.data(), unsized.size(), rows.data(), rows.size()));
  ZSTD_freeCCtx(cctx);
  m.data = unsized;
  m.size = static_cast<int32_t>(m.data.size());
  expectError(fromMsg(m), "not a zstd frame of known size");
  // An unknown predictor byte.
  rows[static_cast<size_t>(image.cols + 1) * 5] = 7;
  m.data = zstdFrame(rows);
  m.size = static_cast<int32_t>(m.data.size());
  expectError(fromMsg(m), "row 5 has predictor 7 (0..3)");
  m = *msg;
  m.row_stride = image.cols;
  expectError(fromMsg(m), "row_stride must be 0 for ZSTD");
  m = *msg;
  m.pixelformat = 9;
  expectError(fromMsg(m), "unknown pixelformat 9");
}

TEST(ImageCodec, TheZstdConstantLeavesImageTsFingerprintAsBefore) {
  // LCM constants are not part of the type hash: logs and peers of before still match. The
  // value is main's before FORMAT_ZSTD (base hash 0x87ee4fe2deaf538d, rotated by getHash).
  EXPECT_EQ(static_cast<uint64_t>(evermap::image_t::getHash()), 1142964077079734043ULL);
}

TEST(ImageCodec, RealImagesRoundTripAndZstdIsNoLargerThanPngOnEuroc) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir / "mav0/cam0/data")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 10u);
  size_t png_bytes = 0, zstd_bytes = 0;
  for (size_t i = 0; i < files.size(); i += files.size() / 10) {
    const cv::Mat image = cv::imread(files[i].string(), cv::IMREAD_GRAYSCALE);
    auto zstd = toMsg(image, 1, ImageEncoding::kZstd);
    auto png = toMsg(image, 1, ImageEncoding::kPng);
    ASSERT_TRUE(zstd.ok() && png.ok());
    zstd_bytes += zstd->data.size();
    png_bytes += png->data.size();
    auto back = fromMsg(*zstd);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(sameImage(*back, image)) << files[i];
  }
  EXPECT_LE(zstd_bytes, png_bytes);
}

}  // namespace
}  // namespace evermap::messages
