#include "vo-proc/keyframe_buffer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/messages/keyframe_parts.h"

namespace evermap::vo {

Status KeyframeResendOptions::validate() const { return checkOptionRanges(*this); }

void KeyframeBuffer::keep(const evermap::keyframe_t& keyframe) {
  if (max_keyframes_ <= 0) return;
  if (!keyframes_.empty() && keyframe.utime <= keyframes_.back().utime) keyframes_.clear();
  keyframes_.push_back(keyframe);
  while (static_cast<int>(keyframes_.size()) > max_keyframes_ ||
         keyframes_.back().utime - keyframes_.front().utime > max_age_us_) {
    keyframes_.pop_front();
  }
}

const evermap::keyframe_t* KeyframeBuffer::find(int64_t utime) const {
  // Utimes increase: a binary search.
  auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), utime,
                             [](const evermap::keyframe_t& k, int64_t u) { return k.utime < u; });
  return it != keyframes_.end() && it->utime == utime ? &*it : nullptr;
}

std::string ResendStats::text() const {
  char line[200];
  std::snprintf(line, sizeof(line),
                "keyframe requests %lld: resent %lld (%lld parts), unknown %lld, too soon %lld, "
                "over the rate %lld",
                static_cast<long long>(requests), static_cast<long long>(resent),
                static_cast<long long>(parts), static_cast<long long>(unknown),
                static_cast<long long>(too_soon), static_cast<long long>(over_rate));
  return line;
}

KeyframeResender::KeyframeResender(const KeyframeResendOptions& options)
    : options_(options),
      buffer_(options.keyframes, options.seconds),
      tokens_(std::max(1.0, options.max_rate_hz)) {}

std::vector<evermap::keyframe_part_t> KeyframeResender::answer(
    const evermap::keyframe_request_t& request, double now_s) {
  ++stats_.requests;
  // Which parts, from the keyframe's size alone: a request refused below encodes nothing.
  const evermap::keyframe_t* keyframe = buffer_.find(request.keyframe_utime);
  const int count = keyframe ? messages::keyframePartCount(*keyframe) : 0;
  const std::vector<bool> want = wanted(count, request.missing);
  const auto num_wanted = std::count(want.begin(), want.end(), true);
  if (num_wanted == 0) {
    ++stats_.unknown;
    return {};
  }
  // A clock that goes back (or is not finite) fills nothing and lets nothing through early.
  const double burst = std::max(1.0, options_.max_rate_hz);
  if (last_s_ && now_s > *last_s_) {
    tokens_ = std::min(burst, tokens_ + (now_s - *last_s_) * options_.max_rate_hz);
  }
  if (!last_s_ || now_s > *last_s_) last_s_ = now_s;
  // Resends older than min_interval_s no longer count, nor beyond one per kept keyframe.
  while (!sent_.empty() && (!(now_s - sent_.front().at_s < options_.min_interval_s) ||
                            sent_.size() > static_cast<size_t>(options_.keyframes))) {
    sent_.pop_front();
  }
  if (std::any_of(sent_.begin(), sent_.end(),
                  [&](const Sent& s) { return s.utime == request.keyframe_utime; })) {
    ++stats_.too_soon;
    return {};
  }
  // The parts cost their share of the keyframe.
  const double cost = static_cast<double>(num_wanted) / static_cast<double>(count);
  if (tokens_ < cost) {
    ++stats_.over_rate;
    return {};
  }
  tokens_ -= cost;
  if (options_.min_interval_s > 0.0) sent_.push_back(Sent{request.keyframe_utime, now_s});
  ++stats_.resent;
  std::vector<evermap::keyframe_part_t> parts = messages::splitKeyframe(*keyframe);
  std::vector<evermap::keyframe_part_t> out;
  for (size_t i = 0; i < parts.size() && i < want.size(); ++i) {
    if (want[i]) out.push_back(std::move(parts[i]));
  }
  stats_.parts += static_cast<int64_t>(out.size());
  return out;
}

std::vector<bool> KeyframeResender::wanted(int count, const std::vector<int16_t>& missing) {
  // None listed: all of them.
  std::vector<bool> want(static_cast<size_t>(std::max(count, 0)), missing.empty());
  for (const int16_t i : missing) {
    if (i >= 0 && i < count) want[static_cast<size_t>(i)] = true;
  }
  return want;
}

}  // namespace evermap::vo
