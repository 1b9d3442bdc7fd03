#include "tools/eval/report.h"

#include <cmath>
#include <cstdio>
#include <numbers>

#include "core/common/atomic_write.h"
#include "core/common/number_text.h"
#include "core/common/quoted_text.h"

namespace evermap::eval {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// ---- JSON ----

std::string jsonString(const std::string& s) { return quotedText(s, /*escape_controls=*/true); }

std::string jsonNumber(double v) { return std::isfinite(v) ? numberText(v, 10) : "null"; }

// Builds one pretty-printed object; members are added in order.
class JsonObject {
 public:
  explicit JsonObject(int indent) : indent_(indent) {}
  JsonObject& raw(const std::string& key, const std::string& json) {
    body_ += (body_.empty() ? "" : ",\n") + std::string(indent_ + 2, ' ') + jsonString(key) + ": " +
             json;
    return *this;
  }
  JsonObject& number(const std::string& key, double v) { return raw(key, jsonNumber(v)); }
  JsonObject& integer(const std::string& key, size_t v) { return raw(key, std::to_string(v)); }
  JsonObject& string(const std::string& key, const std::string& v) {
    return raw(key, jsonString(v));
  }
  JsonObject& boolean(const std::string& key, bool v) { return raw(key, v ? "true" : "false"); }
  std::string str() const { return "{\n" + body_ + "\n" + std::string(indent_, ' ') + "}"; }

 private:
  int indent_;
  std::string body_;
};

std::string jsonArray(std::initializer_list<double> values) {
  std::string s = "[";
  for (double v : values) s += (s.size() > 1 ? ", " : "") + jsonNumber(v);
  return s + "]";
}

std::string jsonStats(const ErrorStats& s, int indent) {
  return JsonObject(indent)
      .integer("count", s.count)
      .number("rmse", s.rmse)
      .number("mean", s.mean)
      .number("median", s.median)
      .number("std", s.std)
      .number("min", s.min)
      .number("max", s.max)
      .str();
}

// ---- text ----

std::string fmt(const char* format, auto... args) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

std::string statsLine(const char* label, const ErrorStats& s) {
  return fmt("  %-17s rmse %-9.4g mean %-9.4g median %-9.4g std %-9.4g max %.4g\n", label, s.rmse,
             s.mean, s.median, s.std, s.max);
}

}  // namespace

std::string formatJson(const EvaluationReport& r) {
  JsonObject gt(2);
  gt.string("file", r.gt_source);
  if (!r.gt_format.empty()) gt.string("format", r.gt_format);
  gt.integer("poses", r.gt_poses).number("matched_path_m", r.gt_path_m);
  JsonObject est(2);
  est.string("file", r.est_source);
  if (!r.est_format.empty()) est.string("format", r.est_format);
  est.integer("poses", r.est_poses).number("matched_path_m", r.est_path_m);

  const Similarity& S = r.alignment.gt_S_est;
  const Eigen::Quaterniond& q = S.rigid.quaternion();
  const core::Vec3& t = S.rigid.translation();
  JsonObject rpe(2);
  if (r.rpe.options.byDistance()) {
    rpe.number("delta_m", r.rpe.options.delta_distance_m);
  } else {
    rpe.integer("delta_frames", static_cast<size_t>(r.rpe.options.delta_frames));
  }
  rpe.raw("translation_m", jsonStats(r.rpe.translation_m, 4))
      .raw("rotation_deg", jsonStats(r.rpe.rotation_deg, 4));

  JsonObject root(0);
  root.raw("ground_truth", gt.str())
      .raw("estimate", est.str())
      .raw("association", JsonObject(2)
                              .number("max_dt_s", r.options.association.max_dt_s)
                              .integer("pairs", r.pairs)
                              .number("max_abs_dt_s", r.max_abs_dt_s)
                              .number("mean_abs_dt_s", r.mean_abs_dt_s)
                              .str())
      .raw("alignment", JsonObject(2)
                            .string("mode", toString(r.alignment.mode))
                            .number("scale", S.scale)
                            .raw("rotation_wxyz", jsonArray({q.w(), q.x(), q.y(), q.z()}))
                            .number("rotation_deg", core::rotationAngle(S.rigid.so3()) * kRadToDeg)
                            .raw("translation_m", jsonArray({t.x(), t.y(), t.z()}))
                            .boolean("rotation_unique", r.alignment.rotation_unique)
                            .str())
      .raw("ate", JsonObject(2)
                      .raw("translation_m", jsonStats(r.ate.translation_m, 4))
                      .raw("rotation_deg", jsonStats(r.ate.rotation_deg, 4))
                      .str())
      .raw("rpe", rpe.str());
  if (r.drift) {
    std::string rows = "[";
    for (const KittiDriftLength& row : r.drift->per_length) {
      rows += (rows.size() > 1 ? ", " : "") + std::string("\n      ") +
              fmt("{\"length_m\": %s, \"segments\": %zu, \"translation_percent\": %s, "
                  "\"rotation_deg_per_100m\": %s}",
                  jsonNumber(row.length_m).c_str(), row.segments,
                  jsonNumber(row.translation_percent).c_str(),
                  jsonNumber(row.rotation_deg_per_100m).c_str());
    }
    rows += "\n    ]";
    root.raw("kitti_drift", JsonObject(2)
                                .integer("segments", r.drift->segments)
                                .number("translation_percent", r.drift->translation_percent)
                                .number("rotation_deg_per_100m", r.drift->rotation_deg_per_100m)
                                .raw("per_length", rows)
                                .str());
  }
  return root.str() + "\n";
}

std::string formatText(const EvaluationReport& r) {
  std::string s;
  s += fmt("ground truth  %s (%s%s%zu poses, %.4g m matched)\n", r.gt_source.c_str(),
           r.gt_format.c_str(), r.gt_format.empty() ? "" : ", ", r.gt_poses, r.gt_path_m);
  s += fmt("estimate      %s (%s%s%zu poses, %.4g m matched after alignment)\n",
           r.est_source.c_str(), r.est_format.c_str(), r.est_format.empty() ? "" : ", ",
           r.est_poses, r.est_path_m);
  s += fmt("association   %zu pairs within %s s (|dt| max %.3g s, mean %.3g s)\n", r.pairs,
           numberText(r.options.association.max_dt_s).c_str(), r.max_abs_dt_s, r.mean_abs_dt_s);
  const Similarity& S = r.alignment.gt_S_est;
  const core::Vec3& t = S.rigid.translation();
  s += fmt("alignment     %s: scale %.6g, rotation %.4g deg, translation (%.4g, %.4g, %.4g) m%s\n",
           toString(r.alignment.mode), S.scale, core::rotationAngle(S.rigid.so3()) * kRadToDeg,
           t.x(), t.y(), t.z(),
           r.alignment.rotation_unique ? "" : " (collinear path: rotation about it undetermined)");
  s += "ATE\n";
  s += statsLine("translation [m]", r.ate.translation_m);
  s += statsLine("rotation [deg]", r.ate.rotation_deg);
  if (r.rpe.options.byDistance()) {
    s += fmt("RPE over %s m (%zu pairs)\n", numberText(r.rpe.options.delta_distance_m).c_str(),
             r.rpe.translation_m.count);
  } else {
    s += fmt("RPE over %d frame%s (%zu pairs)\n", r.rpe.options.delta_frames,
             r.rpe.options.delta_frames == 1 ? "" : "s", r.rpe.translation_m.count);
  }
  s += statsLine("translation [m]", r.rpe.translation_m);
  s += statsLine("rotation [deg]", r.rpe.rotation_deg);
  if (r.drift) {
    s += fmt("KITTI drift   translation %.4g %%, rotation %.4g deg/100 m (%zu segments)\n",
             r.drift->translation_percent, r.drift->rotation_deg_per_100m, r.drift->segments);
    for (const KittiDriftLength& row : r.drift->per_length) {
      if (row.segments == 0) continue;
      s += fmt("  %4.0f m  %7.4g %%  %7.4g deg/100 m  (%zu)\n", row.length_m,
               row.translation_percent, row.rotation_deg_per_100m, row.segments);
    }
  }
  return s;
}

Status writeJson(const EvaluationReport& report, const std::filesystem::path& file) {
  return writeFileAtomically(file, formatJson(report));
}

}  // namespace evermap::eval
