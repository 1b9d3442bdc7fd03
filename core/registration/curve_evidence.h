#pragma once
// Evidence on one calibration parameter (a stereo rig's disparity offset, a rolling shutter's
// line delay) from the pairs of frames a visual odometry registers anyway. Each pair gives its
// own cost curve over a grid of candidate values (its motion re-solved under each candidate,
// robust costs: disparity_offset.h). The evidence is judged, not assumed:
//  - a pair whose own curve is flat (the parameter is not observable from it: a disparity
//    offset without translation against a range of depths, a line delay without rotation) or
//    has its minimum at an end of the grid is not evidence: examined, not used;
//  - pairs whose own minimum lies far from the others' (more than outlier_mads robust
//    deviations, and more than min_outlier_distance, from their median: a moving object, a
//    wrong registration) are left out;
//  - the estimate is the least cost of the used pairs' summed curves; its standard error is
//    their jackknife's, leaving out one *group* at a time (no trust in the nominal noise): the
//    pairs of one group share a frame (the odometry's reference), whose errors they all carry,
//    so they are not independent evidence;
//  - the last max_pairs informative pairs are kept (older ones are dropped as new ones come):
//    the evidence of a slow start is not thrown away, and the cost stays bounded.
// What to do with a converged estimate (apply it, keep the calibration) is the caller's.
//
// A second parameter (the disparity's row slope beside the offset) may be given on a small grid
// of its own ("rows"): each pair then gives a table, one curve per row, each its motion re-solved
// under both candidates (possibly on fewer points than the curve of the pair itself, which
// comes with it). The pairs are judged, and the first parameter estimated, on that
// curve, exactly as without rows; besides, the rows' summed curves give a profile (each row's
// least cost) whose minimum is the second parameter's estimate, with the first's at it, and
// their jackknife standard errors over the same groups.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace evermap::core {

struct CurveEvidenceOptions {
  // A pair is evidence when its own curve's curvature at its minimum gives a standard deviation
  // of at most this (the grid's unit, under the nominal noise).
  double max_pair_sigma = 1.0;
  int min_groups = 8;   // an estimate needs pairs of at least this many groups
  int max_pairs = 150;  // informative pairs kept (the latest)
  double outlier_mads = 3.0;
  double min_outlier_distance = 0.5;  // the grid's unit
};

struct CurveEstimate {
  double value = 0.0;  // 0 until pairs of min_groups groups are used
  double standard_error = std::numeric_limits<double>::infinity();
  int pairs_examined = 0;
  int pairs_informative = 0;  // kept as evidence: not flat, a minimum inside the grid
  int pairs_used = 0;
  int groups_used = 0;
  int pairs_left_out = 0;  // outliers among the informative ones
  std::string message;     // why there is no estimate yet, when the summed curve says why
  // With rows: the second parameter at the profile's minimum, and the first's value there
  // (both with the jackknife's standard error; infinite when the profile's least cost is at an
  // end of the rows, in the whole or with some group left out).
  double row_value = 0.0;
  double row_standard_error = std::numeric_limits<double>::infinity();
  double joint_value = 0.0;
  double joint_standard_error = std::numeric_limits<double>::infinity();
};

class CurveEvidence {
 public:
  // `grid`: the candidates, increasing and evenly spaced.
  CurveEvidence(std::vector<double> grid, const CurveEvidenceOptions& options)
      : grid_(std::move(grid)), options_(options) {}
  // With a second parameter: `rows`, increasing and evenly spaced, of odd size.
  CurveEvidence(std::vector<double> grid, std::vector<double> rows,
                const CurveEvidenceOptions& options)
      : grid_(std::move(grid)), rows_(std::move(rows)), options_(options) {}

  const std::vector<double>& grid() const { return grid_; }
  const std::vector<double>& rows() const { return rows_; }
  // One pair's costs at the grid's candidates, of `group`.
  void add(std::vector<double> costs, int64_t group);
  // With rows: the pair's curve (judged and used as without rows) and, asked only when the
  // curve is kept as evidence (they cost rows().size() curves), one curve per row (each over
  // the grid, all on the same points).
  void add(std::vector<double> costs,
           const std::function<std::vector<std::vector<double>>()>& table, int64_t group);
  void clear();
  // The estimate from the pairs so far (computed when asked after a change).
  const CurveEstimate& estimate() const;
  // Pairs of min_groups groups used and a standard error of at most `max_standard_error`.
  bool converged(double max_standard_error) const {
    return estimate().groups_used >= options_.min_groups &&
           estimate().standard_error <= max_standard_error;
  }

 private:
  // Keeps the pair's curve when it is informative (its least cost subtracted).
  bool addCurve(std::vector<double> costs, int64_t group);
  void dropOldest();
  void update() const;
  void updateRows(const std::vector<size_t>& used, const std::vector<int64_t>& groups) const;

  std::vector<double> grid_;
  std::vector<double> rows_;  // empty: one parameter
  CurveEvidenceOptions options_;
  // The informative pairs: their curves (least cost subtracted) and own minima; with rows,
  // their tables (each row's cost, as given).
  std::vector<std::vector<double>> curves_;
  std::vector<std::vector<std::vector<double>>> tables_;
  std::vector<double> minima_;
  std::vector<int64_t> groups_;
  int pairs_examined_ = 0;
  mutable bool stale_ = false;
  mutable CurveEstimate estimate_;
};

}  // namespace evermap::core
