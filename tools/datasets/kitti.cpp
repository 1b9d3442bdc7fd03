#include "tools/datasets/kitti.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <fstream>
#include <string>

#include "core/camera/pinhole.h"
#include "tools/datasets/euroc.h"  // parseNumbers

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;

bool blank(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }

Mat34 toMat34(const std::vector<double>& v) { return Mat34(v.data()); }

}  // namespace

Expected<KittiProjections> readKittiCalib(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::ifstream in(file);
  if (!in) return makeError(name, ": cannot open");
  std::vector<double> v;
  std::string line;
  bool have0 = false, have1 = false;
  std::vector<Mat34> unlabelled;
  KittiProjections p;
  for (int n = 1; std::getline(in, line); ++n) {
    if (blank(line)) continue;
    const size_t colon = line.find(':');
    const std::string label = colon == std::string::npos ? "" : line.substr(0, colon);
    const std::string numbers = colon == std::string::npos ? line : line.substr(colon + 1);
    if (!label.empty() && label != "P0" && label != "P1") continue;  // P2, P3, Tr, ...
    if (!parseNumbers(numbers, ' ', &v) || v.size() != 12) {
      return makeError(name, ":", n, ": expected 12 numbers (a 3x4 projection matrix)");
    }
    for (double x : v) {
      if (!std::isfinite(x)) return makeError(name, ":", n, ": non-finite number");
    }
    if (label == "P0") {
      p.P0 = toMat34(v);
      have0 = true;
    } else if (label == "P1") {
      p.P1 = toMat34(v);
      have1 = true;
    } else {
      unlabelled.push_back(toMat34(v));
    }
  }
  if (!have0 && !have1 && unlabelled.size() >= 2) {
    p.P0 = unlabelled[0];
    p.P1 = unlabelled[1];
    return p;
  }
  if (!have0 || !have1) {
    return makeError(name,
                     ": needs P0 and P1 (labelled \"P0:\" / \"P1:\", or the first two of "
                     "unlabelled lines of 12 numbers)");
  }
  return p;
}

Expected<core::StereoCalibration> kittiStereoCalibration(const KittiProjections& p, int width,
                                                         int height, const std::string& what) {
  const Eigen::Matrix3d K0 = p.P0.leftCols<3>(), K1 = p.P1.leftCols<3>();
  const double scale = std::max(1.0, K0.cwiseAbs().maxCoeff());
  if ((K0 - K1).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return makeError(what, ": P0 and P1 have different intrinsics: not a rectified pair");
  }
  if (K0(0, 1) != 0.0 || K0(1, 0) != 0.0 || K0(2, 0) != 0.0 || K0(2, 1) != 0.0 || K0(2, 2) != 1.0) {
    return makeError(what, ": P0 is not a pinhole [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (p.P0.col(3).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return makeError(what, ": P0 has a non-zero 4th column: camera 0 is not the reference");
  }
  if (std::abs(p.P1(1, 3)) > 1e-9 * scale || std::abs(p.P1(2, 3)) > 1e-9 * scale) {
    return makeError(what, ": P1's offset is not along x: not a horizontal rectified pair");
  }
  // P1 = K [I | t] with t = (-b, 0, 0): p_right = p_left - (b, 0, 0).
  const double baseline = -p.P1(0, 3) / p.P1(0, 0);
  const core::StereoCalibration c = core::rectifiedPair(
      core::pinholeCamera(width, height, K0(0, 0), K0(1, 1), K0(0, 2), K0(1, 2)), baseline);
  if (Status s = c.validate(what); !s) return s.error();
  return c;
}

Expected<std::vector<int64_t>> readKittiTimes(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::ifstream in(file);
  if (!in) return makeError(name, ": cannot open");
  std::vector<int64_t> out;
  std::vector<double> v;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (blank(line)) continue;
    if (!parseNumbers(line, ' ', &v) || v.size() != 1 || !std::isfinite(v[0]) || v[0] < 0.0 ||
        v[0] > 9.2e9) {
      return makeError(name, ":", n, ": expected one time in seconds");
    }
    const int64_t t_ns = std::llround(v[0] * 1e9);
    if (!out.empty() && t_ns <= out.back()) {
      return makeError(name, ":", n, ": time ", line, " s is not after the previous line's");
    }
    out.push_back(t_ns);
  }
  if (out.empty()) return makeError(name, ": no times");
  return out;
}

Expected<std::vector<core::SE3d>> readKittiPoses(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::ifstream in(file);
  if (!in) return makeError(name, ": cannot open");
  std::vector<core::SE3d> out;
  std::vector<double> v;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (blank(line)) continue;
    if (!parseNumbers(line, ' ', &v) || v.size() != 12) {
      return makeError(name, ":", n, ": expected 12 numbers (row-major 3x4 [R | t])");
    }
    const Mat34 T = toMat34(v);
    if (!T.allFinite()) return makeError(name, ":", n, ": non-finite number");
    const Eigen::Matrix3d R = T.leftCols<3>();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4 ||
        R.determinant() < 0.0) {
      return makeError(name, ":", n, ": the rotation is not orthonormal");
    }
    out.emplace_back(core::SO3d::fromMatrix(R), core::Vec3(T.col(3)));
  }
  return out;
}

namespace {

std::string frameName(size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu.png", i);
  return buf;
}

// The image folder the options name, else the first of `defaults` that exists; empty when
// none does.
fs::path imageFolder(const fs::path& folder, const fs::path& chosen,
                     std::initializer_list<const char*> defaults) {
  if (!chosen.empty()) return chosen.is_absolute() ? chosen : folder / chosen;
  for (const char* name : defaults) {
    if (fs::is_directory(folder / name)) return folder / name;
  }
  return {};
}

// Frame numbers 0 .. the highest NNNNNN.png of `dir`, at `rate_hz`.
Expected<std::vector<int64_t>> timesFromRate(const fs::path& dir, double rate_hz) {
  long long highest = -1;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() != 10 || name.substr(6) != ".png") continue;
    if (name.find_first_not_of("0123456789") != 6) continue;
    highest = std::max(highest, std::stoll(name.substr(0, 6)));
  }
  if (highest < 0) return makeError(dir.string(), ": no NNNNNN.png image");
  std::vector<int64_t> times;
  for (long long i = 0; i <= highest; ++i) {
    times.push_back(std::llround(static_cast<double>(i) * 1e9 / rate_hz));
  }
  return times;
}

}  // namespace

Status KittiSequenceOptions::validate() const {
  if (!poses.empty() && !fs::is_regular_file(poses)) {
    return makeError(poses.string(), ": poses file not found");
  }
  if (!(rate_hz >= 0.0 && rate_hz <= 1e6)) {
    return makeError("frame rate ", rate_hz, " Hz is not in [0, 1e6] (0: use times.txt)");
  }
  return Ok{};
}

fs::path KittiSequence::leftImage(size_t frame) const { return left_dir / frameName(frame); }
fs::path KittiSequence::rightImage(size_t frame) const { return right_dir / frameName(frame); }

Expected<KittiSequence> readKittiSequence(const fs::path& folder,
                                          const KittiSequenceOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  KittiSequence q;
  q.folder = folder;
  q.left_dir = imageFolder(folder, options.left_folder, {"image_0", "image_l"});
  if (q.left_dir.empty() || !fs::is_directory(q.left_dir)) {
    if (!options.left_folder.empty()) {
      return makeError(q.left_dir.string(), ": no left images (no such folder)");
    }
    return makeError((folder / "image_0").string(),
                     ": no left images (neither image_0/ nor image_l/: not a KITTI odometry "
                     "sequence?)");
  }
  q.right_dir = imageFolder(folder, options.right_folder, {"image_1", "image_r"});
  if (q.right_dir.empty() || !fs::is_directory(q.right_dir)) {
    if (!options.right_folder.empty()) {
      return makeError(q.right_dir.string(), ": no right images (no such folder)");
    }
    const bool kitti = q.left_dir.filename() == "image_0";
    return makeError(
        (folder / (kitti ? "image_1" : "image_r")).string(), ": no right images: stereo needs ",
        kitti ? "image_0 and image_1" : "image_l and image_r", " (this folder is monocular)");
  }
  q.calib_file = folder / "calib.txt";
  auto projections = readKittiCalib(q.calib_file);
  if (!projections) return projections.error();
  q.projections = *projections;
  const fs::path times_file = folder / "times.txt";
  Expected<std::vector<int64_t>> times = Error{""};
  if (options.rate_hz > 0.0) {
    times = timesFromRate(q.left_dir, options.rate_hz);
  } else if (!fs::exists(times_file)) {
    return makeError(times_file.string(),
                     ": no such file; give the frame rate instead (--rate HZ)");
  } else {
    times = readKittiTimes(times_file);
  }
  if (!times) return times.error();
  q.times_ns = std::move(*times);

  q.poses_file = options.poses;
  if (q.poses_file.empty() && fs::is_regular_file(folder / "poses.txt")) {
    q.poses_file = folder / "poses.txt";
  }
  if (!q.poses_file.empty()) {
    auto p = readKittiPoses(q.poses_file);
    if (!p) return p.error();
    if (p->size() != q.times_ns.size()) {
      return makeError(q.poses_file.string(), ": ", p->size(), " poses but ",
                       options.rate_hz > 0.0 ? q.left_dir.string() : times_file.string(), " has ",
                       q.times_ns.size(), " frames");
    }
    q.poses = std::move(*p);
  }
  for (size_t i = 0; i < q.times_ns.size(); ++i) {
    if (fs::exists(q.leftImage(i)) && fs::exists(q.rightImage(i))) {
      q.frames.push_back(i);
    } else {
      ++q.skipped_missing_image;
    }
  }
  if (q.frames.empty()) return makeError(folder.string(), ": no frame with both images");
  return q;
}

}  // namespace evermap::datasets
