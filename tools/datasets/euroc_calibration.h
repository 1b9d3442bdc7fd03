#pragma once
// EuRoC camera calibration: the sensor.yaml of each camera (Kalibr output in the ASL folder
// layout: intrinsics [fu, fv, cu, cv], radial-tangential distortion [k1, k2, p1, p2],
// T_BS = body_T_cam as a row-major 4x4, resolution [width, height]).

#include <filesystem>

#include "core/camera/calibration.h"
#include "core/common/expected.h"

namespace evermap::datasets {

// One camera's sensor.yaml; errors name the file and the field.
Expected<core::CameraCalibration> readEurocCameraYaml(const std::filesystem::path& yaml);
// cam0 (left) and cam1 (right) sensor.yaml files: a raw (rectified = false) stereo calibration,
// validated as a pair (same image size, positive baseline).
Expected<core::StereoCalibration> readEurocStereoCalibration(
    const std::filesystem::path& cam0_yaml, const std::filesystem::path& cam1_yaml);

}  // namespace evermap::datasets
