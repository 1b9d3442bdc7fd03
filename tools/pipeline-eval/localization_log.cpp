#include "tools/pipeline-eval/localization_log.h"

#include <string>

#include <evermap/localization_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "tools/lcmlog/log_reader.h"

namespace evermap::mapper {
namespace {

// One LOCALIZATION message as a pose; false when it does not decode or its pose is not one.
bool decodeLocalization(const messages::LogReader::Event& ev, eval::LocalizedPose* out) {
  auto m = messages::decodeLcm<localization_t>(ev.data, ev.datalen, ev.channel);
  if (!m) return false;
  auto pose = messages::fromMsg(m->pose);
  if (!pose) return false;
  out->utime = m->utime;
  out->placed = m->placed;
  out->localized = m->localized;
  out->world_T_body = pose->mean;
  out->node = m->node_id;
  return true;
}

}  // namespace

Expected<RecordedLocalization> readRecordedLocalization(const std::filesystem::path& file) {
  auto opened = messages::LogReader::open(file);
  if (!opened) return opened.error();
  messages::LogReader& log = *opened;
  RecordedLocalization r;
  std::map<int64_t, eval::LocalizedPose> by_time;
  while (const messages::LogReader::Event* ev = log.next()) {
    const std::string channel = ev->channel;
    if (channel == channels::kLocalization) {
      eval::LocalizedPose p;
      if (!decodeLocalization(*ev, &p)) {
        ++r.undecodable;
        continue;
      }
      by_time[p.utime] = p;
    } else if (channel == channels::kGroundTruth) {
      auto p = decodeLoggedPose(*ev);
      if (!p) {
        ++r.undecodable;
        continue;
      }
      r.truth[p->msg.utime] = p->world_T_body;
    }
  }
  if (Status s = log.status(); !s) return s.error();
  if (by_time.empty()) return makeError(file.string(), ": no LOCALIZATION message in the log");
  for (auto& [utime, p] : by_time) r.poses.push_back(p);
  return r;
}

Expected<core::Similarity> mapInTruth(const EvalMap& map, const RunTruth& truth) {
  std::vector<core::SE3d> est, gt;
  for (const EvalNode& n : map.nodes) {
    core::SE3d t;
    if (!truth.at(n.keyframe_utime, &t)) continue;
    est.push_back(n.world_T_body);
    gt.push_back(t);
  }
  return eval::mapToTruth(est, gt);
}

std::map<int64_t, eval::StoredNodeTruth> storedNodesInTruth(const EvalMap& map,
                                                            const RunTruth& truth) {
  std::map<int64_t, eval::StoredNodeTruth> out;
  for (const EvalNode& n : map.nodes) {
    core::SE3d t;
    if (truth.at(n.keyframe_utime, &t)) out[n.id] = {n.world_T_body, t};
  }
  return out;
}

}  // namespace evermap::mapper
