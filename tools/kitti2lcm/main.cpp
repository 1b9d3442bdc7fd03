// evermap-kitti2lcm: a KITTI odometry sequence to an LCM log (core/datasets/to_lcm.h).
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "core/datasets/to_lcm.h"

namespace {

constexpr const char* kUsage =
    "usage: evermap-kitti2lcm [--raw] [--poses FILE] SEQUENCE_FOLDER OUTPUT.lcmlog\n"
    "  SEQUENCE_FOLDER  a KITTI odometry sequence: image_0/, image_1/, calib.txt, times.txt\n"
    "  --raw            store images as raw gray8 instead of PNG\n"
    "  --poses FILE     ground-truth poses (KITTI format); default SEQUENCE_FOLDER/poses.txt\n"
    "                   when present\n";

}  // namespace

int main(int argc, char** argv) {
  evermap::datasets::KittiToLcmOptions options;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--raw") {
      options.encoding = evermap::messages::ImageEncoding::kGray8;
    } else if (a == "--poses" && i + 1 < argc) {
      options.poses = argv[++i];
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "evermap-kitti2lcm: unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() != 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();  // for the report only
  const auto summary =
      evermap::datasets::convertKittiToLcm(positional[0], positional[1], options);
  if (!summary) {
    std::fprintf(stderr, "evermap-kitti2lcm: %s\n", summary.error().message.c_str());
    return 1;
  }
  const double s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s (images: %s)\n%sconverted in %.1f s\n", positional[1].c_str(),
              evermap::messages::toString(options.encoding), summary->report().c_str(), s);
  return 0;
}
