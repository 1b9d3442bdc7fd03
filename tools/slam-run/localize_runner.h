#pragma once
// evermap-slam-run --localize (docs/localization.md): a session run against a map built before,
// in one process, deterministically. The processes' library classes as in SlamRunner, with the
// mapper replaced by the mapper's Localizer (mapper-proc/localizer.h):
//
//   STEREO_CALIB, STEREO -> vo::VoPipeline -> VO_DELTA, KEYFRAME
//   IMU -> imu::AttitudeStream -> ATTITUDE; IMU + ATTITUDE -> elevator::ElevatorTracker -> FLOOR
//   KEYFRAME, REGISTER_REQUEST -> loopclose::LoopCloser (its place store opened read-only)
//   STEREO_CALIB, VO_DELTA, WHEEL_ODOM, ATTITUDE, FLOOR, REGISTER_RESULT -> mapper::Localizer
//
// The map store and the place store are opened read-only (SQLite SQLITE_OPEN_READONLY): their
// bytes do not change. Per VO frame: the pose in the map frame, whether it is localized, its
// covariance. GROUND_TRUTH, where a log has it, is only used for the evaluation, with the map
// put in the truth's frame by its nodes (slam-run's nodes.csv of the mapping run).

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry/umeyama.h"
#include "mapper-proc/localizer.h"
#include "tools/eval/localization_accuracy.h"
#include "tools/slam-run/slam_runner.h"

namespace evermap::slam_run {

struct SessionProcesses;  // session_processes.h

// What a localization run measured (LocalizeRunner::finish; localize-summary.txt).
struct LocalizeSummary {
  int64_t frames = 0;             // VO frames
  int64_t localized_frames = 0;   // ... with localized = true
  double first_localized_s = -1;  // data time from the first frame to the first localized one
  mapper::LocalizerStats localizer;
  loopclose::LoopCloserStats loopclose;
  int64_t input_errors = 0;
  std::vector<std::string> errors;
  // Mean milliseconds per VO frame: VO, loop closing, localizer.
  double vo_ms = 0, loopclose_ms = 0, localizer_ms = 0;
  // Against the truth (localized frames; -1 without truth or a map truth).
  eval::LocalizationAccuracy truth;

  std::string text() const;
};

class LocalizeRunner {
 public:
  // options.store and options.places: the map's two stores, both required and existing.
  static Expected<std::unique_ptr<LocalizeRunner>> create(const bow::Vocabulary& vocabulary,
                                                          const SlamRunOptions& options);
  ~LocalizeRunner();

  // One session against the map: a log, or the image-level simulator's session rendered.
  Status runLog(const std::filesystem::path& log);
  Status renderSession(const sim::ImageSimOptions& options);
  // The map in the truth's frame: slam-run's nodes.csv (x,y,z and true_x,true_y,true_z; node,
  // the orientations qw..qz and true_qw..true_qz for the figures against the node tracked).
  Status setMapTruth(const std::filesystem::path& nodes_csv);
  LocalizeSummary finish();

  struct FrameRow {
    int64_t utime = 0;
    bool placed = false, localized = false;
    int floor = -1;
    int64_t node = -1;
    core::SE3d world_T_body;
    core::Vec6 sigma = core::Vec6::Zero();  // standard deviations (x y z roll pitch yaw)
    double dead_reckoning_m = 0;            // travelled since the last registration applied
    double vo_ms = 0, loopclose_ms = 0, localizer_ms = 0;
    double error_m = -1, error_deg = -1;  // -1: no truth
  };
  const std::vector<FrameRow>& frames() const { return frames_; }

 private:
  LocalizeRunner(const bow::Vocabulary& vocabulary, const SlamRunOptions& options);
  Status runStream(detail::EventStream& events, const std::string& name);
  void handleEvent(const detail::ReadEvent& e, double* loopclose_s, double* localizer_s);
  void onFrame(const detail::ReadEvent& e, double* loopclose_s, double* localizer_s);
  // One output VO released (vo_s: the time of the input that released it, on its last output).
  void onOutput(const vo::PipelineOutput& out, double vo_s, double* loopclose_s,
                double* localizer_s);
  void onImu(const void* data, int64_t size, double* localizer_s);
  void exchange(double* loopclose_s, double* localizer_s);
  void inputError(const std::string& what);
  // Each frame's error against the truth (with a map truth), and the summary's figures.
  void evaluate(std::vector<eval::LocalizedPose>& poses, LocalizeSummary& s);

  const bow::Vocabulary& vocabulary_;
  SlamRunOptions options_;
  std::unique_ptr<loopclose::CoreRegistration> registration_;
  std::unique_ptr<loopclose::LoopCloser> loop_closer_;
  std::unique_ptr<mapper::Localizer> localizer_;
  mapper::CalibrationLatch calibration_;
  std::unique_ptr<SessionProcesses> p_;  // vo-proc, imu-proc, elevator-proc of the session
  std::vector<FrameRow> frames_;
  std::map<int64_t, core::SE3d> truth_;
  std::optional<core::Similarity> map_to_truth_;
  std::map<int64_t, eval::StoredNodeTruth> node_truth_;  // by node id, from nodes.csv
  LocalizeSummary summary_;
};

}  // namespace evermap::slam_run

namespace evermap::slam_run {

// localization.csv (per VO frame: utime, localized, placed, floor, node, the pose x y z qw qx
// qy qz, its standard deviations sigma_x .. sigma_yaw, dead_reckoning_m, ms per component,
// error against the truth) and localize-summary.txt into `out`.
Status writeLocalization(const std::filesystem::path& out, const LocalizeRunner& runner,
                         const LocalizeSummary& summary);

}  // namespace evermap::slam_run
