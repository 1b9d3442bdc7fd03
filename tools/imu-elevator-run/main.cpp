// evermap-imu-elevator-run: the offline runner for imu-proc and elevator-proc.
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "core/common/option_fields.h"
#include "core/datasets/euroc.h"
#include "imu-proc/attitude_evaluation.h"
#include "imu-proc/attitude_filter.h"

int main(int argc, char** argv) {
  using namespace evermap;
  std::string imu_csv, gt_file, dump;
  double offset_ms = 0;
  imu::AttitudeFilterOptions options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--euroc-imu") imu_csv = argv[i + 1];
    else if (a == "--ground-truth") gt_file = argv[i + 1];
    else if (a == "--time-offset-ms") offset_ms = std::stod(argv[i + 1]);
    else if (a == "--dump-attitude") dump = argv[i + 1];
    else if (a == "--set") {
      const Status st = setFieldFromAssignment(&options, argv[i + 1]);
      if (!st.ok()) { std::fprintf(stderr, "%s\n", st.error().message.c_str()); return 2; }
    }
  }
  const auto samples = datasets::readEurocImu(imu_csv);
  if (!samples.ok()) { std::fprintf(stderr, "%s\n", samples.error().message.c_str()); return 1; }
  imu::AttitudeFilter f(options);
  std::vector<imu::Attitude> track;
  for (const auto& s : *samples) {
    imu::ImuSample x{s.t_ns / 1000 + static_cast<int64_t>(offset_ms * 1000), s.gyro_rad_s, s.accel_m_s2};
    if (f.add(x)) track.push_back(f.attitude());
  }
  if (!dump.empty()) {
    std::ofstream out(dump);
    for (const auto& a : track) out << a.utime << ' ' << a.roll_rad << ' ' << a.pitch_rad << ' ' << a.covariance(0,0) << ' ' << a.covariance(1,1) << ' ' << int(a.accel_trusted) << '\n';
  }
  if (!gt_file.empty()) {
    const auto gt = datasets::readEurocGroundTruth(gt_file);
    if (!gt.ok()) { std::fprintf(stderr, "%s\n", gt.error().message.c_str()); return 1; }
    imu::AttitudeCompareOptions c;
    c.max_offset_s = 0.06;
    std::printf("raw: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
    c.align_gravity = true;
    std::printf("world: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
    c.align_body = true;
    std::printf("world+body: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
    c.align_body = false; c.align_gravity = false; c.level_body = true;
    std::printf("level raw: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
    c.align_gravity = true;
    std::printf("level world: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
    c.align_body = true;
    std::printf("level world+body: %s\n", imu::compareAttitude(track, *gt, c).summary().c_str());
  }
  std::printf("%s\n%s\nstill start %d bias %g %g %g\n", f.counts().summary().c_str(), f.gateCounts().summary().c_str(), int(f.counts().still_start), f.gyroBias()[0], f.gyroBias()[1], f.gyroBias()[2]);
}
