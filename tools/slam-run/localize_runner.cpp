#include "tools/slam-run/localize_runner.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include <evermap/imu_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/clocks.h"
#include "core/common/percentile.h"
#include "core/imu/lcm_convert.h"
#include "core/map/store_file.h"
#include "core/map/store_reader.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "elevator-proc/lcm_convert.h"
#include "tools/eval/alignment.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/sim/image_session.h"
#include "tools/slam-run/event_stream.h"
#include "tools/slam-run/session_processes.h"

namespace evermap::slam_run {

using detail::EventStream;
using detail::ReadEvent;

LocalizeRunner::LocalizeRunner(const bow::Vocabulary& vocabulary, const SlamRunOptions& options)
    : vocabulary_(vocabulary), options_(options) {}
LocalizeRunner::~LocalizeRunner() = default;

Expected<std::unique_ptr<LocalizeRunner>> LocalizeRunner::create(const bow::Vocabulary& vocabulary,
                                                                 const SlamRunOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (options.places.empty()) return Error("localization needs the map's place store (--places)");
  std::unique_ptr<LocalizeRunner> r(new LocalizeRunner(vocabulary, options));
  // The map store read once, read-only: no file is created, nothing is written.
  if (!std::filesystem::is_regular_file(options.store))
    return makeError(options.store.string(), ": no such map store");
  auto file = map::StoreFile::open(options.store, /*read_only=*/true);
  if (!file) return file.error();
  auto map = map::readMap(*file);
  if (!map) return map.error();
  r->localizer_ = std::make_unique<mapper::Localizer>(options.mapper);
  if (Status s = r->localizer_->load(*map); !s)
    return makeError(options.store.string(), ": ", s.error().message);
  auto registration = loopclose::CoreRegistration::create(options.registration);
  if (!registration) return registration.error();
  r->registration_ = std::make_unique<loopclose::CoreRegistration>(std::move(*registration));
  auto places = bow::PlaceStore::openReadOnly(options.places, vocabulary.fingerprint(),
                                              vocabulary.numWords());
  if (!places) return places.error();
  auto closer = loopclose::LoopCloser::create(vocabulary, *r->registration_, options.loopclose,
                                              std::move(*places));
  if (!closer) return closer.error();
  r->loop_closer_ = std::move(*closer);
  return r;
}

void LocalizeRunner::inputError(const std::string& what) {
  ++summary_.input_errors;
  if (summary_.errors.size() < 20) summary_.errors.push_back(what);
}

Status LocalizeRunner::runLog(const std::filesystem::path& log_file) {
  auto opened = messages::LogReader::open(log_file);
  if (!opened) return opened.error();
  EventStream events(
      detail::logProducer(std::make_shared<messages::LogReader>(std::move(*opened))));
  return runStream(events, log_file.string());
}

Status LocalizeRunner::renderSession(const sim::ImageSimOptions& options) {
  sim::ImageSimOptions o = options;
  o.render.encoding = messages::ImageEncoding::kGray8;
  auto simulator = sim::ImageSimulator::create(o, nullptr);
  if (!simulator) return simulator.error();
  EventStream events(detail::renderProducer(std::move(*simulator)));
  return runStream(events, "rendered session " + std::to_string(o.render.session));
}

Status LocalizeRunner::runStream(EventStream& events, const std::string& name) {
  auto vo = vo::VoPipeline::create(options_.vo);
  if (!vo) return vo.error();
  p_ = std::make_unique<SessionProcesses>(std::move(*vo), options_.attitude,
                                          options_.attitude_rate_hz, options_.elevator);
  int64_t first = -1;
  bool cut_short = false;
  const auto start_us = static_cast<int64_t>(options_.start_session_s * 1e6);
  while (std::optional<ReadEvent> e = events.next()) {
    if (first < 0) first = e->timestamp;
    const bool calibration =
        e->channel == channels::kStereoCalib || e->channel == channels::kRgbdCalib;
    if (e->timestamp - first < start_us && !calibration) continue;  // --start-s
    if (options_.max_session_s > 0.0 &&
        e->timestamp - first - start_us > static_cast<int64_t>(options_.max_session_s * 1e6)) {
      cut_short = true;
      break;
    }
    double loopclose_s = 0.0, localizer_s = 0.0;
    handleEvent(*e, &loopclose_s, &localizer_s);
  }
  if (Status s = events.finish(); !s && !cut_short) return makeError(name, ": ", s.error().message);
  if (first < 0) return makeError(name, ": no event");
  // What VO's start-up hold still keeps (a session shorter than the hold).
  double loopclose_s = 0.0, localizer_s = 0.0;
  for (const vo::PipelineOutput& out : p_->vo.flush())
    onOutput(out, 0.0, &loopclose_s, &localizer_s);
  return Ok{};
}

void LocalizeRunner::handleEvent(const ReadEvent& e, double* loopclose_s, double* localizer_s) {
  const std::string& channel = e.channel;
  const void* data = e.data.data();
  const auto size = static_cast<int64_t>(e.data.size());
  const auto set = [this](const core::SE3d& m) { localizer_->setCameraMounting(m); };
  if (channel == channels::kStereoCalib) {
    if (Status s = p_->vo.handleCalibrationBytes(data, size); !s)
      inputError("vo: " + s.error().message);
    if (Status s = calibration_.handle(data, size, set); !s)
      inputError("localizer: " + s.error().message);
  } else if (channel == channels::kRgbdCalib) {
    if (Status s = calibration_.handleRgbd(data, size, set); !s)
      inputError("localizer: " + s.error().message);
  } else if (channel == channels::kStereo || channel == channels::kRgbd) {
    onFrame(e, loopclose_s, localizer_s);
  } else if (channel == channels::kImu) {
    onImu(data, size, localizer_s);
  } else if (channel == channels::kWheelOdom) {
    auto msg = messages::decodeLcm<wheel_odom_t>(data, size, channel);
    if (!msg) {
      inputError(msg.error().message);
    } else if (Status s = localizer_->onWheel(*msg); !s) {
      inputError("WHEEL_ODOM: " + s.error().message);
    }
  } else if (channel == channels::kGroundTruth) {
    auto msg = messages::decodeLcm<pose_t>(data, size, channel);
    auto pose = msg ? messages::fromMsg(*msg) : Expected<core::UncertainPose>(msg.error());
    if (pose) truth_[msg->utime] = pose->mean;
  }
}

void LocalizeRunner::onFrame(const ReadEvent& e, double* loopclose_s, double* localizer_s) {
  const auto t0 = SteadyClock::now();
  Expected<vo::PipelineOutputs> outs = p_->runVo(e);
  const double vo_s = secondsSince(t0);
  if (!outs) {
    inputError(e.channel + ": " + outs.error().message);
    return;
  }
  for (size_t i = 0; i < outs->size(); ++i)
    onOutput((*outs)[i], i + 1 == outs->size() ? vo_s : 0.0, loopclose_s, localizer_s);
}

void LocalizeRunner::onOutput(const vo::PipelineOutput& out, double vo_s, double* loopclose_s,
                              double* localizer_s) {
  deliverFrame(
      out, calibration_.haveCamera(), *loop_closer_, *localizer_,
      [this](const std::string& what) { inputError(what); }, loopclose_s, localizer_s);
  exchange(loopclose_s, localizer_s);
  FrameRow row;
  row.utime = out.delta.utime;
  row.placed = localizer_->placed();
  row.localized = localizer_->localized();
  row.floor = localizer_->floor();
  row.node = localizer_->activeNode();
  const core::UncertainPose pose = localizer_->pose();
  row.world_T_body = pose.mean;
  row.sigma = pose.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  row.dead_reckoning_m = localizer_->deadReckoningM();
  row.vo_ms = 1e3 * vo_s;
  row.loopclose_ms = 1e3 * *loopclose_s;
  row.localizer_ms = 1e3 * *localizer_s;
  frames_.push_back(row);
}

void LocalizeRunner::onImu(const void* data, int64_t size, double* localizer_s) {
  auto msg = messages::decodeLcm<imu_t>(data, size, channels::kImu);
  if (!msg) {
    inputError(msg.error().message);
    return;
  }
  const SessionProcesses::ImuOutputs out = p_->onImu(*msg);
  const auto t0 = SteadyClock::now();
  if (out.attitude) {
    if (Status s = localizer_->onAttitude(*out.attitude); !s) {
      inputError("ATTITUDE: " + s.error().message);
    }
  }
  for (const auto& ev : out.floor_events) {
    if (Status s = localizer_->onFloor(elevator::toLcm(ev)); !s)
      inputError("FLOOR: " + s.error().message);
  }
  *localizer_s += secondsSince(t0);
}

void LocalizeRunner::exchange(double* loopclose_s, double* localizer_s) {
  // Each request answered at once (as SlamRunner does); a failed node-mode request is followed
  // by the floor's global search, answered in the next pass.
  while (true) {
    auto requests = localizer_->takeRequests();
    if (requests.empty()) return;
    for (const register_request_t& r : requests) {
      auto t0 = SteadyClock::now();
      const register_result_t answer = loop_closer_->answer(r);
      *loopclose_s += secondsSince(t0);
      t0 = SteadyClock::now();
      if (Status s = localizer_->onRegisterResult(answer); !s)
        inputError("REGISTER_RESULT: " + s.error().message);
      *localizer_s += secondsSince(t0);
    }
  }
}

}  // namespace evermap::slam_run
