#include "tools/eval/alignment.h"
#include "core/common/enum_names.h"

namespace evermap::eval {

namespace {
constexpr EnumNames<AlignmentMode, 4> kAlignmentModeNames{{
    {AlignmentMode::kSE3, "se3"},
    {AlignmentMode::kSim3, "sim3"},
    {AlignmentMode::kFirstPose, "first"},
    {AlignmentMode::kNone, "none"},
}};
}  // namespace

const char* toString(AlignmentMode mode) { return nameOf(kAlignmentModeNames, mode); }

Expected<AlignmentMode> parseAlignmentMode(std::string_view name) {
  return parseName(kAlignmentModeNames, name, "alignment");
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
