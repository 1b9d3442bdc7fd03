#include "core/messages/sender_check.h"

#include <cmath>
#include <cstdio>

namespace evermap::messages {
namespace {

// Beyond this many (instance, channel) counters, those older than the window are forgotten
// (their messages are refused by the window anyway).
constexpr size_t kSeenPrune = 4096;

std::string seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f s", s);
  return text;
}

}  // namespace

Status SenderCheckOptions::validate() const {
  if (!std::isfinite(replay_window_s) || replay_window_s <= 0.0)
    return makeError("replay_window_s: must be a finite number > 0, got ", replay_window_s);
  if (!std::isfinite(silence_s) || silence_s < 0.0)
    return makeError("silence_s: must be a finite number >= 0, got ", silence_s);
  return Ok{};
}

SenderCheck::Now SenderCheck::Now::read() {
  return Now{std::chrono::steady_clock::now(),
             std::chrono::duration_cast<std::chrono::microseconds>(
                 std::chrono::system_clock::now().time_since_epoch())
                 .count()};
}

SenderCheck::SenderCheck(const MacKey* key, SenderCheckOptions options) : key_(key), o_(options) {}

SenderCheck::Result SenderCheck::check(const std::string& channel, const void* data, int64_t size,
                                       Now now) {
  const Expected<Opened> opened = openEnvelope(channel, data, size, key_);
  if (!opened) {
    return Result{key_ ? Kind::kUnauthenticated : Kind::kMalformed, size,
                  channel + ": " + opened.error().message, ""};
  }
  if (key_) {
    if (Result r = authenticate(channel, opened, now); r.kind != Kind::kAccept) return r;
  }
  Result r = lockOnto(channel, opened->envelope ? opened->envelope->sender : SenderId{}, now);
  r.message_size = opened->message_size;
  return r;
}

SenderCheck::Result SenderCheck::authenticate(const std::string& channel,
                                              const Expected<Opened>& opened, Now now) {
  const auto refuse = [&](Kind kind, const std::string& why) {
    return Result{kind, 0, channel + ": " + why, ""};
  };
  if (!opened->envelope) return refuse(Kind::kUnauthenticated, "no envelope (not signed)");
  const Envelope& e = *opened->envelope;
  const std::string from = " from " + e.sender.toString();
  if (!e.has_mac) return refuse(Kind::kUnauthenticated, "no MAC" + from);
  if (!opened->mac_valid) return refuse(Kind::kUnauthenticated, "wrong MAC" + from);
  const double age_s = 1e-6 * (static_cast<double>(now.wall_utime) - e.wall_utime);
  if (!(std::fabs(age_s) <= o_.replay_window_s)) {
    return refuse(Kind::kReplayed, "sent " + seconds(age_s) + " ago by our clock" + from +
                                       ", outside the replay window of " +
                                       seconds(o_.replay_window_s));
  }
  const auto key = std::make_pair(e.sender.instance, channel);
  if (auto it = seen_.find(key); it != seen_.end()) {
    if (e.counter <= it->second.counter) {
      return refuse(Kind::kReplayed, "counter " + std::to_string(e.counter) + from +
                                         " not above the last seen, " +
                                         std::to_string(it->second.counter));
    }
    it->second = Seen{e.counter, e.wall_utime};
    return Result{};
  }
  if (seen_.size() >= kSeenPrune) {
    const int64_t oldest = now.wall_utime - static_cast<int64_t>(o_.replay_window_s * 1e6);
    std::erase_if(seen_, [oldest](const auto& s) { return s.second.wall_utime < oldest; });
  }
  seen_.emplace(key, Seen{e.counter, e.wall_utime});
  return Result{};
}

SenderCheck::Result SenderCheck::lockOnto(const std::string& channel, const SenderId& sender,
                                          Now now) {
  Result r;
  if (shared_.count(channel)) return r;
  auto it = locks_.try_emplace(channel, Lock{sender, now.steady, {}, false}).first;
  Lock& lock = it->second;
  if (!(lock.who == sender)) {
    const double silent_s = std::chrono::duration<double>(now.steady - lock.last).count();
    if (silent_s <= o_.silence_s) {
      r.kind = Kind::kOtherSender;
      if (!lock.ignored_any || !(lock.last_ignored == sender)) {
        r.note = channel + ": ignoring " + sender.toString() +
                 ", a second sender (the channel's is " + lock.who.toString() +
                 "); its messages are counted";
        lock.last_ignored = sender;
        lock.ignored_any = true;
      }
      return r;
    }
    r.note = channel + ": sender now " + sender.toString() + " (" + lock.who.toString() +
             " silent for " + seconds(silent_s) + ")";
    lock = Lock{sender, now.steady, {}, false};
  }
  // The sender is alive: every lock it holds is refreshed.
  for (auto& [name, other] : locks_) {
    if (other.who == sender) other.last = now.steady;
  }
  return r;
}

std::optional<SenderId> SenderCheck::lockedSender(const std::string& channel) const {
  const auto it = locks_.find(channel);
  if (it == locks_.end()) return std::nullopt;
  return it->second.who;
}

}  // namespace evermap::messages
