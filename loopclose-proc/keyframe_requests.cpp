#include "loopclose-proc/keyframe_requests.h"

#include <algorithm>
#include <cstdio>

namespace evermap::loopclose {

Status KeyframeRequestOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (max_retry_us < retry_us) {
    return makeError("max_retry_us (", max_retry_us, ") must be >= retry_us (", retry_us, ")");
  }
  return Ok{};
}

std::string KeyframeRequestStats::text() const {
  char line[200];
  std::snprintf(line, sizeof(line),
                "keyframes asked again %lld (%lld asks): recovered %lld, given up %lld, refused "
                "%lld; parts %lld (%lld not asked for)",
                static_cast<long long>(asked), static_cast<long long>(asks),
                static_cast<long long>(recovered), static_cast<long long>(given_up),
                static_cast<long long>(refused), static_cast<long long>(parts),
                static_cast<long long>(parts_unasked));
  return line;
}

bool KeyframeRequests::need(int64_t keyframe_utime, int64_t now) {
  if (!enabled()) return false;
  if (awaits(keyframe_utime)) return true;
  if (static_cast<int>(open_.size()) >= options_.max_open) {
    ++stats_.refused;
    return false;
  }
  open_[keyframe_utime] = Open{0, now + options_.first_ask_after_us, 0};
  return true;
}

void KeyframeRequests::received(int64_t keyframe_utime) {
  const auto it = open_.find(keyframe_utime);
  if (it == open_.end()) return;
  if (it->second.attempts > 0) ++stats_.recovered;
  open_.erase(it);
  parts_.erase(keyframe_utime);
}

Expected<std::optional<evermap::keyframe_t>> KeyframeRequests::addPart(
    const evermap::keyframe_part_t& part) {
  if (!awaits(part.utime)) {
    ++stats_.parts_unasked;
    return std::optional<evermap::keyframe_t>();
  }
  ++stats_.parts;
  return parts_.add(part);
}

std::vector<evermap::keyframe_request_t> KeyframeRequests::due(int64_t now,
                                                               std::vector<int64_t>* given_up) {
  std::vector<evermap::keyframe_request_t> asks;
  for (auto it = open_.begin(); it != open_.end();) {
    Open& o = it->second;
    if (now < o.next_us) {
      ++it;
      continue;
    }
    if (o.attempts >= options_.max_attempts) {
      ++stats_.given_up;
      given_up->push_back(it->first);
      parts_.erase(it->first);
      it = open_.erase(it);
      continue;
    }
    evermap::keyframe_request_t r{};
    r.utime = now;
    r.keyframe_utime = it->first;
    r.attempt = ++o.attempts;
    r.missing = parts_.missing(it->first);
    r.num_missing = static_cast<int16_t>(r.missing.size());
    if (o.attempts == 1) ++stats_.asked;
    ++stats_.asks;
    asks.push_back(r);
    // The waits grow from retry_us by `backoff`, up to max_retry_us. After a gap in data time
    // (a partition) the next ask is counted from now, so the gap spends one attempt at most.
    o.wait_us =
        o.attempts == 1
            ? options_.retry_us
            : std::min(options_.max_retry_us,
                       static_cast<int64_t>(static_cast<double>(o.wait_us) * options_.backoff));
    o.next_us = now + o.wait_us;
    ++it;
  }
  return asks;
}

}  // namespace evermap::loopclose
