#include "tools/eval/alignment.h"

namespace evermap::eval {

const char* toString(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kSE3:
      return "se3";
    case AlignmentMode::kSim3:
      return "sim3";
    case AlignmentMode::kFirstPose:
      return "first";
  }
  return "?";
}

Expected<AlignmentMode> parseAlignmentMode(std::string_view name) {
  if (name == "none") return AlignmentMode::kNone;
  if (name == "se3") return AlignmentMode::kSE3;
  if (name == "sim3") return AlignmentMode::kSim3;
  if (name == "first") return AlignmentMode::kFirstPose;
  return makeError("unknown alignment \"", std::string(name),
                   "\" (expected se3, sim3, first or none)");
}

Expected<AlignmentResult> umeyama(const std::vector<core::Vec3>& src,
                                  const std::vector<core::Vec3>& dst, bool with_scale) {
  auto fit = core::umeyama(src, dst, with_scale);
  if (!fit) return fit.error();
  AlignmentResult out;
  out.mode = with_scale ? AlignmentMode::kSim3 : AlignmentMode::kSE3;
  out.gt_S_est = fit->dst_S_src;
  out.pairs = fit->pairs;
  out.rotation_unique = fit->rotation_unique;
  return out;
}

Expected<AlignmentResult> alignTrajectories(const std::vector<core::SE3d>& gt,
                                            const std::vector<core::SE3d>& est,
                                            AlignmentMode mode) {
  if (gt.size() != est.size()) {
    return makeError("alignment: ", est.size(), " estimated poses but ", gt.size(),
                     " ground-truth poses");
  }
  if (mode == AlignmentMode::kNone) {
    if (gt.empty()) return makeError("alignment: no matched poses");
    AlignmentResult out;
    out.pairs = gt.size();
    return out;
  }
  if (mode == AlignmentMode::kFirstPose) {
    if (gt.empty()) return makeError("alignment: no matched poses");
    AlignmentResult out;
    out.mode = mode;
    out.pairs = gt.size();
    out.gt_S_est.rigid = gt.front() * est.front().inverse();
    return out;
  }
  std::vector<core::Vec3> src;
  std::vector<core::Vec3> dst;
  src.reserve(est.size());
  dst.reserve(gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    src.push_back(est[i].translation());
    dst.push_back(gt[i].translation());
  }
  return umeyama(src, dst, mode == AlignmentMode::kSim3);
}

}  // namespace evermap::eval
