#include "tools/sim/image_session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/common/clocks.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/rgbd_convert.h"

#include <evermap/rgbd_calib_t.hpp>
#include "tools/sim/run_output.h"
#include "tools/sim/streams.h"

namespace evermap::sim {
namespace {}  // namespace

std::string ImageSessionSummary::text() const {
  std::ostringstream out;
  out << "session " << session << ": " << duration_s << " s, " << distance_m << " m, " << rides
      << " elevator rides, floors";
  for (int f : floors_visited) out << " " << f;
  out << "\ncamera frames: " << frames << " (dark room " << frames_dark_room << ", featureless "
      << frames_blank_zone << ", passers-by " << frames_passerby << ", closed cab "
      << frames_closed_cab << ")\n";
  int64_t bytes = 0;
  for (const auto& [channel, c] : channels) {
    out << channel << ": " << c.messages << " messages, " << c.bytes << " bytes\n";
    bytes += c.bytes;
  }
  out << "total: " << bytes << " bytes of messages\n";
  if (frames > 0) {
    out << "render: " << render_s << " s (" << frames / std::max(render_s, 1e-9)
        << " frames/s), encode: " << encode_s << " s\n";
  }
  return out.str();
}

ImageSimulator::ImageSimulator(const ImageSimOptions& options, RunPlan plan)
    : options_(options), plan_(std::move(plan)) {}

Expected<std::unique_ptr<ImageSimulator>> ImageSimulator::create(const ImageSimOptions& o,
                                                                 ProgressReporter* progress) {
  if (Status s = o.validate(); !s) return s.error();
  const int index = o.render.session;
  if (progress) progress->reportText("planning session " + std::to_string(index));
  auto plan = RunPlan::create(o.sim);
  if (!plan) return plan.error();
  std::unique_ptr<ImageSimulator> sim(new ImageSimulator(o, std::move(*plan)));
  sim->session_ = sim->plan_.session(index);
  Random texture_rng = Random::derive(o.sim.seed, static_cast<uint64_t>(Stream::kTextures));
  if (progress) progress->reportText("making the textures");
  auto textures = makeTextureLibrary(
      o.render.textures, o.posterFolder(), texture_rng, [progress](int made, int total) {
        if (progress)
          progress->updateText(std::to_string(made) + " of " + std::to_string(total) +
                               " textures made");
      });
  if (!textures) return textures.error();
  sim->textures_ = std::make_unique<TextureLibrary>(std::move(*textures));
  if (progress) progress->reportText("building the world");
  Random paint_rng = Random::derive(o.sim.seed, static_cast<uint64_t>(Stream::kPainting));
  auto world = buildRenderWorld(sim->plan_.building(), o.sim.building, o.render.world,
                                *sim->textures_, paint_rng);
  if (!world) return world.error();
  sim->world_ = std::move(*world);
  const Trajectory& traj = *sim->session_.trajectory;
  Random passer_rng = streamFor(o.sim.seed, Stream::kPassersBy, index);
  const VoOptions& vo = o.sim.sensors.vo;
  sim->passers_ = Intervals(traj.startUtime(), traj.endUtime(), vo.passerby_rate_per_hour,
                            vo.passerby_min_s, vo.passerby_max_s, passer_rng);
  sim->renderer_ = std::make_unique<ImageRenderer>(
      *sim->textures_, o.camera(), o.render.noise_sigma_gray,
      mixSeed(o.sim.seed, static_cast<uint64_t>(Stream::kRenderNoise) + index));
  sim->renderer_->setLighting(o.lighting.forSession(index, o.sim.seed));
  sim->depth_sensor_ = std::make_unique<DepthSensor>(
      o.render.depth, o.sim.sensors.camera.fx,
      mixSeed(o.sim.seed, static_cast<uint64_t>(Stream::kDepthNoise) + index));
  return sim;
}

int64_t ImageSimulator::startUtime() const { return session_.trajectory->startUtime(); }

int64_t ImageSimulator::endUtime() const {
  const int64_t end = session_.trajectory->endUtime();
  if (options_.render.max_duration_s <= 0.0) return end;
  return std::min(end, startUtime() + static_cast<int64_t>(options_.render.max_duration_s * 1e6));
}

core::StereoCalibration ImageSimulator::calibration() const {
  return options_.sim.sensors.camera.stereoCalibration(options_.render.width,
                                                       options_.render.height);
}

FrameFacts ImageSimulator::facts(int64_t utime, const BodyState& state) const {
  FrameFacts f;
  f.floor = state.floor;
  if (state.in_cab) {
    const auto margin = static_cast<int64_t>(options_.render.door_margin_s * 1e6);
    for (const ElevatorRide& r : session_.rides) {
      if (utime >= r.start_utime - margin && utime <= r.end_utime + margin) f.closed_cab = true;
    }
  }
  if (!f.closed_cab) {
    if (f.floor < 0) f.floor = building().nearestFloor(state.world_T_body.translation().z());
    const SE3d world_T_cam = state.world_T_body * options_.sim.sensors.camera.bodyTCam();
    const Vec3 c = world_T_cam.translation();
    const Floor& fl = building().floors[static_cast<size_t>(f.floor)];
    const int room = fl.roomAt(c.head<2>());
    f.dark_room = room >= 0 && fl.rooms[static_cast<size_t>(room)].dark;
    const RenderFloor& rf = world_.floors[static_cast<size_t>(f.floor)];
    f.blank_zone = (rf.cellAt(static_cast<float>(c.x()), static_cast<float>(c.y())) & 0x80) != 0;
  }
  f.passerby = passers_.contains(utime);
  return f;
}

std::vector<Occluder> ImageSimulator::passersBy(int64_t utime) const {
  std::vector<Occluder> out;
  const auto& spans = passers_.spans();
  for (size_t i = 0; i < spans.size(); ++i) {
    const auto [b, e] = spans[i];
    if (utime < b || utime >= e) continue;
    // The look of this passer-by: its own stream, so it does not depend on the frame rate.
    Random rng =
        Random::derive(options_.sim.seed, static_cast<uint64_t>(Stream::kPasserbyLook) +
                                              static_cast<uint64_t>(i) * 7919 +
                                              static_cast<uint64_t>(options_.render.session));
    const PasserbyOptions& p = options_.passerby;
    const double distance = rng.uniform(p.distance_min_m, p.distance_max_m);
    const bool from_left = rng.bernoulli(0.5);
    const std::vector<int>& pool = textures_->people.empty() ? textures_->wall : textures_->people;
    const int texture = pool[static_cast<size_t>(rng.index(static_cast<int64_t>(pool.size())))];
    const Trajectory& traj = *session_.trajectory;
    const SE3d cam_mid =
        traj.at(std::clamp((b + e) / 2, traj.startUtime(), traj.endUtime())).world_T_body *
        options_.sim.sensors.camera.bodyTCam();
    Vec2 fwd = cam_mid.so3().matrix().col(2).head<2>();
    fwd.normalize();
    const Vec2 left(-fwd.y(), fwd.x());
    // Crosses the whole view, fast at the edges and slowly in front of the camera:
    // x(τ) = x0 (1 - 2 (τ - 0.9 sin(2πτ) / 2π)).
    const PinholeCamera cam = options_.camera();
    const double half_view = distance * 0.5 * cam.width / cam.fx + 0.5 * p.width_m + 0.1;
    const double x0 = from_left ? half_view : -half_view;
    const double tau = static_cast<double>(utime - b) / static_cast<double>(e - b);
    const double shape =
        tau - 0.9 * std::sin(2.0 * std::numbers::pi * tau) / (2.0 * std::numbers::pi);
    const double x = x0 * (1.0 - 2.0 * shape);
    const Vec3 c =
        (traj.at(utime).world_T_body * options_.sim.sensors.camera.bodyTCam()).translation();
    Occluder o;
    o.centre = c.head<2>() + distance * fwd + x * left;
    o.normal = -fwd;
    o.width_m = p.width_m;
    o.height_m = p.height_m;
    o.texture = texture;
    o.texel_m = 0.006;
    out.push_back(o);
  }
  return out;
}

FrameFacts ImageSimulator::renderPair(int64_t utime, cv::Mat* left, cv::Mat* right) {
  const BodyState state = session_.trajectory->at(utime);
  const FrameFacts f = facts(utime, state);
  const CameraOptions& c = options_.sim.sensors.camera;
  const SE3d world_T_left = state.world_T_body * c.bodyTCam();
  const SE3d world_T_right = world_T_left * SE3d(core::SO3d(), Vec3(c.baseline_m, 0.0, 0.0));
  const std::vector<Occluder> occluders = passersBy(utime);
  const RenderFloor& floor =
      f.closed_cab ? world_.closed_cab : world_.floors[static_cast<size_t>(f.floor)];
  const double z_shift = f.closed_cab ? state.world_T_body.translation().z() : 0.0;
  renderer_->render(floor, z_shift, world_T_left, occluders, left);
  renderer_->render(floor, z_shift, world_T_right, occluders, right);
  return f;
}

FrameFacts ImageSimulator::renderRgbd(int64_t utime, cv::Mat* gray, cv::Mat* depth,
                                      cv::Mat* truth) {
  const BodyState state = session_.trajectory->at(utime);
  const FrameFacts f = facts(utime, state);
  const SE3d world_T_cam = state.world_T_body * options_.sim.sensors.camera.bodyTCam();
  const std::vector<Occluder> occluders = passersBy(utime);
  const RenderFloor& floor =
      f.closed_cab ? world_.closed_cab : world_.floors[static_cast<size_t>(f.floor)];
  const double z_shift = f.closed_cab ? state.world_T_body.translation().z() : 0.0;
  cv::Mat& exact = truth ? *truth : depth_truth_;
  renderer_->render(floor, z_shift, world_T_cam, occluders, gray, &exact);
  depth_sensor_->measure(exact, depth);
  return f;
}

Expected<ImageSessionSummary> ImageSimulator::run(MessageSink& out,
                                                  const std::function<bool(double)>& progress) {
  const ImageSimOptions& o = options_;
  const SensorOptions& so = o.sim.sensors;
  const Trajectory& traj = *session_.trajectory;
  const int index = o.render.session;
  const int64_t start = startUtime(), end = endUtime();
  CountingSink sink(&out);
  ImageSessionSummary summary = summaryHead();
  std::vector<int> floors;

  Random slip_rng = streamFor(o.sim.seed, Stream::kSlips, index);
  Intervals slips(start, traj.endUtime(), so.wheel.slip_rate_per_hour, so.wheel.slip_min_s,
                  so.wheel.slip_max_s, slip_rng);
  WheelModel wheel(so.wheel, std::move(slips), streamFor(o.sim.seed, Stream::kWheelNoise, index));
  Random imu_rng = streamFor(o.sim.seed, Stream::kImuNoise, index);
  const Vec3 imu_bias = accelBias(so.imu, imu_rng);
  const Vec3 gyro_bias = gyroBias(so.imu, o.sim.seed, index);

  const core::StereoCalibration calib = calibration();
  channels::CalibrationRepeat calib_repeat;
  TickClock imu(start, so.imu.rate_hz), gt(start, so.ground_truth_rate_hz),
      wheel_ticks(start, so.wheel.rate_hz, 1), stereo(start, o.render.rate_hz);
  constexpr int64_t kNever = INT64_MAX;
  int64_t wheel_prev_utime = start;
  BodyState wheel_prev = traj.at(start);
  const double total = static_cast<double>(std::max<int64_t>(1, end - start));
  while (true) {
    const int64_t t_imu = so.imu.enabled ? imu.next() : kNever;
    const int64_t t = std::min({t_imu, gt.next(), wheel_ticks.next(), stereo.next()});
    if (t > end) break;
    if (t == t_imu) {
      writeMessage(sink, channels::kImu, measureImu(t, traj, so.imu, imu_bias, gyro_bias, imu_rng));
      imu.advance();
    } else if (t == gt.next()) {
      const BodyState s = traj.at(t);
      writeMessage(sink, channels::kGroundTruth,
                   messages::toMsg(t, core::UncertainPose{s.world_T_body}, s.floor, index));
      if (s.floor >= 0 && std::find(floors.begin(), floors.end(), s.floor) == floors.end())
        floors.push_back(s.floor);
      gt.advance();
    } else if (t == wheel_ticks.next()) {
      const BodyState s = traj.at(t);
      writeMessage(sink, channels::kWheelOdom, wheel.increment(wheel_prev_utime, wheel_prev, t, s));
      wheel_prev_utime = t;
      wheel_prev = s;
      wheel_ticks.advance();
    } else {
      if (Status s = writeCameraFrame(sink, t, calib, calib_repeat, &summary); !s) return s.error();
      stereo.advance();
      if (progress && !progress(static_cast<double>(t - start) / total)) {
        stoppedAt(t, &summary);  // the figures cover what was written
        break;
      }
    }
  }
  std::sort(floors.begin(), floors.end());
  summary.floors_visited = floors;
  summary.channels = sink.counts();
  return summary;
}

ImageSessionSummary ImageSimulator::summaryHead() const {
  const Trajectory& traj = *session_.trajectory;
  const int64_t start = startUtime(), end = endUtime();
  ImageSessionSummary summary;
  summary.session = options_.render.session;
  summary.duration_s = static_cast<double>(end - start) * 1e-6;
  summary.distance_m = traj.at(end).odometer_m - traj.at(start).odometer_m;
  for (const ElevatorRide& r : session_.rides) {
    if (r.start_utime < end) ++summary.rides;
  }
  return summary;
}

void ImageSimulator::stoppedAt(int64_t utime, ImageSessionSummary* summary) const {
  const Trajectory& traj = *session_.trajectory;
  const int64_t start = startUtime();
  summary->duration_s = static_cast<double>(utime - start) * 1e-6;
  summary->distance_m = traj.at(utime).odometer_m - traj.at(start).odometer_m;
  summary->rides = 0;
  for (const ElevatorRide& r : session_.rides) summary->rides += r.start_utime < utime ? 1 : 0;
}

Status ImageSimulator::writeCameraFrame(MessageSink& sink, int64_t t,
                                        const core::StereoCalibration& calib,
                                        channels::CalibrationRepeat& calib_repeat,
                                        ImageSessionSummary* summary) {
  const bool rgbd = options_.render.camera == CameraMode::kRgbd;
  cv::Mat &left = frame_left_, &right = frame_right_, &depth = frame_depth_;
  const auto t0 = SteadyClock::now();
  const FrameFacts f = rgbd ? renderRgbd(t, &left, &depth) : renderPair(t, &left, &right);
  summary->render_s += secondsSince(t0);
  ++summary->frames;
  summary->frames_dark_room += f.dark_room;
  summary->frames_blank_zone += f.blank_zone;
  summary->frames_passerby += f.passerby;
  summary->frames_closed_cab += f.closed_cab;
  summary->frame_facts.emplace_back(t, f);
  const messages::ImageEncoding encoding = options_.render.encoding;
  if (rgbd) {
    if (calib_repeat.due(t)) {
      evermap::rgbd_calib_t c;
      c.utime = t;
      c.camera = messages::toMsg(calib.left);
      writeMessage(sink, channels::kRgbdCalib, c);
    }
    const auto t1 = SteadyClock::now();
    messages::RgbdFrame frame;
    frame.utime = frame.depth_utime = t;
    frame.gray = left;
    frame.depth = depth;
    frame.depth_scale_m = options_.render.depth.unit_m;
    frame.camera = calib.left;
    auto msg = messages::toMsg(frame, encoding);
    if (!msg) return msg.error();
    summary->encode_s += secondsSince(t1);
    writeMessage(sink, channels::kRgbd, *msg);
  } else {
    if (calib_repeat.due(t)) writeMessage(sink, channels::kStereoCalib, messages::toMsg(calib, t));
    const auto t1 = SteadyClock::now();
    auto msg = messages::toMsg(messages::StereoFrame{t, true, left, right}, encoding);
    if (!msg) return msg.error();
    summary->encode_s += secondsSince(t1);
    writeMessage(sink, channels::kStereo, *msg);
  }
  return Ok{};
}

Expected<ImageSessionSummary> writeImageSessionLog(ImageSimulator& simulator,
                                                   const std::filesystem::path& output,
                                                   const std::function<bool(double)>& progress) {
  auto writer = messages::LogWriter::open(output);
  if (!writer) return writer.error();
  LogWriterSink sink(std::move(*writer));
  auto summary = simulator.run(sink, progress);
  if (!summary) return summary.error();
  if (Status s = sink.commit(); !s) return s.error();
  return summary;
}

}  // namespace evermap::sim
