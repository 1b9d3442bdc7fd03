#include "core/registration/curve_evidence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/registration/disparity_offset.h"

namespace evermap::core {

namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The jackknife's standard error of `partial` (one estimate per group left out).
double jackknifeError(const std::vector<double>& partial) {
  double mean = 0.0;
  for (double p : partial) mean += p / static_cast<double>(partial.size());
  double sum = 0.0;
  for (double p : partial) sum += (p - mean) * (p - mean);
  const double m = static_cast<double>(partial.size());
  return std::sqrt((m - 1.0) / m * sum);
}

}  // namespace

void CurveEvidence::clear() {
  curves_.clear();
  tables_.clear();
  minima_.clear();
  groups_.clear();
  pairs_examined_ = 0;
  stale_ = false;
  estimate_ = CurveEstimate{};
}

const CurveEstimate& CurveEvidence::estimate() const {
  if (stale_) update();
  return estimate_;
}

void CurveEvidence::add(std::vector<double> costs, int64_t group) {
  if (!rows_.empty()) return;  // with rows, tables
  if (addCurve(std::move(costs), group)) dropOldest();
}

void CurveEvidence::add(std::vector<double> costs,
                        const std::function<std::vector<std::vector<double>>()>& table,
                        int64_t group) {
  if (rows_.empty() || !addCurve(std::move(costs), group)) return;
  tables_.push_back(table());
  if (tables_.back().size() != rows_.size())  // a caller's fault: nothing to the rows
    tables_.back().assign(rows_.size(), std::vector<double>(grid_.size(), 0.0));
  dropOldest();
}

bool CurveEvidence::addCurve(std::vector<double> costs, int64_t group) {
  ++pairs_examined_;
  stale_ = true;
  const Expected<double> own = leastCostOffset(grid_, costs);
  if (!own || grid_.size() < 2) return false;
  // Its curvature at the minimum: the information of this pair alone.
  const auto best_it = std::min_element(costs.begin(), costs.end());
  const size_t best = static_cast<size_t>(best_it - costs.begin());
  const double least = *best_it;
  const double step = grid_[1] - grid_[0];
  const double curvature = (costs[best - 1] - 2.0 * costs[best] + costs[best + 1]) / (step * step);
  if (!(curvature > 0.0 && 1.0 / std::sqrt(curvature) <= options_.max_pair_sigma)) return false;
  for (double& c : costs) c -= least;
  curves_.push_back(std::move(costs));
  minima_.push_back(*own);
  groups_.push_back(group);
  return true;
}

void CurveEvidence::dropOldest() {
  if (curves_.size() <= static_cast<size_t>(options_.max_pairs)) return;
  curves_.erase(curves_.begin());
  minima_.erase(minima_.begin());
  groups_.erase(groups_.begin());
  if (!tables_.empty()) tables_.erase(tables_.begin());
}

void CurveEvidence::update() const {
  stale_ = false;
  // No estimate unless this update makes one (value 0, standard error infinite); the message
  // stays, as the last reason there was none.
  const std::string message = estimate_.message;
  estimate_ = CurveEstimate{};
  estimate_.message = message;
  estimate_.pairs_examined = pairs_examined_;
  const size_t n = curves_.size();
  estimate_.pairs_informative = static_cast<int>(n);
  if (n < static_cast<size_t>(options_.min_groups)) return;
  // Pairs whose own minimum is far from the others' are left out.
  const double mid = median(minima_);
  std::vector<double> deviations;
  for (double m : minima_) deviations.push_back(std::abs(m - mid));
  const double bound =
      std::max(options_.outlier_mads * 1.4826 * median(deviations), options_.min_outlier_distance);
  std::vector<size_t> used;
  for (size_t i = 0; i < n; ++i) {
    if (std::abs(minima_[i] - mid) <= bound) used.push_back(i);
  }
  estimate_.pairs_used = static_cast<int>(used.size());
  estimate_.pairs_left_out = static_cast<int>(n - used.size());
  std::vector<int64_t> groups;
  for (size_t i : used) groups.push_back(groups_[i]);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  estimate_.groups_used = static_cast<int>(groups.size());
  if (groups.size() < static_cast<size_t>(options_.min_groups)) return;
  std::vector<double> total(grid_.size(), 0.0);
  for (size_t i : used) {
    for (size_t s = 0; s < total.size(); ++s) total[s] += curves_[i][s];
  }
  const Expected<double> all = leastCostOffset(grid_, total);
  if (!all) {
    estimate_.message = all.error().message;
    return;
  }
  // Jackknife: the estimate with each group left out in turn.
  std::vector<double> partial;
  for (int64_t g : groups) {
    std::vector<double> without = total;
    for (size_t i : used) {
      if (groups_[i] != g) continue;
      for (size_t s = 0; s < total.size(); ++s) without[s] -= curves_[i][s];
    }
    const Expected<double> e = leastCostOffset(grid_, without);
    if (!e) return;  // one group holds the minimum inside the grid: not converged
    partial.push_back(*e);
  }
  estimate_.value = *all;
  estimate_.standard_error = jackknifeError(partial);
  if (!rows_.empty()) updateRows(used, groups);
}

void CurveEvidence::updateRows(const std::vector<size_t>& used,
                               const std::vector<int64_t>& groups) const {
  const std::vector<std::vector<double>> zero(rows_.size(), std::vector<double>(grid_.size(), 0.0));
  auto summed = [&](int64_t without) {
    auto total = zero;
    for (size_t i : used) {
      if (groups_[i] == without) continue;
      for (size_t r = 0; r < rows_.size(); ++r)
        for (size_t s = 0; s < grid_.size(); ++s) total[r][s] += tables_[i][r][s];
    }
    return total;
  };
  constexpr int64_t kNone = std::numeric_limits<int64_t>::min();
  const auto all = leastCostProfile(grid_, rows_, summed(kNone));
  if (!all) return;
  std::vector<double> rows, joints;
  for (int64_t g : groups) {
    const auto e = leastCostProfile(grid_, rows_, summed(g));
    if (!e) return;  // one group holds the profile's minimum inside the rows: not converged
    rows.push_back(e->first);
    joints.push_back(e->second);
  }
  estimate_.row_value = all->first;
  estimate_.joint_value = all->second;
  estimate_.row_standard_error = jackknifeError(rows);
  estimate_.joint_standard_error = jackknifeError(joints);
}

}  // namespace evermap::core
