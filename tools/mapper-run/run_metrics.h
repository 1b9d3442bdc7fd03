#pragma once
// Measurements of an offline run that are not the mapper's own: the timeline (nodes and
// per-component mapper time against operating time, the paper's Fig. 7) and the "mapped
// area" test (did a session add nodes where an earlier one had mapped?).

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <tuple>
#include <vector>

#include "core/common/expected.h"
#include "core/common/percentile.h"
#include "core/geometry/se3.h"
#include "mapper-proc/mapper.h"
#include "tools/mapper-run/offline_run.h"

namespace evermap::mapper {

// Per-component wall time and step costs of the mapper between two timeline rows.
class TimelineRecorder {
 public:
  TimelineRecorder(const Mapper& mapper, double interval_s)
      : mapper_(mapper), interval_s_(interval_s) {}
  // Fills a row's store columns (TimelineRow::store_rows, store_bytes) when it is taken.
  void setStoreProbe(std::function<void(TimelineRow*)> probe) { store_probe_ = std::move(probe); }
  // Counts the views of the true poses (TimelineRow::views) when a row is taken.
  void setViewProbe(std::function<int64_t()> probe) { view_probe_ = std::move(probe); }

  void sample(double operating_s, int64_t utime, int session, bool force = false) {
    if (!(interval_s_ > 0.0) || (!force && operating_s < next_s_)) return;
    next_s_ = (std::floor(operating_s / interval_s_) + 1.0) * interval_s_;
    const MapperStats& st = mapper_.stats();
    const MapperTiming& t = st.timing;
    TimelineRow r;
    r.operating_s = operating_s;
    r.utime = utime;
    r.session = session;
    r.nodes = static_cast<int64_t>(mapper_.nodes().size());
    r.factors = st.factors;
    r.tracking_s = t.tracking_s - last_.tracking_s;
    r.registration_s = t.registration_s - last_.registration_s;
    r.partition_s = t.partition_s - last_.partition_s;
    r.solver_s = t.solver_s - last_.solver_s;
    std::vector<double> ms;
    for (size_t k = steps_seen_; k < t.step_cost.size(); ++k) ms.push_back(1e3 * t.step_cost[k].s);
    r.steps = static_cast<int64_t>(ms.size());
    r.step_median_ms = percentile(ms, 0.5);
    r.step_p99_ms = percentile(ms, 0.99);
    r.step_max_ms = ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end());
    steps_seen_ = t.step_cost.size();
    if (store_probe_) store_probe_(&r);
    if (view_probe_) r.views = view_probe_();
    last_ = r;
    last_.tracking_s = t.tracking_s;
    last_.registration_s = t.registration_s;
    last_.partition_s = t.partition_s;
    last_.solver_s = t.solver_s;
    rows_.push_back(r);
  }
  std::vector<TimelineRow> take() { return std::move(rows_); }

 private:
  const Mapper& mapper_;
  double interval_s_;
  double next_s_ = 0.0;
  size_t steps_seen_ = 0;
  TimelineRow last_;
  std::vector<TimelineRow> rows_;
  std::function<void(TimelineRow*)> store_probe_;
  std::function<int64_t()> view_probe_;
};

// Items filed by floor in square cells of a given size, for the items near a point: anything
// within one cell's size of it lies in the 3x3 cells around the point's own.
template <class T>
class FloorGrid {
 public:
  explicit FloorGrid(double cell_m) : cell_m_(cell_m) {}
  void add(int floor, double x, double y, T item) {
    cells_[key(floor, x, y, 0, 0)].push_back(std::move(item));
  }
  // Calls near(item) for the items of the cells around (x, y) on `floor`, until it returns
  // true; whether one did.
  template <class F>
  bool any(int floor, double x, double y, F&& near) const {
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        auto it = cells_.find(key(floor, x, y, dx, dy));
        if (it == cells_.end()) continue;
        for (const T& item : it->second)
          if (near(item)) return true;
      }
    }
    return false;
  }

 private:
  using Key = std::tuple<int, int64_t, int64_t>;
  Key key(int floor, double x, double y, int64_t dx, int64_t dy) const {
    return {floor, static_cast<int64_t>(std::floor(x / cell_m_)) + dx,
            static_cast<int64_t>(std::floor(y / cell_m_)) + dy};
  }
  double cell_m_;
  std::map<Key, std::vector<T>> cells_;
};

// True pose and floor of a node (or a step pose)'s keyframe, and the count of nodes placed where an
// earlier session already had one.
struct NodeTruth {
  core::SE3d world_T_body;
  int floor = -1;
  int session = 0;
  bool known = false;
};

// For each session: how many of `queries` lie where an earlier session had a node of `nodes`
// (same true floor, within radius_m and angle_rad), all at their true poses.
std::vector<int64_t> inMappedArea(const std::vector<NodeTruth>& nodes,
                                  const std::vector<NodeTruth>& queries, double radius_m,
                                  double angle_rad);

// Where each query lies against the nodes of earlier sessions (same true floor, true poses):
// the cause a new node has (issue 22's accounting of late nodes).
enum class PlaceCause : uint8_t {
  kNewPlace = 0,    // no earlier node within radius_m
  kNewHeading = 1,  // earlier nodes within radius_m, none within angle_rad of its heading
  kMapped = 2,      // an earlier node within radius_m and angle_rad: a duplicate
  kUnknown = 3,     // no true pose
};
std::vector<PlaceCause> placeCauses(const std::vector<NodeTruth>& nodes,
                                    const std::vector<NodeTruth>& queries, double radius_m,
                                    double angle_rad);

// The views the robot's true poses need (issue 22): a greedy cover of the poses, in the
// order given, where a pose is a new view unless an earlier view lies on its floor within
// radius_m and heading_rad of it (the overlap's reach, MapperOptions::overlap_*). It is
// what Algorithm 1's node rule would make with perfect estimates and no failed
// registration, so its growth after exploration is what the map's can be held against:
// a robot that keeps meeting new views adds nodes however well it maps.
class ViewCover {
 public:
  ViewCover(double radius_m, double heading_rad)
      : radius_m_(radius_m), heading_rad_(heading_rad), views_(radius_m) {}
  // True when world_T_body is a new view.
  bool add(int floor, const core::SE3d& world_T_body);
  int64_t views() const { return count_; }

 private:
  double radius_m_, heading_rad_;
  int64_t count_ = 0;
  FloorGrid<core::SE2d> views_;  // in radius-sized cells
};

}  // namespace evermap::mapper
