#include "viewer/lcm_listener.h"

#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <evermap/stereo_image_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "viewer/json_writer.h"

namespace evermap::viewer {
namespace {

std::string base64(const std::vector<uchar>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t k = 0;
  for (; k + 2 < bytes.size(); k += 3) {
    const uint32_t v = (bytes[k] << 16) | (bytes[k + 1] << 8) | bytes[k + 2];
    for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(v >> s) & 63];
  }
  if (k < bytes.size()) {
    uint32_t v = bytes[k] << 16;
    if (k + 1 < bytes.size()) v |= bytes[k + 1] << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += k + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

Status LcmListenerOptions::validate() const {
  if (Status s = state.validate(); !s) return s;
  if (!(image_period_s >= 0.0) || !std::isfinite(image_period_s))
    return makeError("image_period_s: must be a finite number >= 0, got ", image_period_s);
  if (image_width < 16 || image_width > 4096)
    return makeError("image_width: must be in [16, 4096], got ", image_width);
  return input.validate();
}

LcmListener::LcmListener(lcm::LCM& lcm, Board& board, const LcmListenerOptions& options)
    : board_(board), o_(options), state_(board, options.state), inbox_(lcm, options.input) {
  inbox_.shareChannel(channels::kDeputyStatus);  // every host's deputy
  // The graph is large and only the newest matters: a queue of 2. Only the mapper the Inbox
  // locked onto is shown (a second one is ignored, counted; sender_check.h), named in counts.
  inbox_.subscribe<map_graph_t>(
      channels::kMapGraph, [this](const map_graph_t& m) { return state_.onGraph(m); }, 2);
  inbox_.subscribe<pose_t>(channels::kPose, [this](const pose_t& m) { return state_.onPose(m); });
  inbox_.subscribe<floor_t>(channels::kFloor,
                            [this](const floor_t& m) { return state_.onFloor(m); });
  inbox_.subscribe<mapper_stats_t>(channels::kMapperStats,
                                   [this](const mapper_stats_t& m) { return state_.onStats(m); });
  inbox_.subscribe<register_result_t>(
      channels::kRegisterResult,
      [this](const register_result_t& m) { return state_.onRegister(m); });
  inbox_.subscribe<deputy_status_t>(
      channels::kDeputyStatus, [this](const deputy_status_t& m) { return state_.onDeputy(m); });
  inbox_.subscribe<vo_delta_t>(channels::kVoDelta,
                               [this](const vo_delta_t& m) { return state_.onVo(m); });
  inbox_.subscribe<keyframe_t>(
      channels::kKeyframe, [this](const keyframe_t& m) { return state_.onKeyframe(m); }, 4);
  inbox_.subscribeBytes<stereo_image_t>(
      channels::kStereo, [this](const void* data, int64_t size) { return onStereo(data, size); },
      2);
}

Status LcmListener::onStereo(const void* data, int64_t size) {
  const auto now = std::chrono::steady_clock::now();
  if (now < next_image_) return Ok{};  // not due: not even decoded
  next_image_ = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double>(o_.image_period_s));
  auto msg = messages::decodeLcm<stereo_image_t>(data, size, channels::kStereo);
  if (!msg) return msg.error();
  auto left = messages::fromMsg(msg->left);
  if (!left) return makeError("STEREO ", msg->utime, ": left image: ", left.error().message);
  cv::Mat shown = *left;
  const double scale =
      left->cols > o_.image_width ? static_cast<double>(o_.image_width) / left->cols : 1.0;
  if (scale < 1.0) cv::resize(*left, shown, cv::Size(), scale, scale, cv::INTER_AREA);
  std::vector<uchar> jpeg;
  if (!cv::imencode(".jpg", shown, jpeg, {cv::IMWRITE_JPEG_QUALITY, 75}))
    return makeError("STEREO ", msg->utime, ": the left image does not encode as JPEG");
  JsonWriter j;
  j.beginObject().key("type").value("image").key("utime").value(msg->utime);
  j.key("width")
      .value(static_cast<int64_t>(left->cols))
      .key("height")
      .value(static_cast<int64_t>(left->rows));
  j.key("scale").value(scale, 5).key("jpeg").value(base64(jpeg));
  j.key("features_utime").value(state_.featuresUtime());
  j.key("features").raw(state_.featuresJson()).endObject();
  board_.post(Topic::kImage, j.take());
  ++images_sent_;
  return Ok{};
}

void LcmListener::postCounts(const std::string& extra_members) {
  JsonWriter j;
  j.beginObject().key("type").value("viewer").key("channels").beginObject();
  for (const auto& [channel, c] : inbox_.counts()) {
    j.key(channel)
        .beginObject()
        .key("received")
        .value(c.received)
        .key("dropped")
        .value(c.dropped())
        .endObject();
  }
  const messages::ChannelCounts total = inbox_.total();
  j.endObject().key("received").value(total.received).key("dropped").value(total.dropped());
  j.key("images_sent").value(images_sent_).key("graphs").value(state_.graphs());
  j.key("map_sender").value(inbox_.senderOf(channels::kMapGraph));
  j.key("server").raw(extra_members.empty() ? "{}" : extra_members).endObject();
  board_.post(Topic::kViewer, j.take());
}

}  // namespace evermap::viewer
