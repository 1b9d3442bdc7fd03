#include "tools/datasets/euroc_calibration.h"

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace evermap::datasets {
namespace {

// Reads a sequence of numbers; false when the node is missing, not a sequence or not numeric.
bool readNumbers(const cv::FileNode& node, std::vector<double>* out) {
  out->clear();
  if (node.empty() || !node.isSeq()) return false;
  for (const cv::FileNode& n : node) {
    if (!n.isReal() && !n.isInt()) return false;
    out->push_back(static_cast<double>(n));
  }
  return true;
}

}  // namespace

Expected<core::CameraCalibration> readEurocCameraYaml(const std::filesystem::path& yaml) {
  const std::string name = yaml.string();
  if (!std::filesystem::is_regular_file(yaml)) return makeError(name, ": cannot open");
  cv::FileStorage fs;
  try {
    if (!fs.open(name, cv::FileStorage::READ)) return makeError(name, ": cannot open");
  } catch (const cv::Exception& e) {
    return makeError(name, ": not a readable YAML file (", e.msg, ")");
  }
  core::CameraCalibration c;
  std::vector<double> v;

  const std::string model = fs["camera_model"].empty() ? "" : std::string(fs["camera_model"]);
  if (model != "pinhole") {
    return makeError(name, ": camera_model \"", model, "\" is not supported (only pinhole)");
  }
  if (!readNumbers(fs["intrinsics"], &v) || v.size() != 4) {
    return makeError(name, ": intrinsics must be 4 numbers [fu, fv, cu, cv]");
  }
  c.fx = v[0];
  c.fy = v[1];
  c.cx = v[2];
  c.cy = v[3];
  if (!readNumbers(fs["resolution"], &v) || v.size() != 2 || v[0] != std::floor(v[0]) ||
      v[1] != std::floor(v[1])) {
    return makeError(name, ": resolution must be 2 integers [width, height]");
  }
  c.width = static_cast<int>(v[0]);
  c.height = static_cast<int>(v[1]);

  const std::string dist =
      fs["distortion_model"].empty() ? "" : std::string(fs["distortion_model"]);
  if (dist == "radial-tangential" || dist == "radtan") {
    if (!readNumbers(fs["distortion_coefficients"], &v) || v.size() != 4) {
      return makeError(name, ": distortion_coefficients must be 4 numbers [k1, k2, p1, p2]");
    }
    c.distortion_model = core::DistortionModel::kRadTan;
    c.distortion = v;
  } else if (dist == "none" || dist.empty()) {
    c.distortion_model = core::DistortionModel::kNone;
  } else {
    return makeError(name, ": distortion_model \"", dist,
                     "\" is not supported (radial-tangential or none)");
  }

  if (!readNumbers(fs["T_BS"]["data"], &v) || v.size() != 16) {
    return makeError(name, ": T_BS.data must be 16 numbers (row-major 4x4 body_T_cam)");
  }
  const Eigen::Matrix4d T =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(v.data());
  if (!T.allFinite()) return makeError(name, ": T_BS has a non-finite entry");
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
      R.determinant() < 0.0 ||
      (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-12) {
    return makeError(name,
                     ": T_BS is not a rigid transform (rotation not orthonormal or last "
                     "row not 0 0 0 1)");
  }
  c.body_T_cam = core::SE3d::fromMatrix(T);

  if (Status s = c.validate(name); !s) return s.error();
  return c;
}

Expected<core::StereoCalibration> readEurocStereoCalibration(
    const std::filesystem::path& cam0_yaml, const std::filesystem::path& cam1_yaml) {
  auto left = readEurocCameraYaml(cam0_yaml);
  if (!left) return left.error();
  auto right = readEurocCameraYaml(cam1_yaml);
  if (!right) return right.error();
  core::StereoCalibration c;
  c.rectified = false;
  c.left = std::move(*left);
  c.right = std::move(*right);
  if (Status s = c.validate(cam0_yaml.string() + " + " + cam1_yaml.string()); !s) return s.error();
  return c;
}

}  // namespace evermap::datasets
