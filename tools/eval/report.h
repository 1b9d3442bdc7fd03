#pragma once
// An evaluation report as text for a person and as JSON for scripts. The JSON is written by
// hand (no dependency): objects, arrays, strings with escapes, numbers with 10 significant
// digits, and null where a number is not finite. Keys:
//   ground_truth {file, format, poses, matched_path_m}, estimate {file, format, poses,
//   matched_path_m}, association {max_dt_s, pairs, max_abs_dt_s, mean_abs_dt_s},
//   alignment {mode, scale, rotation_wxyz, rotation_deg, translation_m, rotation_unique},
//   ate {translation_m, rotation_deg}, rpe {delta_frames | delta_m, translation_m,
//   rotation_deg}, kitti_drift {segments, translation_percent, rotation_deg_per_100m,
//   per_length [...]} (only when computed);
//   each statistics object holds count, rmse, mean, median, std, min, max.

#include <filesystem>
#include <string>

#include "core/common/expected.h"
#include "tools/eval/evaluation.h"

namespace evermap::eval {

// A few aligned lines, as evermap-eval prints them.
std::string formatText(const EvaluationReport& report);
// One JSON object, pretty-printed with two-space indentation.
std::string formatJson(const EvaluationReport& report);
// formatJson through a temporary file and a rename.
Status writeJson(const EvaluationReport& report, const std::filesystem::path& file);

}  // namespace evermap::eval
