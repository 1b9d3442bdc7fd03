// evermap-slam-run --localize's files (localize_runner.h).

#include <sstream>

#include "core/common/atomic_write.h"
#include "tools/slam-run/localize_runner.h"

namespace evermap::slam_run {

Status writeLocalization(const std::filesystem::path& out, const LocalizeRunner& runner,
                         const LocalizeSummary& summary) {
  std::ostringstream csv;
  csv.precision(9);
  csv << "utime,localized,placed,floor,node,x,y,z,qw,qx,qy,qz,sigma_x,sigma_y,sigma_z,"
         "sigma_roll,sigma_pitch,sigma_yaw,dead_reckoning_m,"
         "vo_ms,loopclose_ms,localizer_ms,error_m,error_deg\n";
  for (const LocalizeRunner::FrameRow& f : runner.frames()) {
    const core::Vec3& t = f.world_T_body.translation();
    const Eigen::Quaterniond& q = f.world_T_body.quaternion();
    csv << f.utime << "," << (f.localized ? 1 : 0) << "," << (f.placed ? 1 : 0) << "," << f.floor
        << "," << f.node << "," << t.x() << "," << t.y() << "," << t.z() << "," << q.w() << ","
        << q.x() << "," << q.y() << "," << q.z();
    for (int i = 0; i < 6; ++i) csv << "," << f.sigma[i];
    csv << "," << f.dead_reckoning_m << "," << f.vo_ms << "," << f.loopclose_ms << ","
        << f.localizer_ms << "," << f.error_m << "," << f.error_deg << "\n";
  }
  if (Status s = writeFileAtomically(out / "localization.csv", csv.str()); !s) return s;
  return writeFileAtomically(out / "localize-summary.txt", summary.text());
}

}  // namespace evermap::slam_run
