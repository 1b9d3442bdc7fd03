#include "tools/slam-run/slam_runner.h"

#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <set>
#include <sstream>
#include <utility>
#include <thread>

#include <evermap/imu_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/clocks.h"
#include "core/common/percentile.h"
#include "core/geometry/se2.h"
#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/pose_fields.h"
#include "elevator-proc/lcm_convert.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/lcm_node.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/mapper-run/run_metrics.h"
#include "tools/mapper-run/store_bytes.h"
#include "tools/sim/image_session.h"
#include "tools/slam-run/event_stream.h"
#include "tools/slam-run/session_processes.h"
#include "tools/slam-run/truth_evaluation.h"

namespace evermap::slam_run {
namespace {

int64_t peakRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

}  // namespace

Status SlamRunOptions::validate() const {
  if (Status s = vo.validate(); !s) return s;
  if (Status s = attitude.validate(); !s) return s;
  if (!(attitude_rate_hz > 0.0)) return Error("attitude_rate_hz: must be > 0");
  if (Status s = loopclose.validate(); !s) return s;
  if (Status s = registration.validate(); !s) return s;
  if (Status s = mapper.validate(); !s) return s;
  if (store.empty()) return Error("a map store is needed (sessions restore the map from it)");
  if (!(false_closure_m > 0.0) || !(false_closure_deg > 0.0))
    return Error("false closure thresholds must be > 0");
  if (!(max_session_s >= 0.0)) return Error("max_session_s: must be >= 0");
  if (!(start_session_s >= 0.0)) return Error("start_session_s: must be >= 0");
  if (!(progress_period_s >= 0.0)) return Error("progress_period_s: must be >= 0");
  return drop.validate();
}

SlamRunner::SlamRunner(const bow::Vocabulary& vocabulary, const SlamRunOptions& options)
    : vocabulary_(vocabulary), options_(options), dropper_(options.drop) {}
SlamRunner::~SlamRunner() = default;

Expected<std::unique_ptr<SlamRunner>> SlamRunner::create(const bow::Vocabulary& vocabulary,
                                                         const SlamRunOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  std::unique_ptr<SlamRunner> r(new SlamRunner(vocabulary, options));
  auto registration = loopclose::CoreRegistration::create(options.registration);
  if (!registration) return registration.error();
  r->registration_ = std::make_unique<loopclose::CoreRegistration>(std::move(*registration));
  auto store = mapper::MapStore::open(options.store);
  if (!store) return store.error();
  r->store_ = std::move(*store);
  // The loop closer's places live in memory for the whole run (loopclose-proc would reload
  // the same from its place store after a restart); with options.places they are also
  // persisted there, as loopclose-proc does (evermap-map-export reads the node keyframes).
  std::optional<bow::PlaceStore> places;
  if (!options.places.empty()) {
    auto opened =
        bow::PlaceStore::open(options.places, vocabulary.fingerprint(), vocabulary.numWords());
    if (!opened) return opened.error();
    places = std::move(*opened);
  }
  auto closer = loopclose::LoopCloser::create(vocabulary, *r->registration_, options.loopclose,
                                              std::move(places));
  if (!closer) return closer.error();
  r->loop_closer_ = std::move(*closer);
  return r;
}

void SlamRunner::inputError(const std::string& what) {
  ++summary_.input_errors;
  if (summary_.errors.size() < 20) summary_.errors.push_back(what);
}

Status SlamRunner::startMapper(int session) {
  if (mapper_) {
    if (Status s = store_->save(*mapper_, mapper_->session(), session_start_utime_); !s) return s;
  }
  auto held = store_->load();
  if (!held) return held.error();
  auto m = std::make_unique<mapper::Mapper>(options_.mapper, session);
  if (!held->nodes.empty()) {
    if (Status s = m->restore(*held); !s)
      return makeError(options_.store.string(), ": ", s.error().message);
  }
  if (mapper_) {  // the run's totals
    mapper_before_.addCounters(mapper_->stats());
    summary_.tracker.add(mapper_->tracker().counts());
  }
  mapper_ = std::move(m);
  calibration_ = mapper::CalibrationLatch{};
  return Ok{};
}

namespace {

// The mapper's counters that say what it did with a registration answer, in the order they
// are told apart (counters only: MapperStats also holds the growing per-step timings).
using OutcomeCounters = std::array<int64_t, 7>;
OutcomeCounters outcomeCounters(const mapper::MapperStats& s) {
  return {s.loop_closures,     s.relocalizations,
          s.gate_recoveries,   s.delta_fused + s.delta_replaced + s.delta_kept,
          s.rejected_map_gate, s.rejected_inconsistent,
          s.rejected_floor};
}
const char* outcomeOf(const OutcomeCounters& before, const OutcomeCounters& after) {
  static constexpr const char* kNames[] = {"closure", "relocalised",  "recovered", "active",
                                           "gate",    "inconsistent", "floor"};
  for (size_t i = 0; i < before.size(); ++i)
    if (after[i] > before[i]) return kNames[i];
  return "none";
}

}  // namespace

void SlamRunner::exchange(double* loopclose_s, double* mapper_s) {
  // A node id the mapper has made, and its keyframe's time.
  auto isNode = [&](int64_t id) {
    return id >= 0 && id < static_cast<int64_t>(mapper_->nodes().size());
  };
  auto keyframeOf = [&](int64_t id) {
    return mapper_->nodes()[static_cast<size_t>(id)].keyframe_utime;
  };
  while (true) {
    // Errors of nodes that waited for their keyframe come out of addKeyframe, addNode and
    // answer (the clock moving on): drained at every pass, the last (empty) one included.
    for (const std::string& why : loop_closer_->takeNodeErrors()) inputError("NODE_ADDED: " + why);
    auto nodes = mapper_->takeNodesAdded();
    auto requests = mapper_->takeRequests();
    if (nodes.empty() && requests.empty()) return;
    for (const node_added_t& n : nodes) {
      const auto t0 = SteadyClock::now();
      if (Status s = loop_closer_->addNode(n); !s) inputError("NODE_ADDED: " + s.error().message);
      *loopclose_s += secondsSince(t0);
    }
    for (const register_request_t& r : requests) {
      auto t0 = SteadyClock::now();
      const register_result_t answer = loop_closer_->answer(r);
      *loopclose_s += secondsSince(t0);
      ++requests_answered_;
      RegistrationRow row;
      row.query_utime = r.keyframe_utime;
      row.mode = r.mode;
      if (r.mode == register_request_t::MODE_NODE && isNode(r.target_node_id)) {
        row.requested_node = r.target_node_id;
        row.requested_keyframe_utime = keyframeOf(r.target_node_id);
      }
      row.status = answer.status;
      row.inliers = answer.num_inliers;
      row.score = answer.score;
      if (answer.status == register_result_t::STATUS_OK) {
        ++answers_ok_;
        row.node = answer.node_id;
        if (isNode(answer.node_id)) row.node_keyframe_utime = keyframeOf(answer.node_id);
        // The loop closer answers OK with a finite unit quaternion (putPose of an SE3d).
        const Eigen::Quaterniond q =
            *messages::quaternionFromMessage(answer.orientation, "REGISTER_RESULT");
        const core::SE3d cam_T(
            q.normalized(),
            core::Vec3(answer.translation[0], answer.translation[1], answer.translation[2]));
        // As the mapper reads it; the mean alone when the covariance is unusable.
        const auto cam_cov = messages::covarianceFromMessage(answer.covariance, "REGISTER_RESULT");
        const core::UncertainPose body =
            mapper_->tracker().registrationToBody(cam_T, cam_cov ? *cam_cov : core::Mat6::Zero());
        row.b_T_q = body.mean;
        if (cam_cov) row.b_T_q_covariance = body.covariance;
      }
      if (const auto pending = mapper_->pendingStep(); pending && isNode(pending->active)) {
        row.active = pending->active;
        row.active_keyframe_utime = keyframeOf(pending->active);
        row.active_T_q = pending->active_T_keyframe;
      }
      registrations_.push_back(row);
      t0 = SteadyClock::now();
      const OutcomeCounters before = outcomeCounters(mapper_->stats());
      if (Status s = mapper_->onRegisterResult(answer); !s)
        inputError("REGISTER_RESULT: " + s.error().message);
      *mapper_s += secondsSince(t0);
      registrations_.back().outcome = outcomeOf(before, outcomeCounters(mapper_->stats()));
    }
  }
}

using detail::EventStream;
using detail::ReadEvent;

// One session's pipeline state: the processes that start anew with each session (vo-proc,
// imu-proc, elevator-proc) and what the session's summary counts.
struct SlamRunner::Session : SessionProcesses {
  Session(vo::VoPipeline vo_pipeline, const SlamRunOptions& options)
      : SessionProcesses(std::move(vo_pipeline), options.attitude, options.attitude_rate_hz,
                         options.elevator) {}

  SessionSummary summary;
  int64_t nodes_before = 0;
  bool starts_lost = false;
  int64_t first_utime = -1, last_utime = -1;
  int64_t events = 0;
  std::optional<ProgressReporter> progress;
};

Status SlamRunner::runSession(const std::filesystem::path& log_file) {
  // The log's event count, for the progress lines (the reader reports damage itself), before
  // the reader thread starts.
  const auto count = messages::LogReader::check(log_file);
  auto opened = messages::LogReader::open(log_file);
  if (!opened) return opened.error();
  auto log = std::make_shared<messages::LogReader>(std::move(*opened));
  EventStream events(detail::logProducer(log));
  return mapSession(events, log_file.string(), SessionSize{count ? *count : -1, 0.0});
}

Status SlamRunner::renderSession(const sim::ImageSimOptions& options) {
  sim::ImageSimOptions o = options;
  o.render.encoding = messages::ImageEncoding::kGray8;  // nothing to compress: no disk
  std::optional<ProgressReporter> setup;
  if (options_.progress_period_s > 0.0)
    setup.emplace("evermap-slam-run, rendered session " + std::to_string(o.render.session),
                  "frames", printToStderr, options_.progress_period_s);
  auto simulator = sim::ImageSimulator::create(o, setup ? &*setup : nullptr);
  if (!simulator) return simulator.error();
  std::shared_ptr<sim::ImageSimulator> sim = std::move(*simulator);
  const double duration_s = 1e-6 * static_cast<double>(sim->endUtime() - sim->startUtime());
  EventStream events(detail::renderProducer(std::move(sim)));
  return mapSession(events, "rendered session " + std::to_string(o.render.session),
                    SessionSize{-1, duration_s});
}

Status SlamRunner::mapSession(detail::EventStream& log, const std::string& name,
                              const SessionSize& size) {
  const int session = sessions_++;
  if (Status s = startMapper(session); !s) return s;
  auto vo = vo::VoPipeline::create(options_.vo);
  if (!vo) return vo.error();
  Session ss(std::move(*vo), options_);
  ss.summary.log = name;
  ss.summary.session = session;
  ss.nodes_before = static_cast<int64_t>(mapper_->nodes().size());
  ss.starts_lost = mapper_->lost() || !mapper_->nodes().empty();
  if (options_.progress_period_s > 0.0)
    ss.progress.emplace("evermap-slam-run session " + std::to_string(session), "frames",
                        printToStderr, options_.progress_period_s);
  session_start_utime_ = -1;
  ComponentTimes& t = summary_.times;
  auto t_read = SteadyClock::now();
  bool cut_short = false;
  while (std::optional<ReadEvent> e = log.next()) {
    if (ss.first_utime < 0) ss.first_utime = e->timestamp;
    ss.last_utime = std::max(ss.last_utime, e->timestamp);
    if (options_.max_session_s > 0.0 &&
        e->timestamp - ss.first_utime > static_cast<int64_t>(options_.max_session_s * 1e6)) {
      cut_short = true;  // damage the reader found further on does not concern this map
      break;
    }
    t.decode_s += e->decode_s;
    t.wait_s += secondsSince(t_read);
    double loopclose_s = 0.0, mapper_s = 0.0;
    handleEvent(ss, *e, &loopclose_s, &mapper_s);
    exchange(&loopclose_s, &mapper_s);
    t.loopclose_s += loopclose_s;
    t.mapper_s += mapper_s;
    ++ss.events;
    if (ss.progress) ss.progress->update(progressOf(ss, size));
    t_read = SteadyClock::now();
  }
  t.wait_s += secondsSince(t_read);
  if (Status s = log.finish(); !s && !cut_short) {
    // The reader's message names the log already.
    if (s.error().message.rfind(name, 0) == 0) return s;
    return makeError(name, ": ", s.error().message);
  }
  if (ss.first_utime < 0) return makeError(name, ": no event");
  // What VO's start-up hold still keeps (a session shorter than the hold).
  double loopclose_s = 0.0, mapper_s = 0.0;
  for (const vo::PipelineOutput& out : ss.vo.flush())
    onOutput(ss, out, 0.0, &loopclose_s, &mapper_s);
  t.loopclose_s += loopclose_s;
  t.mapper_s += mapper_s;
  return endSession(ss);
}

Progress SlamRunner::progressOf(const Session& ss, const SessionSize& size) const {
  Progress p;
  p.data_done_s = 1e-6 * static_cast<double>(ss.last_utime - ss.first_utime);
  p.data_total_s = size.data_s;
  if (options_.max_session_s > 0.0)
    p.data_total_s = p.data_total_s > 0.0 ? std::min(p.data_total_s, options_.max_session_s)
                                          : options_.max_session_s;
  if (size.events > 0) {
    p.fraction = static_cast<double>(ss.events) / static_cast<double>(size.events);
    if (options_.max_session_s > 0.0)
      p.fraction = std::max(p.fraction, p.data_done_s / options_.max_session_s);
  }
  p.steps = ss.summary.stereo_frames;
  p.nodes = static_cast<int64_t>(mapper_->nodes().size());
  return p;
}

void SlamRunner::handleEvent(Session& ss, const ReadEvent& e, double* loopclose_s,
                             double* mapper_s) {
  const std::string& channel = e.channel;
  const void* data = e.data.data();
  const auto size = static_cast<int64_t>(e.data.size());
  if (channel == channels::kStereoCalib) {
    auto t0 = SteadyClock::now();
    if (Status s = ss.vo.handleCalibrationBytes(data, size); !s)
      inputError("vo: " + s.error().message);
    summary_.times.vo_s += secondsSince(t0);
    t0 = SteadyClock::now();
    if (Status s = calibration_.handle(data, size, *mapper_); !s)
      inputError("mapper: " + s.error().message);
    *mapper_s += secondsSince(t0);
  } else if (channel == channels::kRgbdCalib) {
    // An RGB-D camera: vo-proc takes the calibration from the frames, the mapper from here.
    auto t0 = SteadyClock::now();
    if (Status s = calibration_.handleRgbd(data, size, *mapper_); !s)
      inputError("mapper: " + s.error().message);
    *mapper_s += secondsSince(t0);
  } else if (channel == channels::kStereo || channel == channels::kRgbd) {
    if (dropper_.drop(e.stereo_utime)) return;
    onFrame(ss, e, loopclose_s, mapper_s);
  } else if (channel == channels::kImu) {
    onImu(ss, data, size, mapper_s);
  } else if (channel == channels::kWheelOdom) {
    auto msg = messages::decodeLcm<wheel_odom_t>(data, size, channel);
    const auto t0 = SteadyClock::now();
    if (!msg) {
      inputError(msg.error().message);
    } else if (Status s = mapper_->onWheel(*msg); !s) {
      inputError("WHEEL_ODOM: " + s.error().message);
    }
    *mapper_s += secondsSince(t0);
  } else if (channel == channels::kGroundTruth) {
    auto msg = messages::decodeLcm<pose_t>(data, size, channel);
    auto pose = msg ? messages::fromMsg(*msg) : Expected<core::UncertainPose>(msg.error());
    if (!pose) {
      inputError("GROUND_TRUTH: " + pose.error().message);
    } else {
      truth_[msg->utime] = pose->mean;
      truth_floor_[msg->utime] = {msg->floor, msg->session};
    }
  }
}

void SlamRunner::onFrame(Session& ss, const ReadEvent& e, double* loopclose_s, double* mapper_s) {
  const auto t0 = SteadyClock::now();
  Expected<vo::PipelineOutputs> outs = ss.runVo(e);
  const double vo_s = secondsSince(t0);
  summary_.times.vo_s += vo_s;
  if (!outs) {
    inputError(e.channel + ": " + outs.error().message);
    return;
  }
  for (size_t i = 0; i < outs->size(); ++i)
    onOutput(ss, (*outs)[i], i + 1 == outs->size() ? vo_s : 0.0, loopclose_s, mapper_s);
}

void SlamRunner::onOutput(Session& ss, const vo::PipelineOutput& out, double vo_s,
                          double* loopclose_s, double* mapper_s) {
  ++ss.summary.stereo_frames;
  if (session_start_utime_ < 0) session_start_utime_ = out.delta.utime;
  if (out.result.ok()) ++ss.summary.vo_ok;
  if (out.keyframe) ++ss.summary.keyframes;
  if (!out.result.calibration_message.empty()) {
    ss.summary.self_calibration.push_back("frame " + std::to_string(ss.summary.stereo_frames - 1) +
                                          ": " + out.result.calibration_message);
  }
  deliverFrame(
      out, calibration_.haveCamera(), *loop_closer_, *mapper_,
      [this](const std::string& what) { inputError(what); }, loopclose_s, mapper_s);
  exchange(loopclose_s, mapper_s);
  afterFrame(ss, out, vo_s, *loopclose_s, *mapper_s);
}

void SlamRunner::afterFrame(Session& ss, const vo::PipelineOutput& out, double vo_s,
                            double loopclose_s, double mapper_s) {
  const int64_t utime = out.delta.utime;
  if (mapper_->activeNode() >= 0 && !mapper_->lost())
    summary_.trajectory.emplace_back(utime, mapper_->pose().mean);
  if (ss.starts_lost && ss.summary.relocalised_after_s < 0 && !mapper_->lost() &&
      mapper_->activeNode() >= 0)
    ss.summary.relocalised_after_s = 1e-6 * static_cast<double>(utime - session_start_utime_);
  const double run_s = summary_.data_s + 1e-6 * static_cast<double>(utime - session_start_utime_);
  frames_.push_back(FrameRow{utime, ss.summary.session, run_s, out.delta.status,
                             out.delta.num_inliers, 1e3 * vo_s, 1e3 * loopclose_s, 1e3 * mapper_s,
                             static_cast<int64_t>(mapper_->nodes().size())});
}

void SlamRunner::onImu(Session& ss, const void* data, int64_t size, double* mapper_s) {
  auto msg = messages::decodeLcm<imu_t>(data, size, channels::kImu);
  if (!msg) {
    inputError(msg.error().message);
    return;
  }
  auto t0 = SteadyClock::now();
  const SessionProcesses::ImuOutputs out = ss.onImu(*msg);
  summary_.times.imu_s += secondsSince(t0);
  t0 = SteadyClock::now();
  if (out.attitude) {
    if (Status s = mapper_->onAttitude(*out.attitude); !s) {
      inputError("ATTITUDE: " + s.error().message);
    }
  }
  for (const auto& ev : out.floor_events) {
    ++ss.summary.floor_events;
    if (Status s = mapper_->onFloor(elevator::toLcm(ev)); !s)
      inputError("FLOOR: " + s.error().message);
  }
  *mapper_s += secondsSince(t0);
}

Status SlamRunner::endSession(Session& ss) {
  SessionSummary& out = ss.summary;
  out.duration_s = 1e-6 * static_cast<double>(ss.last_utime - ss.first_utime);
  out.nodes_added = static_cast<int64_t>(mapper_->nodes().size()) - ss.nodes_before;
  summary_.data_s += out.duration_s;
  summary_.frames_dropped = dropper_.dropped();
  summary_.frames_named_dropped = dropper_.namedDropped();
  summary_.frames_named = static_cast<int64_t>(options_.drop.utimes.size());
  const vo::PipelineStats& vs = ss.vo.stats();
  summary_.vo.frames += vs.frames;
  for (size_t i = 0; i < vs.by_status.size(); ++i) summary_.vo.by_status[i] += vs.by_status[i];
  summary_.vo.keyframes += vs.keyframes;
  summary_.vo.calibrations += vs.calibrations;
  summary_.vo.calibrations_refused += vs.calibrations_refused;
  summary_.vo.undecodable += vs.undecodable;
  if (Status s = store_->save(*mapper_, mapper_->session(),
                              session_start_utime_ >= 0 ? session_start_utime_ : ss.first_utime);
      !s)
    return s;
  out.store_bytes = mapper::storeFileBytes(options_.store);
  if (auto rows = store_->edgeRows()) out.store_edge_rows = *rows;
  summary_.sessions.push_back(out);
  return Ok{};
}

Expected<SlamRunSummary> SlamRunner::finish() {
  if (!mapper_) return Error("no session was run");
  if (Status s = store_->save(*mapper_, mapper_->session(), session_start_utime_); !s)
    return s.error();
  SlamRunSummary& out = summary_;
  const mapper::Mapper& m = *mapper_;
  out.mapper = m.stats();
  out.mapper.addCounters(mapper_before_);
  out.tracker.add(m.tracker().counts());
  out.loopclose = loop_closer_->stats();
  out.nodes = static_cast<int64_t>(m.nodes().size());
  out.edges = static_cast<int64_t>(m.constraints().pairs().size());
  out.floors = static_cast<int64_t>(m.floors().size());
  out.loop_proposals = requests_answered_;
  out.verified = answers_ok_;
  out.rejected = out.mapper.rejected_map_gate + out.mapper.rejected_inconsistent;
  out.accepted_closures = 0;
  for (const auto& c : m.constraints().all())
    if (c.accepted && c.kind == mapper::ConstraintKind::kLoop) ++out.accepted_closures;
  out.peak_rss_kb = peakRssKb();
  out.hours = hourFigures(frames_);
  if (auto truth = mapper::truthFromSamples(truth_, truth_floor_)) {
    if (Status s = evaluate(*truth); !s) return s.error();
  }
  return out;
}

Status SlamRunner::evaluate(const mapper::RunTruth& truth) {
  SlamRunSummary& out = summary_;
  const mapper::Mapper& m = *mapper_;
  const std::map<int64_t, core::SE3d> node_truth = nodeTruth(m, truth);
  out.node_rows = nodeRows(m, node_truth, truth_floor_);
  out.false_closures = falseClosures(m, node_truth, options_.false_closure_m,
                                     options_.false_closure_deg, &out.closures_with_truth);
  for (RegistrationRow& row : registrations_) scoreRegistration(truth, &row);
  out.reach = registrationReach(registrations_, truth, m.tracker().bodyTCamera(),
                                options_.false_closure_m, options_.false_closure_deg);
  if (!out.reach.empty()) out.reach_fit = sim::fitReach(out.reach, sim::OracleOptions{});
  countNodesInMappedArea(m, node_truth, &out.sessions);
  auto map = mapper::mapFromGraph(mapper::graphMessage(m, 0));
  if (!map) return map.error();
  auto e = mapper::evaluateMap(*map, truth, out.trajectory);
  if (e)
    out.evaluation = *e;
  else
    out.errors.push_back("evaluation: " + e.error().message);
  return Ok{};
}

}  // namespace evermap::slam_run
