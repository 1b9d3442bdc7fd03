#include "tools/eval/trajectory.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "core/common/atomic_write.h"
#include "core/common/number_text.h"
#include "core/common/enum_names.h"
#include "core/common/key_value_file.h"
#include "tools/datasets/text_lines.h"

namespace evermap::eval {
namespace {

using datasets::isCommentOrBlank;

// One stamp per non-blank line, in seconds.
Expected<std::vector<int64_t>> readKittiTimes(const std::filesystem::path& file) {
  std::vector<int64_t> out;
  const Status s = datasets::forEachDataLine(file, [&](const std::string& line, int n) -> Status {
    int64_t t_ns = 0;
    const std::string field = trimmed(line);
    if (!datasets::parseSecondsToNs(field, &t_ns)) {
      return makeError(file.string(), ":", n, ": expected one time in seconds, got \"", field,
                       "\"");
    }
    out.push_back(t_ns);
    return Ok{};
  });
  if (!s) return s.error();
  return out;
}

Expected<Trajectory> checked(Trajectory t) {
  if (Status s = validate(t); !s) return s.error();
  return t;
}

}  // namespace

namespace {
constexpr EnumNames<TrajectoryFormat, 3> kTrajectoryFormatNames{{
    {TrajectoryFormat::kTum, "tum"},
    {TrajectoryFormat::kKitti, "kitti"},
    {TrajectoryFormat::kEuroc, "euroc"},
}};
}  // namespace

const char* toString(TrajectoryFormat format) { return nameOf(kTrajectoryFormatNames, format); }

Expected<TrajectoryFormat> parseTrajectoryFormat(std::string_view name) {
  return parseName(kTrajectoryFormatNames, name, "trajectory format");
}

double Trajectory::pathLengthM() const {
  double length = 0.0;
  for (size_t k = 1; k < poses.size(); ++k) {
    length +=
        (poses[k].world_T_body.translation() - poses[k - 1].world_T_body.translation()).norm();
  }
  return length;
}

Status validate(const Trajectory& trajectory) {
  const std::string& name = trajectory.source;
  if (trajectory.empty()) return makeError(name, ": no poses");
  for (size_t k = 0; k < trajectory.size(); ++k) {
    const core::SE3d& T = trajectory.poses[k].world_T_body;
    if (!T.translation().allFinite() || !T.quaternion().coeffs().allFinite()) {
      return makeError(name, ": pose ", k, " is not finite");
    }
    if (k > 0 && trajectory.poses[k].t_ns <= trajectory.poses[k - 1].t_ns) {
      return makeError(name, ": time stamps must increase, but pose ", k,
                       " (t=", trajectory.poses[k].t_ns,
                       " ns) follows t=", trajectory.poses[k - 1].t_ns, " ns");
    }
  }
  return Ok{};
}

Expected<TrajectoryFormat> guessTrajectoryFormat(const std::filesystem::path& file) {
  if (file.extension() == ".csv") return TrajectoryFormat::kEuroc;
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (isCommentOrBlank(line)) continue;
    if (line.find(',') != std::string::npos) return TrajectoryFormat::kEuroc;
    if (datasets::parseNumbers(line, ' ', &v)) {
      if (v.size() == 8) return TrajectoryFormat::kTum;
      if (v.size() == 12) return TrajectoryFormat::kKitti;
    }
    return makeError(file.string(), ":", n,
                     ": cannot tell the format (expected 8 numbers for TUM, 12 for KITTI or a "
                     "EuRoC CSV line); name it explicitly");
  }
  return makeError(file.string(), ": no poses");
}

Expected<Trajectory> readTum(const std::filesystem::path& file) {
  auto poses = datasets::readEurocGroundTruth(file, datasets::PoseFileLayout::kTum);
  if (!poses) return poses.error();
  return checked(Trajectory{file.string(), std::move(poses.value())});
}

Expected<Trajectory> readEuroc(const std::filesystem::path& file) {
  auto poses = datasets::readEurocGroundTruth(file, datasets::PoseFileLayout::kEurocCsv);
  if (!poses) return poses.error();
  return checked(Trajectory{file.string(), std::move(poses.value())});
}

Expected<Trajectory> readKitti(const std::filesystem::path& poses_file,
                               const std::filesystem::path& times_file) {
  std::ifstream in(poses_file);
  if (!in) return makeError(poses_file.string(), ": cannot open");
  Trajectory out{poses_file.string(), {}};
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (isCommentOrBlank(line)) continue;
    if (!datasets::parseNumbers(line, ' ', &v) || v.size() != 12) {
      return makeError(poses_file.string(), ":", n,
                       ": expected 12 numbers (KITTI row-major 3x4 [R|t])");
    }
    core::Mat4 T = core::Mat4::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) T(r, c) = v[4 * r + c];
    }
    if (!T.allFinite()) return makeError(poses_file.string(), ":", n, ": non-finite value");
    // Files print 6-7 significant digits; anything far from a rotation is a corrupt line.
    const core::Mat3 R = T.topLeftCorner<3, 3>();
    const double orthogonality = (R.transpose() * R - core::Mat3::Identity()).cwiseAbs().maxCoeff();
    if (orthogonality > 1e-2 || R.determinant() < 0.0) {
      return makeError(
          poses_file.string(), ":", n,
          ": the 3x3 block is not a rotation (|R^T R - I| = ", numberText(orthogonality, 3),
          ", det = ", numberText(R.determinant(), 3), ")");
    }
    StampedPose p;
    // Without a times file the line index is the stamp, in seconds.
    p.t_ns = static_cast<int64_t>(out.poses.size()) * 1000000000LL;
    p.world_T_body = core::SE3d::fromMatrix(T);
    out.poses.push_back(p);
  }
  if (!times_file.empty()) {
    auto times = readKittiTimes(times_file);
    if (!times) return times.error();
    if (times->size() != out.poses.size()) {
      return makeError(times_file.string(), ": ", times->size(), " stamps for ", out.poses.size(),
                       " poses in ", poses_file.string());
    }
    for (size_t k = 0; k < out.poses.size(); ++k) out.poses[k].t_ns = (*times)[k];
  }
  return checked(std::move(out));
}

Expected<Trajectory> readTrajectory(const std::filesystem::path& file, TrajectoryFormat format,
                                    const std::filesystem::path& kitti_times) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return readTum(file);
    case TrajectoryFormat::kKitti:
      return readKitti(file, kitti_times);
    case TrajectoryFormat::kEuroc:
      return readEuroc(file);
  }
  return makeError(file.string(), ": unknown format");
}

Status writeTum(const Trajectory& trajectory, const std::filesystem::path& file) {
  std::string text = "# timestamp[s] tx ty tz qx qy qz qw\n";
  char buf[256];
  for (const StampedPose& p : trajectory.poses) {
    // The stamp is printed from the integer nanoseconds so that it survives a round trip.
    constexpr int64_t kNsPerS = 1000000000;
    const int64_t abs_ns = p.t_ns < 0 ? -p.t_ns : p.t_ns;
    const Eigen::Quaterniond& q = p.world_T_body.quaternion();
    const core::Vec3& t = p.world_T_body.translation();
    std::snprintf(buf, sizeof(buf),
                  "%s%" PRId64 ".%09" PRId64 " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n",
                  p.t_ns < 0 ? "-" : "", abs_ns / kNsPerS, abs_ns % kNsPerS, t.x(), t.y(), t.z(),
                  q.x(), q.y(), q.z(), q.w());
    text += buf;
  }
  return writeFileAtomically(file, text);
}

}  // namespace evermap::eval
