#pragma once
// A localization run recorded live (docs/localization.md): the LOCALIZATION messages
// mapper-proc --localize published and the GROUND_TRUTH of the replayed session, read from one
// LCM log, and the stored map put in the truth's frame, for eval::evaluateLocalization.

#include <cstdint>
#include <filesystem>
#include <map>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/umeyama.h"
#include "tools/eval/localization_accuracy.h"
#include "tools/pipeline-eval/map_evaluation.h"

namespace evermap::mapper {

struct RecordedLocalization {
  std::vector<eval::LocalizedPose> poses;  // LOCALIZATION, in time order; a stamp given twice
                                           // (a VO frame and a wheel increment): the later
  std::map<int64_t, core::SE3d> truth;     // GROUND_TRUTH by utime
  int64_t undecodable = 0;                 // messages of either channel that did not decode
};
// Errors name the file: unreadable, cut mid-event, no LOCALIZATION message.
Expected<RecordedLocalization> readRecordedLocalization(const std::filesystem::path& log);

// The map in the truth's frame: its nodes with truth at their keyframes (eval::mapToTruth).
Expected<core::Similarity> mapInTruth(const EvalMap& map, const RunTruth& truth);

// The map's nodes with truth at their keyframes, by node id (the figures against the node
// tracked).
std::map<int64_t, eval::StoredNodeTruth> storedNodesInTruth(const EvalMap& map,
                                                            const RunTruth& truth);

}  // namespace evermap::mapper
