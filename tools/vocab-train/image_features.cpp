#include "tools/vocab-train/image_features.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <optional>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/features/gray_image.h"

namespace evermap::bow {

void OrbOptions::declareOptions(OptionList& o) {
  o.add("features", &max_features, "", "ORB features kept per image").in(1, 100000);
  o.add("scale_factor", &scale_factor, "", "scale between pyramid levels").above(1).max(2);
  o.add("pyramid_levels", &pyramid_levels, "", "pyramid levels").in(1, 16);
  o.add("fast_threshold", &fast_threshold, "grey levels", "FAST threshold").in(1, 254);
}

ImageFeatures extractOrb(const cv::Mat& image, const OrbOptions& options) {
  if (image.depth() != CV_8U) {
    std::fprintf(stderr, "evermap: extractOrb needs an 8-bit image, got depth %d\n", image.depth());
    std::abort();
  }
  const std::optional<cv::Mat> converted = core::toGray(image);
  const cv::Mat gray = converted ? *converted : image;
  auto orb = cv::ORB::create(options.max_features, static_cast<float>(options.scale_factor),
                             options.pyramid_levels, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31,
                             options.fast_threshold);
  ImageFeatures out;
  out.image_size = gray.size();
  cv::Mat descriptors;
  orb->detectAndCompute(gray, cv::noArray(), out.keypoints, descriptors);
  // cv::ORB always yields CV_8UC1 x 32, so this cannot fail.
  out.descriptors = descriptorsFromMat(descriptors, "cv::ORB").value();
  return out;
}

Expected<ImageFeatures> extractOrbFromFile(const std::filesystem::path& file,
                                           const OrbOptions& options) {
  if (Status s = options.validate(); !s) return makeError("ORB options: ", s.error().message);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such file");
  cv::Mat image = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
  if (image.empty()) return makeError(file.string(), ": not a readable image");
  return extractOrb(image, options);
}

bool naturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i]));
    const bool db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      // Compare as numbers without overflow: strip leading zeros, then length, then digits.
      size_t is = i, js = j;
      while (is + 1 < ie && a[is] == '0') ++is;
      while (js + 1 < je && b[js] == '0') ++js;
      if (ie - is != je - js) return ie - is < je - js;
      const int c = a.compare(is, ie - is, b, js, je - js);
      if (c != 0) return c < 0;
      if (ie - i != je - j) return ie - i < je - j;  // "01" after "1"
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

Expected<std::vector<std::filesystem::path>> listImages(const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return makeError(folder.string(), ": no such folder");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".pgm" ||
        ext == ".ppm" || ext == ".tif" || ext == ".tiff") {
      files.push_back(entry.path());
    }
  }
  if (ec) return makeError(folder.string(), ": cannot list: ", ec.message());
  if (files.empty()) return makeError(folder.string(), ": holds no image files");
  std::sort(files.begin(), files.end(), [](const fs::path& x, const fs::path& y) {
    return naturalLess(x.filename().string(), y.filename().string());
  });
  return files;
}

}  // namespace evermap::bow
