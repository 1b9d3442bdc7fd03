#pragma once
// ORB features of an image file, for vocabulary training and the place-recognition evaluation
// on monocular image folders. This uses OpenCV's ORB (cv::ORB: oriented FAST + rotated BRIEF,
// Rublee et al., ICCV 2011) for now; keyframes on the live path carry the descriptors vo-proc
// computed instead. Listing of image folders lives here too.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/bow/descriptor.h"
#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::bow {

// ORB-SLAM's pyramid (1.2, 8 levels), the strongest features by FAST/Harris response.
struct OrbOptions {
  int max_features = 1000;
  double scale_factor = 1.2;
  int pyramid_levels = 8;
  int fast_threshold = 20;

  void declareOptions(OptionList& o);
  Status validate() const { return checkOptionRanges(*this); }
};

struct ImageFeatures {
  std::vector<cv::KeyPoint> keypoints;  // pixels, in the image as read
  std::vector<Descriptor> descriptors;  // one per keypoint
  cv::Size image_size;
};

// ORB on an 8-bit image, grey or colour (colour is converted to grey). Contract: 8-bit depth
// (what extractOrbFromFile reads); other depths abort with a message.
ImageFeatures extractOrb(const cv::Mat& image, const OrbOptions& options);
// Reads the file (any format OpenCV decodes) and extracts; an unreadable or empty image is an
// error naming the file.
Expected<ImageFeatures> extractOrbFromFile(const std::filesystem::path& file,
                                           const OrbOptions& options);

// The image files (png, jpg, jpeg, bmp, pgm, ppm, tif, tiff) directly in `folder`, in natural
// order: digit runs compare as numbers, so "2.jpg" comes before "10.jpg". An error names a
// folder that does not exist or holds no image.
Expected<std::vector<std::filesystem::path>> listImages(const std::filesystem::path& folder);

// Natural order of two file names (see listImages).
bool naturalLess(const std::string& a, const std::string& b);

}  // namespace evermap::bow
