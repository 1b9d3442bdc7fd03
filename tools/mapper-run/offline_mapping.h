#pragma once
// The state of one offline run (offline_run.h, runOffline): the mapper, the oracle and the
// broker between them, the map store, and the truth the run's figures are measured against,
// gathered while the simulator generates the sessions.

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "core/common/expected.h"
#include "core/common/progress.h"
#include "core/geometry/se3.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tools/mapper-run/offline_run.h"
#include "tools/mapper-run/oracle_broker.h"
#include "tools/mapper-run/run_metrics.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/run.h"
#include "tools/sim/session_generator.h"

namespace evermap::mapper {

// What the run saw of the truth, for its figures (run_figures.h).
struct RunTruthRecord {
  std::map<int64_t, core::SE3d> world_T_body;       // mapped part, by utime
  std::vector<std::pair<int64_t, int>> step_floor;  // (keyframe utime, true floor), mapped part
  std::vector<NodeTruth> nodes;                     // by node id
  std::vector<int64_t> views_by_session;
  std::vector<std::pair<int64_t, double>> session_offsets;  // (start utime, operating time then)
};

class OfflineMapping {
 public:
  // Contract: `plan` outlives this; the options are valid.
  OfflineMapping(const sim::SimOptions& sim, const sim::RunPlan& plan, const MapperOptions& options,
                 const OfflineRunOptions& run);

  // With OfflineRunOptions::store_file: opens the store and restores its map. Errors: the
  // store.
  Status restore();
  // Generates sessions up to `last_session` (inclusive), mapping those from
  // OfflineRunOptions::first_session on. Errors: the store.
  Status simulate(int last_session);

  const Mapper& mapper() const { return mapper_; }
  const OracleBroker& broker() const { return broker_; }
  const RunTruthRecord& truth() const { return truth_; }
  TimelineRecorder& timeline() { return timeline_; }
  const sim::RunSummary& simulated() const { return simulated_; }
  bool stoppedEarly() const { return stopped_early_; }
  double operatingReachedS() const { return operating_reached_s_; }
  int64_t storeTransactions() const { return transactions_; }
  double storeS() const { return store_s_; }
  double wallS() const;

 private:
  void watchStore();
  void onNode(const node_added_t& n);
  void onKeyframe(const sim::KeyframeTruth& k);
  void afterMessage(int64_t utime);
  bool wallTimeUp();
  void saveStore(int64_t utime);
  // Operating time at `utime`: mapped sessions finished, and the current one so far.
  double operating(int64_t utime) const;
  Progress progressAt(int64_t utime) const;

  const sim::SimOptions& sim_;
  const sim::RunPlan& plan_;
  OfflineRunOptions run_;
  core::SE3d body_T_cam_;
  Mapper mapper_;
  sim::RegistrationOracle oracle_;
  OracleBroker broker_;
  TimelineRecorder timeline_;
  ViewCover views_;
  RunTruthRecord truth_;
  std::chrono::steady_clock::time_point wall_start_;
  std::optional<ProgressReporter> progress_;

  // The map store.
  std::optional<MapStore> store_;
  Status store_status_ = Ok{};
  int64_t stored_nodes_ = 0, stored_constraints_ = 0, transactions_ = 0, tracked_steps_ = 0;
  double store_s_ = 0.0;
  double next_store_s_ = 0.0;  // OfflineRunOptions::store_period_s
  // A stored map: its nodes, told to the oracle as their keyframes come by; the newest
  // message time it covers.
  std::deque<node_added_t> stored_for_oracle_;
  int64_t resume_utime_ = -1;

  // Where the simulation is.
  std::deque<sim::KeyframeTruth> recent_;  // recent keyframe truths, for new nodes' poses
  double operating_before_s_ = 0.0;        // mapped sessions finished
  int64_t session_start_ = -1;
  int current_session_ = 0;
  int first_generated_ = 0, last_session_ = 0;
  int64_t trajectory_start_ = 0, trajectory_end_ = 0;
  int64_t messages_seen_ = 0;
  bool stopped_early_ = false;
  double operating_reached_s_ = 0.0;
  sim::RunSummary simulated_;
};

}  // namespace evermap::mapper
