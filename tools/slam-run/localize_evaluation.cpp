// evermap-slam-run --localize against the truth (localize_runner.h): the map put in the truth's
// frame by its nodes, each localized frame's error, and the summary.

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

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
  // The figures against the node tracked need the nodes' ids and both orientations (a nodes.csv
  // written before they were columns has neither).
  bool with_nodes = cols.count("node") > 0;
  for (const char* c : {"qw", "qx", "qy", "qz", "true_qw", "true_qx", "true_qy", "true_qz"})
    with_nodes = with_nodes && cols.count(c) > 0;
  std::vector<core::SE3d> est, gt;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) v.push_back(std::strtod(cell.c_str(), nullptr));
    auto at = [&](const char* c) {
      return cols.count(c) && cols.at(c) < v.size() ? v[cols.at(c)] : NAN;
    };
    // The orientations (qw..qz, true_qw..true_qz) matter to a map of one or two nodes, or of
    // nodes along one line (eval::mapToTruth), and to the figures against the node tracked.
    auto rotation = [&](const char* w, const char* x, const char* y, const char* z) {
      const Eigen::Quaterniond q(at(w), at(x), at(y), at(z));
      return q.coeffs().allFinite() && q.norm() > 0.5 ? q.normalized()
                                                      : Eigen::Quaterniond::Identity();
    };
    est.emplace_back(rotation("qw", "qx", "qy", "qz"), core::Vec3(at("x"), at("y"), at("z")));
    gt.emplace_back(rotation("true_qw", "true_qx", "true_qy", "true_qz"),
                    core::Vec3(at("true_x"), at("true_y"), at("true_z")));
    if (with_nodes && std::isfinite(at("node")))
      node_truth_[static_cast<int64_t>(at("node"))] = {est.back(), gt.back()};
  }
  auto fit = eval::mapToTruth(est, gt);
  if (!fit) return makeError(nodes_csv.string(), ": ", fit.error().message);
  map_to_truth_ = *fit;
  return Ok{};
}

void LocalizeRunner::evaluate(std::vector<eval::LocalizedPose>& poses, LocalizeSummary& s) {
  if (!map_to_truth_ || truth_.empty()) return;
  s.truth = eval::evaluateLocalization(poses, *map_to_truth_, truth_, node_truth_, s.truth.false_m,
                                       s.truth.false_deg);
  for (size_t i = 0; i < frames_.size(); ++i) {
    frames_[i].error_m = poses[i].error_m;
    frames_[i].error_deg = poses[i].error_deg;
  }
}

LocalizeSummary LocalizeRunner::finish() {
  LocalizeSummary& s = summary_;
  s.truth.false_m = options_.false_closure_m;
  s.truth.false_deg = options_.false_closure_deg;
  std::vector<eval::LocalizedPose> poses;
  for (const FrameRow& f : frames_)
    poses.push_back({f.utime, f.placed, f.localized, f.world_T_body, f.node});
  eval::LocalizationAccuracy counts;
  eval::countLocalized(poses, &counts);
  s.frames = counts.poses;
  s.localized_frames = counts.localized;
  s.first_localized_s = counts.first_localized_s;
  double vo = 0, lc = 0, loc = 0;
  for (const FrameRow& f : frames_) {
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
  evaluate(poses, s);
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
  o << eval::truthLine(truth);
  o << "input_errors " << input_errors << "\n";
  for (const std::string& e : errors) o << "  " << e << "\n";
  return o.str();
}

}  // namespace evermap::slam_run
