#pragma once
// The whole visual SLAM system in one process (DESIGN.md section 1, "evermap-slam-run"): the
// library classes of the five processes chained in message order, deterministically and as
// fast as the CPU allows, from LCM logs (the image-level simulator, evermap-euroc2lcm,
// evermap-kitti2lcm). Each log is one session, as if the processes had been restarted for it:
//
//   STEREO_CALIB, STEREO -> vo::VoPipeline (vo-proc) -> VO_DELTA, KEYFRAME
//   IMU -> imu::AttitudeStream (imu-proc) -> ATTITUDE
//   IMU + ATTITUDE -> elevator::ElevatorTracker (elevator-proc) -> FLOOR
//   KEYFRAME, NODE_ADDED, REGISTER_REQUEST -> loopclose::LoopCloser (loopclose-proc)
//   STEREO_CALIB, VO_DELTA, WHEEL_ODOM, ATTITUDE, FLOOR, REGISTER_RESULT -> mapper::Mapper
//
// What differs from the live pipeline, on purpose: nothing is dropped (no queues), and each
// registration request is answered as soon as it is made (live: at most 2 Hz, a little later);
// a keyframe reaches loopclose before its VO_DELTA reaches the mapper. At each new session the
// map store is saved and a new Mapper restores it (mapper-proc restarted on a stored map: lost
// until a global registration places it), VO, attitude and elevator state start anew, and the
// loop closer keeps its places (loopclose-proc reloads them from its store).
//
// GROUND_TRUTH, where a log has it, is only used for the evaluation.

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/bow/vocabulary.h"
#include "core/common/expected.h"
#include "core/common/progress.h"
#include "core/geometry/se3.h"
#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_stream.h"
#include "loopclose-proc/core_registration.h"
#include "loopclose-proc/loop_closer.h"
#include "mapper-proc/calibration_latch.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tools/pipeline-eval/map_evaluation.h"
#include "tools/slam-run/frame_dropper.h"
#include "tools/sim/image_sim_options.h"
#include "tools/sim/registration_oracle.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::slam_run {

namespace detail {
class EventStream;
struct ReadEvent;
}  // namespace detail

inline loopclose::LoopCloserOptions withoutKeyframeRecovery() {
  loopclose::LoopCloserOptions o;
  o.recovery.max_attempts = 0;
  return o;
}

struct SlamRunOptions {
  vo::PipelineOptions vo;
  imu::AttitudeFilterOptions attitude;
  double attitude_rate_hz = 50.0;  // imu-proc's publish_rate_hz
  elevator::ElevatorTrackerOptions elevator;
  // In one process no keyframe is lost and nobody answers KEYFRAME_REQUEST: a node never
  // waits for a keyframe asked again.
  loopclose::LoopCloserOptions loopclose = withoutKeyframeRecovery();
  core::RegistrationOptions registration;  // loopclose-proc's frame registration
  mapper::MapperOptions mapper;
  std::filesystem::path store;  // the map store; required (sessions restore from it)
  // The loop closer's place store (loopclose-proc --store): node keyframes and places are
  // persisted there as loopclose-proc does; empty: kept in memory only.
  std::filesystem::path places;
  // An accepted loop closure is false when it is this far from the truth.
  double false_closure_m = 0.5;
  double false_closure_deg = 5.0;
  // > 0: stop a session after this many seconds of its data.
  double max_session_s = 0.0;
  // Localizing (LocalizeRunner): begin this far into the session, as a robot switched on there
  // (wherever the session has taken it: another floor, mid-corridor); calibration before it
  // is kept. max_session_s then counts from here.
  double start_session_s = 0.0;
  // A progress line on stderr at most this often, seconds of wall time (0: none).
  double progress_period_s = kProgressPeriodS;
  // Frames dropped before VO, as vo-proc drops them under load (none by default).
  FrameDropOptions drop;

  Status validate() const;
};

// Wall time per component, seconds (measurement only).
struct ComponentTimes {
  double decode_s = 0.0;     // reading and decoding the log (LCM, images), on the reader thread
  double wait_s = 0.0;       // the pipeline waiting for the reader
  double vo_s = 0.0;         // rectification, features, odometry, keyframe descriptors
  double imu_s = 0.0;        // attitude filter and elevator tracker
  double loopclose_s = 0.0;  // keyframe cache, places, appearance search, registration
  double mapper_s = 0.0;     // tracking, steps, solver, store
};

struct SessionSummary {
  std::string log;
  int session = 0;
  double duration_s = 0.0;  // data time
  int64_t stereo_frames = 0;
  int64_t vo_ok = 0;
  int64_t keyframes = 0;
  int64_t nodes_added = 0;
  int64_t floor_events = 0;
  // Data time from the session's first frame to its first accepted global registration that
  // tied it to the map (relocalisation); -1: never, or the first session.
  double relocalised_after_s = -1.0;
  int64_t nodes_in_mapped_area = 0;  // new nodes within 1 m / π/8 of an earlier session's node
  // The map store after the session: file bytes (with its WAL) and rows.
  int64_t store_bytes = 0;
  int64_t store_edge_rows = 0;
  // VO's self-calibration decisions ("frame N: disparity offset ..."), one per line.
  std::vector<std::string> self_calibration;
};

// One hour of run time (sessions end to end): growth and per-frame cost (DESIGN.md section 9).
struct HourFigures {
  int hour = 0;
  int64_t nodes_at_end = 0;
  int64_t frames = 0;
  double mapper_p99_ms = 0.0;     // per stereo frame: tracking, steps, solver, store
  double loopclose_p99_ms = 0.0;  // per stereo frame: keyframe, appearance query, registration
};

struct SlamRunSummary {
  std::vector<SessionSummary> sessions;
  std::vector<HourFigures> hours;
  mapper::MapperStats mapper;
  loopclose::LoopCloserStats loopclose;
  vo::PipelineStats vo;
  mapper::TrackerCounts tracker;  // of every session's mapper, summed
  int64_t nodes = 0;
  int64_t edges = 0;  // node pairs with a factor
  int64_t floors = 0;
  int64_t loop_proposals = 0;     // registration requests that were answered (node + global)
  int64_t verified = 0;           // answers that registered (geometric check passed)
  int64_t accepted_closures = 0;  // accepted constraints between existing nodes
  int64_t rejected = 0;           // gate or consistency rejections
  int64_t false_closures = -1;    // accepted closures off the truth; -1: no truth
  int64_t closures_with_truth = 0;
  std::optional<mapper::MapEvaluation> evaluation;  // with ground truth
  ComponentTimes times;
  double data_s = 0.0;  // data time of all sessions
  double wall_s = 0.0;
  int64_t peak_rss_kb = 0;
  std::vector<std::pair<int64_t, core::SE3d>> trajectory;  // live pose after each VO frame
  // Nodes with ground truth (nodes.csv, the Fig. 4 plot).
  struct NodeRow {
    int64_t id = 0;
    int session = 0;
    int floor = 0;        // the map's floor label
    int true_floor = -1;  // the ground truth's floor at the node's keyframe
    int64_t keyframe_utime = 0;
    core::Vec3 truth, estimate;
    double true_yaw_rad = 0.0, yaw_rad = 0.0;    // heading of the body, truth and map
    Eigen::Quaterniond true_rotation, rotation;  // the body's whole orientation, truth and map
  };
  std::vector<NodeRow> node_rows;
  // Node-mode requests with the truth (same floor): distance and view angle between the two
  // keyframes' cameras and whether a true registration came back; the measurement-level
  // oracle's success model fitted to them (docs/mapper.md, "A year", sixth pass).
  std::vector<sim::ReachSample> reach;
  std::optional<sim::ReachFit> reach_fit;
  std::vector<std::string> errors;  // first few input errors (one line each)
  int64_t input_errors = 0;
  int64_t frames_dropped = 0;  // by SlamRunOptions::drop, never seen by VO
  // Of SlamRunOptions::drop.utimes (when given): how many met a frame, of how many.
  int64_t frames_named_dropped = 0;
  int64_t frames_named = 0;

  std::string text() const;
};

class SlamRunner {
 public:
  static Expected<std::unique_ptr<SlamRunner>> create(const bow::Vocabulary& vocabulary,
                                                      const SlamRunOptions& options);
  ~SlamRunner();

  // Maps one log as the next session. Errors: the log cannot be read, the store fails.
  Status runSession(const std::filesystem::path& log);
  // Renders one session of the image-level simulator (options.render.session) and maps it as
  // the next session, frame by frame as it is rendered (no log on disk: runs of hours).
  Status renderSession(const sim::ImageSimOptions& options);
  // Saves the store, evaluates against the ground truth seen in the logs (if any).
  Expected<SlamRunSummary> finish();

  // Per-frame rows (utime, session, component ms, VO status, nodes), for the CSV.
  struct FrameRow {
    int64_t utime = 0;
    int session = 0;
    double run_s = 0.0;  // data time since the run's first session started (sessions end to end)
    int vo_status = 0;
    int inliers = 0;
    double vo_ms = 0.0;
    double loopclose_ms = 0.0;
    double mapper_ms = 0.0;
    int64_t nodes = 0;
  };
  const std::vector<FrameRow>& frames() const { return frames_; }

  // Every registration answer (the paper's Fig. 5 material): mode, score, inliers, and, with
  // ground truth, how far the measured body motion is from the true one.
  struct RegistrationRow {
    int64_t query_utime = 0;
    int64_t node = -1;
    int64_t node_keyframe_utime = 0;
    int64_t requested_node = -1;  // the node a MODE_NODE request named, answered or not
    int64_t requested_keyframe_utime = 0;
    int mode = 0;
    int status = 0;
    int inliers = 0;
    double score = 0.0;
    core::SE3d b_T_q;  // body frames
    core::Mat6 b_T_q_covariance = core::Mat6::Zero();
    double error_m = -1.0, error_deg = -1.0;  // -1: no truth
    // The registration's normalised error against the truth, e' Σ⁻¹ e (6 dof: 6 on average
    // when its covariance is right); -1: no truth.
    double nees = -1.0;
    // The tracked Δ (active node to keyframe) the mapper tested it against, and its error and
    // normalised error against the truth (the active node's keyframe to the query's).
    int64_t active = -1;
    int64_t active_keyframe_utime = 0;
    core::UncertainPose active_T_q;
    double delta_error_m = -1.0, delta_error_deg = -1.0, delta_nees = -1.0;
    // What the mapper did with it: closure, relocalised, recovered, active (fused with or
    // replacing Δ, or kept Δ), gate (refused by the map gate), inconsistent, floor (another
    // floor's node), none (not registered, or a candidate waiting for a second one).
    std::string outcome;
  };
  const std::vector<RegistrationRow>& registrations() const { return registrations_; }

 private:
  SlamRunner(const bow::Vocabulary& vocabulary, const SlamRunOptions& options);
  struct Session;
  // How much a session holds, as far as known before it is read: its events (a log; -1: not
  // known) and its data time (rendered; 0: not known).
  struct SessionSize {
    int64_t events = -1;
    double data_s = 0.0;
  };
  Status startMapper(int session);
  Status mapSession(detail::EventStream& events, const std::string& name, const SessionSize& size);
  // One event of the session into the processes; component times of loopclose and the mapper
  // are added to the two counts (vo and imu to summary_.times).
  void handleEvent(Session& ss, const detail::ReadEvent& e, double* loopclose_s, double* mapper_s);
  void onFrame(Session& ss, const detail::ReadEvent& e, double* loopclose_s, double* mapper_s);
  // One output VO released (vo_s: the time of the input that released it, on its last output).
  void onOutput(Session& ss, const vo::PipelineOutput& out, double vo_s, double* loopclose_s,
                double* mapper_s);
  void afterFrame(Session& ss, const vo::PipelineOutput& out, double vo_s, double loopclose_s,
                  double mapper_s);
  void onImu(Session& ss, const void* data, int64_t size, double* mapper_s);
  // The session's totals into the run's, and the map store saved.
  Status endSession(Session& ss);
  Progress progressOf(const Session& ss, const SessionSize& size) const;
  // The run's figures against the ground truth of its logs.
  Status evaluate(const mapper::RunTruth& truth);
  // Hands the mapper's requests to the loop closer and its answers back, and new nodes to it,
  // until neither side has anything more.
  void exchange(double* loopclose_s, double* mapper_s);
  void inputError(const std::string& what);

  const bow::Vocabulary& vocabulary_;
  SlamRunOptions options_;
  std::unique_ptr<loopclose::CoreRegistration> registration_;
  std::unique_ptr<loopclose::LoopCloser> loop_closer_;
  std::optional<mapper::MapStore> store_;
  std::unique_ptr<mapper::Mapper> mapper_;
  mapper::CalibrationLatch calibration_;
  int sessions_ = 0;
  int64_t session_start_utime_ = -1;
  SlamRunSummary summary_;
  mapper::MapperStats mapper_before_;    // of earlier sessions' mappers, summed by finish()
  std::map<int64_t, core::SE3d> truth_;  // GROUND_TRUTH, world_T_body by utime
  std::map<int64_t, std::pair<int, int>> truth_floor_;  // utime -> (floor, session)
  std::vector<FrameRow> frames_;
  std::vector<RegistrationRow> registrations_;
  FrameDropper dropper_;
  int64_t requests_answered_ = 0;
  int64_t answers_ok_ = 0;
  bool relocalised_ = false;
};

}  // namespace evermap::slam_run
