// evermap-slam-run --localize against the truth (localize_runner.h): the map put in the truth's
// frame by its nodes, each localized frame's error, and the summary.

#include <cmath>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/common/percentile.h"
#include "tools/eval/alignment.h"
#include "tools/slam-run/localize_runner.h"

namespace evermap::slam_run {
namespace {

// The columns of a CSV header line, by name.
std::map<std::string, size_t> columnsOf(const std::string& header) {
  std::map<std::string, size_t> out;
  std::stringstream ss(header);
  std::string name;
  for (size_t i = 0; std::getline(ss, name, ','); ++i) out[name] = i;
  return out;
}

}  // namespace

Status LocalizeRunner::setMapTruth(const std::filesystem::path& nodes_csv) {
  std::ifstream in(nodes_csv);
  std::string line;
  if (!in || !std::getline(in, line)) return makeError(nodes_csv.string(), ": cannot read");
  const auto cols = columnsOf(line);
  for (const char* c : {"x", "y", "z", "true_x", "true_y", "true_z"})
    if (!cols.count(c)) return makeError(nodes_csv.string(), ": no column ", c, " (nodes.csv)");
  std::vector<core::Vec3> est, gt;
  std::optional<core::SE3d> first_est, first_gt;  // the first node's whole pose, when given
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) v.push_back(std::strtod(cell.c_str(), nullptr));
    auto at = [&](const char* c) {
      return cols.count(c) && cols.at(c) < v.size() ? v[cols.at(c)] : NAN;
    };
    est.emplace_back(at("x"), at("y"), at("z"));
    gt.emplace_back(at("true_x"), at("true_y"), at("true_z"));
    const Eigen::Quaterniond q(at("qw"), at("qx"), at("qy"), at("qz"));
    const Eigen::Quaterniond true_q(at("true_qw"), at("true_qx"), at("true_qy"), at("true_qz"));
    if (!first_est && q.coeffs().allFinite() && true_q.coeffs().allFinite() && q.norm() > 0.5 &&
        true_q.norm() > 0.5) {
      first_est = core::SE3d(q.normalized(), est.back());
      first_gt = core::SE3d(true_q.normalized(), gt.back());
    }
  }
  // A map of one or two nodes (a camera turning in place): the first node's pose puts it in
  // the truth's frame; three or more: the least-squares fit of all their positions.
  if (est.size() < 3 && first_est) {
    map_to_truth_ = core::Similarity{1.0, *first_gt * first_est->inverse()};
    return Ok{};
  }
  auto fit = eval::umeyama(est, gt, false);
  if (!fit) return makeError(nodes_csv.string(), ": ", fit.error().message);
  map_to_truth_ = fit->gt_S_est;
  return Ok{};
}

void LocalizeRunner::evaluate(LocalizeSummary& s) {
  if (!map_to_truth_ || truth_.empty()) return;
  std::vector<double> errors;
  double yaw2 = 0.0;
  s.false_frames = 0;
  s.false_placements = 0;
  bool was_localized = false;
  for (FrameRow& f : frames_) {
    const bool placement = f.localized && !was_localized;
    was_localized = f.localized;
    // The truth at the frame's time (rendered: the same stamps), within 25 ms.
    auto it = truth_.lower_bound(f.utime - 25000);
    if (it == truth_.end() || it->first > f.utime + 25000 || !f.placed) continue;
    const core::SE3d est = *map_to_truth_ * f.world_T_body;
    f.error_m = (est.translation() - it->second.translation()).norm();
    const Eigen::AngleAxisd d(it->second.quaternion().conjugate() * est.quaternion());
    f.error_deg = std::abs(d.angle()) * 180.0 / std::numbers::pi;
    if (!f.localized) continue;
    errors.push_back(f.error_m);
    yaw2 += f.error_deg * f.error_deg;
    const bool wrong = f.error_m > s.false_m || f.error_deg > s.false_deg;
    if (wrong) ++s.false_frames;
    if (wrong && placement) ++s.false_placements;
  }
  s.frames_with_truth = static_cast<int64_t>(errors.size());
  if (errors.empty()) return;
  double sq = 0.0;
  for (double e : errors) sq += e * e;
  s.ate_rmse_m = std::sqrt(sq / static_cast<double>(errors.size()));
  s.ate_p95_m = percentile(errors, 0.95);
  s.ate_max_m = *std::max_element(errors.begin(), errors.end());
  s.yaw_rmse_deg = std::sqrt(yaw2 / static_cast<double>(errors.size()));
}

LocalizeSummary LocalizeRunner::finish() {
  LocalizeSummary& s = summary_;
  s.false_m = options_.false_closure_m;
  s.false_deg = options_.false_closure_deg;
  s.frames = static_cast<int64_t>(frames_.size());
  double vo = 0, lc = 0, loc = 0;
  for (const FrameRow& f : frames_) {
    s.localized_frames += f.localized ? 1 : 0;
    vo += f.vo_ms;
    lc += f.loopclose_ms;
    loc += f.localizer_ms;
  }
  if (s.frames > 0) {
    const auto n = static_cast<double>(s.frames);
    s.vo_ms = vo / n;
    s.loopclose_ms = lc / n;
    s.localizer_ms = loc / n;
  }
  s.localizer = localizer_->stats();
  s.loopclose = loop_closer_->stats();
  evaluate(s);
  return s;
}

std::string LocalizeSummary::text() const {
  std::ostringstream o;
  const double pct =
      frames > 0 ? 100.0 * static_cast<double>(localized_frames) / static_cast<double>(frames)
                 : 0.0;
  o << "frames " << frames << "\nlocalized_frames " << localized_frames << " (" << pct
    << " %)\nfirst_localized_s " << first_localized_s << "\n";
  const mapper::LocalizerStats& l = localizer;
  o << "localizer steps " << l.steps << " requests_node " << l.requests_node << " requests_global "
    << l.requests_global << " registrations_ok " << l.registrations_ok << " placements "
    << l.placements << " corrections " << l.corrections << " refused_gate " << l.refused_gate
    << " gate_recoveries " << l.gate_recoveries << " recoveries_too_far " << l.recoveries_too_far
    << " placements_too_far " << l.placements_too_far << " refused_floor " << l.refused_floor
    << " disagreements " << l.disagreements << " unlocalized " << l.unlocalized << " timeouts "
    << l.timeouts << " dropped " << l.dropped << " rides " << l.rides << " vertical_alarms "
    << l.vertical_alarms << "\n";
  o << "loopclose nodes " << loopclose.nodes << " keyframes " << loopclose.keyframes << "\n";
  o << "ms_per_frame vo " << vo_ms << " loopclose " << loopclose_ms << " localizer " << localizer_ms
    << "\n";
  o << "truth frames_localized " << frames_with_truth << " ate_rmse_m " << ate_rmse_m
    << " ate_p95_m " << ate_p95_m << " ate_max_m " << ate_max_m << " rot_rmse_deg " << yaw_rmse_deg
    << " false_frames " << false_frames << " false_placements " << false_placements << " (beyond "
    << false_m << " m or " << false_deg << " deg)\n";
  o << "input_errors " << input_errors << "\n";
  for (const std::string& e : errors) o << "  " << e << "\n";
  return o.str();
}

}  // namespace evermap::slam_run
