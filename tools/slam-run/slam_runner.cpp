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
#include <evermap/rgbd_image_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/clocks.h"
#include "core/common/percentile.h"
#include "core/geometry/se2.h"
#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/pose_fields.h"
#include "core/messages/rgbd_convert.h"
#include "elevator-proc/lcm_convert.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/lcm_node.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/mapper-run/run_metrics.h"
#include "tools/sim/image_session.h"
#include "tools/sim/message_sink.h"
#include "vo-proc/frame_queue.h"

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
  return Ok{};
}

SlamRunner::SlamRunner(const bow::Vocabulary& vocabulary, const SlamRunOptions& options)
    : vocabulary_(vocabulary), options_(options) {}
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
  // the same from its place store after a restart).
  auto closer =
      loopclose::LoopCloser::create(vocabulary, *r->registration_, options.loopclose, std::nullopt);
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

// e' Σ⁻¹ e of an estimate's error err = truth⁻¹ · estimate, as the mapper's gates compute it
// (ConstraintSet::mahalanobis2 against the exact truth); -1 without a covariance.
double normalisedError(const core::SE3d& err, const core::Mat6& covariance) {
  if (!covariance.allFinite() || covariance.isZero()) return -1.0;
  const double d2 = mapper::ConstraintSet::mahalanobis2(core::UncertainPose{}, {err, covariance});
  return std::isfinite(d2) ? d2 : -1.0;
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

namespace detail {

// One event, read from a log or rendered (and for STEREO, decoded: LCM and PNG) by the
// producer thread ahead of the pipeline, which then spends its time on the algorithms.
struct ReadEvent {
  std::string channel;
  int64_t timestamp = 0;
  std::vector<uint8_t> data;
  // STEREO that decoded as LCM: its images, decoded, and its utime.
  std::optional<Expected<messages::StereoFrame>> frame;
  // RGBD that decoded as LCM: its images, decoded (utime in stereo_utime).
  std::optional<Expected<messages::RgbdFrame>> rgbd_frame;
  int64_t stereo_utime = 0;
  double decode_s = 0.0;
};

ReadEvent makeEvent(const std::string& channel, int64_t timestamp, const uint8_t* p, size_t size) {
  const auto t0 = SteadyClock::now();
  ReadEvent r;
  r.channel = channel;
  r.timestamp = timestamp;
  r.data.assign(p, p + size);
  if (r.channel == channels::kStereo) {
    auto msg = messages::decodeLcm<stereo_image_t>(p, static_cast<int64_t>(size), r.channel);
    if (msg) {
      r.frame = messages::fromMsg(*msg);
      r.stereo_utime = msg->utime;
      r.data.clear();  // the decoded images are what is used
    }
  } else if (r.channel == channels::kRgbd) {
    auto msg = messages::decodeLcm<rgbd_image_t>(p, static_cast<int64_t>(size), r.channel);
    if (msg) {
      r.rgbd_frame = messages::fromMsg(*msg);
      r.stereo_utime = msg->utime;
      r.data.clear();
    }
  }
  r.decode_s = secondsSince(t0);
  return r;
}

// A session's events, produced on their own thread at most `ahead` events in front of the
// consumer (512: about 25 frames of a 20 Hz stereo session with 200 Hz IMU, ~30 MB of decoded
// images). The producer is an LCM log or the image-level simulator rendering on the fly.
class EventStream {
 public:
  using Producer = std::function<Status(EventStream&)>;
  explicit EventStream(Producer produce, size_t ahead = 512)
      : queue_(ahead, vo::BoundedQueue<ReadEvent>::Full::kWait) {
    thread_ = std::thread([this, produce = std::move(produce)] {
      status_ = produce(*this);
      queue_.close();
    });
  }
  ~EventStream() {
    queue_.close();
    if (thread_.joinable()) thread_.join();
  }
  // False once the consumer has stopped (the producer should stop too).
  bool push(ReadEvent e) { return queue_.push(std::move(e)); }
  std::optional<ReadEvent> next() { return queue_.pop(); }
  // The producer's outcome, once next() has returned nullopt.
  Status finish() {
    queue_.close();
    if (thread_.joinable()) thread_.join();
    return status_;
  }

 private:
  vo::BoundedQueue<ReadEvent> queue_;
  Status status_ = Ok{};
  std::thread thread_;
};

}  // namespace detail

using detail::EventStream;
using detail::makeEvent;
using detail::ReadEvent;

namespace {

// Rendered messages into the stream.
class StreamSink final : public sim::MessageSink {
 public:
  explicit StreamSink(EventStream& stream) : stream_(stream) {}
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    if (!stream_.push(makeEvent(channel, utime, data.data(), data.size()))) stopped_ = true;
  }
  bool stopped() const { return stopped_; }

 private:
  EventStream& stream_;
  bool stopped_ = false;
};

}  // namespace

Status SlamRunner::runSession(const std::filesystem::path& log_file) {
  auto opened = messages::LogReader::open(log_file);
  if (!opened) return opened.error();
  auto log = std::make_shared<messages::LogReader>(std::move(*opened));
  EventStream events([log](EventStream& out) -> Status {
    while (const messages::LogReader::Event* e = log->next()) {
      if (!out.push(makeEvent(e->channel, e->timestamp, e->data, static_cast<size_t>(e->datalen))))
        return Ok{};  // the consumer stopped (--max-session-s): what follows is not used
    }
    return log->status();  // a log cut mid-event or damaged: the map would be of part of it
  });
  return mapSession(events, log_file.string());
}

Status SlamRunner::renderSession(const sim::ImageSimOptions& options) {
  sim::ImageSimOptions o = options;
  o.render.encoding = messages::ImageEncoding::kGray8;  // nothing to compress: no disk
  auto simulator = sim::ImageSimulator::create(o);
  if (!simulator) return simulator.error();
  std::shared_ptr<sim::ImageSimulator> sim = std::move(*simulator);
  EventStream events([sim](EventStream& out) -> Status {
    StreamSink sink(out);
    auto summary = sim->run(sink, [&sink](double) { return !sink.stopped(); });
    if (!summary) return summary.error();
    return Ok{};
  });
  return mapSession(events, "rendered session " + std::to_string(o.render.session));
}

Status SlamRunner::mapSession(detail::EventStream& log, const std::string& name) {
  const int session = sessions_++;
  if (Status s = startMapper(session); !s) return s;
  auto vo = vo::VoPipeline::create(options_.vo);
  if (!vo) return vo.error();
  imu::AttitudeStream attitude(options_.attitude, options_.attitude_rate_hz);
  elevator::ElevatorTracker elevator(options_.elevator);
  std::optional<imu::Attitude> latest_attitude;

  SessionSummary ss;
  ss.log = name;
  ss.session = session;
  const int64_t nodes_before = static_cast<int64_t>(mapper_->nodes().size());
  const bool starts_lost = mapper_->lost() || !mapper_->nodes().empty();
  int64_t first_utime = -1, last_utime = -1;
  session_start_utime_ = -1;
  ComponentTimes& t = summary_.times;
  auto t_read = SteadyClock::now();
  bool cut_short = false;
  while (std::optional<ReadEvent> e = log.next()) {
    const std::string& channel = e->channel;
    const void* data = e->data.data();
    const auto size = static_cast<int64_t>(e->data.size());
    if (first_utime < 0) first_utime = e->timestamp;
    last_utime = std::max(last_utime, e->timestamp);
    if (options_.max_session_s > 0.0 &&
        e->timestamp - first_utime > static_cast<int64_t>(options_.max_session_s * 1e6)) {
      cut_short = true;  // damage the reader found further on does not concern this map
      break;
    }
    t.decode_s += e->decode_s;
    t.wait_s += secondsSince(t_read);
    double loopclose_s = 0.0, mapper_s = 0.0;
    if (channel == channels::kStereoCalib) {
      auto t0 = SteadyClock::now();
      if (Status s = vo->handleCalibrationBytes(data, size); !s)
        inputError("vo: " + s.error().message);
      t.vo_s += secondsSince(t0);
      t0 = SteadyClock::now();
      if (Status s = calibration_.handle(data, size, *mapper_); !s)
        inputError("mapper: " + s.error().message);
      mapper_s += secondsSince(t0);
    } else if (channel == channels::kRgbdCalib) {
      // An RGB-D camera: vo-proc takes the calibration from the frames, the mapper from here.
      auto t0 = SteadyClock::now();
      if (Status s = calibration_.handleRgbd(data, size, *mapper_); !s)
        inputError("mapper: " + s.error().message);
      mapper_s += secondsSince(t0);
    } else if (channel == channels::kStereo || channel == channels::kRgbd) {
      auto t0 = SteadyClock::now();
      // Decoded ahead by the reader; what did not decode as LCM fails here as in vo-proc.
      const bool rgbd = channel == channels::kRgbd;
      Expected<vo::PipelineOutput> out =
          rgbd       ? (e->rgbd_frame ? Expected<vo::PipelineOutput>(
                                      vo->handleRgbdFrame(e->stereo_utime, *e->rgbd_frame))
                                      : vo->handleRgbdBytes(data, size))
          : e->frame ? Expected<vo::PipelineOutput>(vo->handleFrame(e->stereo_utime, *e->frame))
                     : vo->handleStereoBytes(data, size);
      const double vo_s = secondsSince(t0);
      t.vo_s += vo_s;
      if (!out) {
        inputError(std::string(channel) + ": " + out.error().message);
      } else {
        ++ss.stereo_frames;
        if (session_start_utime_ < 0) session_start_utime_ = out->delta.utime;
        if (out->result.ok()) ++ss.vo_ok;
        if (out->keyframe) {
          ++ss.keyframes;
          t0 = SteadyClock::now();
          if (Status s = loop_closer_->addKeyframe(*out->keyframe); !s)
            inputError("KEYFRAME: " + s.error().message);
          loopclose_s += secondsSince(t0);
        }
        t0 = SteadyClock::now();
        if (!calibration_.haveCamera()) {
          inputError("VO_DELTA before STEREO_CALIB or RGBD_CALIB");
        } else if (Status s = mapper_->onVo(out->delta); !s) {
          inputError("VO_DELTA: " + s.error().message);
        }
        mapper_s += secondsSince(t0);
        exchange(&loopclose_s, &mapper_s);
        if (mapper_->activeNode() >= 0 && !mapper_->lost())
          summary_.trajectory.emplace_back(out->delta.utime, mapper_->pose().mean);
        if (starts_lost && ss.relocalised_after_s < 0 && !mapper_->lost() &&
            mapper_->activeNode() >= 0)
          ss.relocalised_after_s =
              1e-6 * static_cast<double>(out->delta.utime - session_start_utime_);
        const double run_s =
            summary_.data_s + 1e-6 * static_cast<double>(out->delta.utime - session_start_utime_);
        frames_.push_back(FrameRow{out->delta.utime, session, run_s, out->delta.status,
                                   out->delta.num_inliers, 1e3 * vo_s, 1e3 * loopclose_s,
                                   1e3 * mapper_s, mapper_->graphNodes()});
      }
    } else if (channel == channels::kImu) {
      auto msg = messages::decodeLcm<imu_t>(data, size, channel);
      if (!msg) {
        inputError(msg.error().message);
      } else {
        auto t0 = SteadyClock::now();
        std::optional<attitude_t> att = attitude.add(*msg);
        if (att) latest_attitude = imu::fromLcm(*att);
        const auto events =
            elevator.add(imu::fromLcm(*msg), latest_attitude ? &*latest_attitude : nullptr);
        t.imu_s += secondsSince(t0);
        t0 = SteadyClock::now();
        if (att) {
          if (Status s = mapper_->onAttitude(*att); !s)
            inputError("ATTITUDE: " + s.error().message);
        }
        for (const auto& ev : events) {
          ++ss.floor_events;
          if (Status s = mapper_->onFloor(elevator::toLcm(ev)); !s)
            inputError("FLOOR: " + s.error().message);
        }
        mapper_s += secondsSince(t0);
      }
    } else if (channel == channels::kWheelOdom) {
      auto msg = messages::decodeLcm<wheel_odom_t>(data, size, channel);
      const auto t0 = SteadyClock::now();
      if (!msg) {
        inputError(msg.error().message);
      } else if (Status s = mapper_->onWheel(*msg); !s) {
        inputError("WHEEL_ODOM: " + s.error().message);
      }
      mapper_s += secondsSince(t0);
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
    exchange(&loopclose_s, &mapper_s);
    t.loopclose_s += loopclose_s;
    t.mapper_s += mapper_s;
    t_read = SteadyClock::now();
  }
  t.wait_s += secondsSince(t_read);
  if (Status s = log.finish(); !s && !cut_short) {
    // The reader's message names the log already.
    if (s.error().message.rfind(name, 0) == 0) return s;
    return makeError(name, ": ", s.error().message);
  }
  if (first_utime < 0) return makeError(name, ": no event");
  ss.duration_s = 1e-6 * static_cast<double>(last_utime - first_utime);
  ss.nodes_added = static_cast<int64_t>(mapper_->nodes().size()) - nodes_before;
  summary_.data_s += ss.duration_s;
  const vo::PipelineStats& vs = vo->stats();
  summary_.vo.frames += vs.frames;
  for (size_t i = 0; i < vs.by_status.size(); ++i) summary_.vo.by_status[i] += vs.by_status[i];
  summary_.vo.keyframes += vs.keyframes;
  summary_.vo.calibrations += vs.calibrations;
  summary_.vo.calibrations_refused += vs.calibrations_refused;
  summary_.vo.undecodable += vs.undecodable;
  if (Status s = store_->save(*mapper_, mapper_->session(),
                              session_start_utime_ >= 0 ? session_start_utime_ : first_utime);
      !s)
    return s;
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(options_.store.string() + suffix, ec);
    if (!ec) ss.store_bytes += static_cast<int64_t>(bytes);
  }
  if (auto rows = store_->edgeRows()) ss.store_edge_rows = *rows;
  summary_.sessions.push_back(ss);
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
  out.nodes = m.graphNodes();
  out.edges = static_cast<int64_t>(m.constraints().pairs().size());
  out.floors = static_cast<int64_t>(m.floors().size());
  out.loop_proposals = requests_answered_;
  out.verified = answers_ok_;
  out.rejected = out.mapper.rejected_map_gate + out.mapper.rejected_inconsistent;
  out.accepted_closures = 0;
  for (const auto& c : m.constraints().all())
    if (c.accepted && c.kind == mapper::ConstraintKind::kLoop) ++out.accepted_closures;
  out.peak_rss_kb = peakRssKb();
  out.hours.clear();
  for (size_t i = 0; i < frames_.size();) {
    HourFigures h;
    h.hour = static_cast<int>(frames_[i].run_s / 3600.0);
    std::vector<double> mapper_ms, loopclose_ms;
    for (; i < frames_.size() && static_cast<int>(frames_[i].run_s / 3600.0) == h.hour; ++i) {
      mapper_ms.push_back(frames_[i].mapper_ms);
      loopclose_ms.push_back(frames_[i].loopclose_ms);
      h.nodes_at_end = frames_[i].nodes;
    }
    h.frames = static_cast<int64_t>(mapper_ms.size());
    h.mapper_p99_ms = percentile(std::move(mapper_ms), 0.99);
    h.loopclose_p99_ms = percentile(std::move(loopclose_ms), 0.99);
    out.hours.push_back(h);
  }

  auto truth = mapper::truthFromSamples(truth_, truth_floor_);
  if (truth) {
    // Accepted closures against the truth at their nodes' keyframes.
    std::map<int64_t, core::SE3d> node_truth;
    for (const mapper::MapperNode& n : m.nodes()) {
      core::SE3d p;
      if (truth->at(n.keyframe_utime, &p)) node_truth[n.id] = p;
    }
    for (const auto& [id, p] : node_truth) {
      const mapper::MapperNode& n = m.nodes()[static_cast<size_t>(id)];
      const core::SE3d est = m.nodePose(id);
      SlamRunSummary::NodeRow row{id,
                                  n.session,
                                  n.floor,
                                  -1,
                                  n.keyframe_utime,
                                  p.translation(),
                                  est.translation(),
                                  core::toPlanar(p).theta(),
                                  core::toPlanar(est).theta()};
      auto f = truth_floor_.lower_bound(n.keyframe_utime);
      if (f != truth_floor_.end()) row.true_floor = f->second.first;
      out.node_rows.push_back(row);
    }
    out.false_closures = 0;
    for (const auto& c : m.constraints().all()) {
      if (!c.accepted || c.kind != mapper::ConstraintKind::kLoop) continue;
      auto a = node_truth.find(c.from), bb = node_truth.find(c.to);
      if (a == node_truth.end() || bb == node_truth.end()) continue;
      ++out.closures_with_truth;
      const core::SE3d err = (a->second.inverse() * bb->second).inverse() * c.from_T_to.mean;
      if (err.translation().norm() > options_.false_closure_m ||
          core::rotationAngle(err.so3()) * 180.0 / std::numbers::pi > options_.false_closure_deg)
        ++out.false_closures;
    }
    for (RegistrationRow& row : registrations_) {
      core::SE3d b, q;
      if (row.node < 0 || !truth->at(row.node_keyframe_utime, &b) ||
          !truth->at(row.query_utime, &q))
        continue;
      const core::SE3d err = (b.inverse() * q).inverse() * row.b_T_q;
      row.error_m = err.translation().norm();
      row.error_deg = core::rotationAngle(err.so3()) * 180.0 / std::numbers::pi;
      row.nees = normalisedError(err, row.b_T_q_covariance);
      core::SE3d a;
      if (row.active < 0 || !truth->at(row.active_keyframe_utime, &a)) continue;
      const core::SE3d delta_err = (a.inverse() * q).inverse() * row.active_T_q.mean;
      row.delta_error_m = delta_err.translation().norm();
      row.delta_error_deg = core::rotationAngle(delta_err.so3()) * 180.0 / std::numbers::pi;
      row.delta_nees = normalisedError(delta_err, row.active_T_q.covariance);
    }
    // The registration's reach: every node-mode request on one floor, answered or not.
    const core::SE3d& body_T_cam = m.tracker().bodyTCamera();
    for (const RegistrationRow& row : registrations_) {
      core::SE3d n, q;
      if (row.requested_node < 0 || !truth->at(row.requested_keyframe_utime, &n) ||
          !truth->at(row.query_utime, &q))
        continue;
      if (std::abs(n.translation().z() - q.translation().z()) > 1.0) continue;
      const bool ok = row.status == register_result_t::STATUS_OK &&
                      row.node == row.requested_node && row.error_m >= 0.0 &&
                      row.error_m <= options_.false_closure_m &&
                      row.error_deg <= options_.false_closure_deg;
      out.reach.push_back({(n.translation() - q.translation()).norm(),
                           sim::viewAngle(n * body_T_cam, q * body_T_cam), ok});
    }
    if (!out.reach.empty()) out.reach_fit = sim::fitReach(out.reach, sim::OracleOptions{});
    // New nodes of a session where an earlier session had one (true poses; 1 m, π/8).
    for (SessionSummary& ss : out.sessions) ss.nodes_in_mapped_area = 0;
    for (const mapper::MapperNode& n : m.nodes()) {
      auto it = node_truth.find(n.id);
      if (it == node_truth.end()) continue;
      const core::SE2d p = core::toPlanar(it->second);
      for (const mapper::MapperNode& o : m.nodes()) {
        if (o.session >= n.session) continue;
        auto jt = node_truth.find(o.id);
        if (jt == node_truth.end()) continue;
        const core::SE2d q = core::toPlanar(jt->second);
        const double dyaw = std::remainder(p.theta() - q.theta(), 2.0 * std::numbers::pi);
        if ((p.translation() - q.translation()).norm() <= 1.0 &&
            std::abs(dyaw) <= std::numbers::pi / 8 &&
            std::abs(it->second.translation().z() - jt->second.translation().z()) < 1.0) {
          for (SessionSummary& ss : out.sessions)
            if (ss.session == n.session) ++ss.nodes_in_mapped_area;
          break;
        }
      }
    }
    auto map = mapper::mapFromGraph(mapper::graphMessage(m, 0));
    if (!map) return map.error();
    auto e = mapper::evaluateMap(*map, *truth, out.trajectory);
    if (e)
      out.evaluation = *e;
    else
      out.errors.push_back("evaluation: " + e.error().message);
  }
  return out;
}

std::string SlamRunSummary::text() const {
  std::ostringstream s;
  s << "sessions " << sessions.size() << "\ndata_s " << data_s << "\nwall_s " << wall_s
    << "\nrealtime_factor " << (wall_s > 0 ? data_s / wall_s : 0.0) << "\npeak_rss_mb "
    << peak_rss_kb / 1024 << "\n";
  for (const SessionSummary& ss : sessions) {
    s << "session." << ss.session << " log " << ss.log << " duration_s " << ss.duration_s
      << " frames " << ss.stereo_frames << " vo_ok " << ss.vo_ok << " keyframes " << ss.keyframes
      << " floor_events " << ss.floor_events << " nodes_added " << ss.nodes_added
      << " nodes_in_mapped_area " << ss.nodes_in_mapped_area << " relocalised_after_s "
      << ss.relocalised_after_s << " store_bytes " << ss.store_bytes << " store_edge_rows "
      << ss.store_edge_rows << "\n";
  }
  for (const HourFigures& h : hours)
    s << "hour." << h.hour << " frames " << h.frames << " nodes_at_end " << h.nodes_at_end
      << " mapper_p99_ms " << h.mapper_p99_ms << " loopclose_p99_ms " << h.loopclose_p99_ms << "\n";
  s << "nodes " << nodes << "\nedges " << edges << "\nfloors " << floors << "\nloop_proposals "
    << loop_proposals << " (node " << mapper.requests_node << ", global " << mapper.requests_global
    << ")\nverified " << verified << "\naccepted_closures " << accepted_closures
    << " (in the final map's constraints: a folded pair counts as its first; "
    << mapper.loop_closures << " made over the run)\nrejected " << rejected << " (map gate "
    << mapper.rejected_map_gate << ", other floor " << mapper.rejected_floor << ", inconsistent "
    << mapper.rejected_inconsistent << ", recovered " << mapper.gate_recoveries
    << ", too far to recover " << mapper.recoveries_too_far << ")\nrelocalizations "
    << mapper.relocalizations << "\n";
  if (false_closures >= 0)
    s << "false_closures " << false_closures << " (of " << closures_with_truth << " with truth)\n";
  if (reach_fit) {
    // Node-mode requests by the true distance between the keyframes: registered / asked.
    constexpr double kEdges[] = {0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 1e9};
    s << "registration_reach node_requests " << reach.size()
      << " (same floor, with truth), registered by distance:";
    for (size_t b = 0; b + 1 < std::size(kEdges); ++b) {
      int asked = 0, ok = 0;
      for (const sim::ReachSample& r : reach)
        if (r.distance_m >= kEdges[b] && r.distance_m < kEdges[b + 1]) {
          ++asked;
          ok += r.ok ? 1 : 0;
        }
      s << " " << kEdges[b];
      if (b + 2 < std::size(kEdges))
        s << "-" << kEdges[b + 1];
      else
        s << "+";
      s << " m " << ok << "/" << asked;
    }
    s << "\nregistration_reach_fit success_probability " << reach_fit->success_probability
      << " distance_scale_m " << reach_fit->distance_scale_m << " angle_scale_rad "
      << reach_fit->angle_scale_rad << " (the oracle's p = P exp(-(d/D)^2/2) exp(-(a/A)^2/2) over "
      << reach_fit->samples << " requests; beyond its bounds " << reach_fit->beyond << ", "
      << reach_fit->ok_beyond << " registered; its defaults: 0.95, 2, 0.5)\n";
  }
  s << "vo " << vo.report();
  // Every counter of the mapper and of its tracker (mapper_stats.h, tracker_counts.h).
  const char* separator = "\nmapper ";
  for (const auto& c : mapper::MapperStats::counters())
    s << std::exchange(separator, ", ") << c.name << " " << mapper.*c.field;
  separator = "\ntracker ";
  for (const auto& c : mapper::TrackerCounts::counters())
    s << std::exchange(separator, ", ") << c.name << " " << tracker.*c.field;
  s << "\nloopclose " << loopclose.text() << "\n";
  if (evaluation) s << evaluation->text();
  const double n = std::max<double>(1.0, static_cast<double>(vo.frames));
  s << "ms_per_frame decode " << 1e3 * times.decode_s / n << " (reader thread) wait "
    << 1e3 * times.wait_s / n << " vo " << 1e3 * times.vo_s / n << " imu " << 1e3 * times.imu_s / n
    << " loopclose " << 1e3 * times.loopclose_s / n << " mapper " << 1e3 * times.mapper_s / n
    << "\ninput_errors " << input_errors << "\n";
  for (const std::string& e : errors) s << "error " << e << "\n";
  return s.str();
}

}  // namespace evermap::slam_run
