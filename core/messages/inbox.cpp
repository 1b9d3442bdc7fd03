#include "core/messages/inbox.h"

#include "core/messages/lcm_receive_guard.h"
#include "core/messages/outbox.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>

namespace evermap::messages {
namespace {

// Every evermap type has `int64_t utime` first (DESIGN.md section 2); the layout says so.
bool hasUtimeFirst(int type) {
  const wire::Type& t = wire::kTypes[type];
  return t.num_members > 0 && std::strcmp(t.members[0].name, "utime") == 0 &&
         t.members[0].kind == wire::Kind::kInt64 && t.members[0].num_dims == 0;
}

// |a - b| > window, without overflow for any two int64 (2^62 and -2^62 included).
bool apart(int64_t a, int64_t b, int64_t window_us) {
  const long double d = static_cast<long double>(a) - static_cast<long double>(b);
  return std::fabs(d) > static_cast<long double>(window_us);
}

}  // namespace

Status TimeGuardOptions::validate() const {
  if (!std::isfinite(window_s) || window_s < 0.0)
    return makeError("time window_s: must be a finite number >= 0, got ", window_s);
  if (window_s > 1e9) return makeError("time window_s: at most 1e9 s, got ", window_s);
  if (confirm_count < 1 || confirm_count > 100)
    return makeError("time confirm_count: must be in [1, 100], got ", confirm_count);
  if (!std::isfinite(confirm_span_s) || confirm_span_s < 0.0 || confirm_span_s > 1e9)
    return makeError("time confirm_span_s: must be in [0, 1e9] s, got ", confirm_span_s);
  if (expire_count < 1) return makeError("time expire_count: must be >= 1, got ", expire_count);
  if (max_held < confirm_count)
    return makeError("time max_held: must be >= confirm_count (", confirm_count, "), got ",
                     max_held);
  return Ok{};
}

Status Inbox::Options::validate() const {
  if (queue_capacity < 0) return makeError("queue_capacity: must be >= 0, got ", queue_capacity);
  if (log_lines < 0) return makeError("log_lines: must be >= 0, got ", log_lines);
  if (Status s = senders.validate(); !s) return s;
  return time.validate();
}

Inbox::Inbox(lcm::LCM& lcm, Options options)
    : lcm_(lcm), o_(std::move(options)), senders_(o_.signer.key(), o_.senders) {
  // Every process with an Inbox gets the fragment guard (lcm_receive_guard.h) linked in.
  if (!lcmReceiveGuardLinked()) std::abort();
  if (Status s = o_.validate(); !s) {  // a broken contract: the caller validated its options
    std::fprintf(stderr, "%s: Inbox options: %s\n", o_.process.c_str(), s.error().message.c_str());
    std::abort();
  }
}

Inbox::~Inbox() {
  for (Entry& e : entries_) {
    if (e.subscription) lcm_.unsubscribe(e.subscription);
  }
}

void Inbox::add(const std::string& channel, int queue_capacity, int type, int64_t hash,
                Handler handler) {
  Entry& e = entries_.emplace_back(Entry{this, channel, type, hash, std::move(handler)});
  counts_[channel];
  e.subscription = lcm_.subscribeFunction(channel, &Inbox::onMessage, &e);
  if (e.subscription) {
    e.subscription->setQueueCapacity(queue_capacity < 0 ? o_.queue_capacity : queue_capacity);
  }
}

void Inbox::onMessage(const lcm::ReceiveBuffer* rbuf, const std::string&, Entry* entry) {
  entry->inbox->receive(*entry, rbuf->data, rbuf->data_size);
}

void Inbox::receive(Entry& e, const void* data, int64_t size) {
  ChannelCounts& c = counts_[e.channel];
  ++c.received;
  if (!admit(e, data, &size)) return;
  // The layout first: the time guard reads utime, and held bytes must be a whole message.
  const Expected<int64_t> used = checkWire(e.type, e.hash, data, size);
  if (!used || *used != size) {
    ++c.malformed;
    log(e.channel, c.malformed,
        e.channel + ": not a valid " + wire::kTypes[e.type].name + " (" +
            (used ? std::to_string(size - *used) + " unexpected bytes after the message"
                  : used.error().message) +
            ")");
    return;
  }
  if (o_.time.window_s > 0.0 && hasUtimeFirst(e.type)) {
    guard(e, data, size, *leadingUtime(data, size));
  } else {
    deliver(e, data, size, 0);
  }
}

bool Inbox::admit(Entry& e, const void* data, int64_t* size) {
  const SenderCheck::Result r = senders_.check(e.channel, data, *size, SenderCheck::Now::read());
  if (!r.note.empty()) std::fprintf(stderr, "%s: %s\n", o_.process.c_str(), r.note.c_str());
  ChannelCounts& c = counts_[e.channel];
  switch (r.kind) {
    case SenderCheck::Kind::kAccept:
      *size = r.message_size;
      return true;
    case SenderCheck::Kind::kMalformed:
      log(e.channel, ++c.malformed, r.why);
      return false;
    case SenderCheck::Kind::kUnauthenticated:
      log(e.channel, ++c.unauthenticated, r.why);
      return false;
    case SenderCheck::Kind::kReplayed:
      log(e.channel, ++c.replayed, r.why);
      return false;
    case SenderCheck::Kind::kOtherSender:
      ++c.other_sender;
      return false;
  }
  return false;
}

std::string Inbox::senderOf(const std::string& channel) const {
  const std::optional<SenderId> s = senders_.lockedSender(channel);
  return s ? s->toString() : std::string();
}

void Inbox::guard(Entry& e, const void* data, int64_t size, int64_t utime) {
  const int64_t window_us = static_cast<int64_t>(std::llround(o_.time.window_s * 1e6));
  if (have_clock_ && !apart(utime, clock_utime_, window_us)) {
    deliver(e, data, size, utime);
    expireHeld();
    return;
  }
  const auto* b = static_cast<const uint8_t*>(data);
  held_.push_back(Held{&e, utime, passed_, std::vector<uint8_t>(b, b + size)});
  if (static_cast<int>(held_.size()) > o_.time.max_held)
    refuseOldestHeld("far from the stream's clock and not confirmed (too many held)");
  const std::vector<size_t> agree = agreeing(utime, window_us);
  if (confirmsJump(agree)) jump(agree, utime);
}

std::vector<size_t> Inbox::agreeing(int64_t utime, int64_t window_us) const {
  std::vector<size_t> agree;
  for (size_t k = 0; k < held_.size(); ++k)
    if (!apart(held_[k].utime, utime, window_us)) agree.push_back(k);
  return agree;
}

bool Inbox::confirmsJump(const std::vector<size_t>& agree) {
  // Distinct stamps: copies of one message (the same stamp sent again) confirm nothing.
  std::vector<int64_t> stamps;
  for (size_t k : agree) stamps.push_back(held_[k].utime);
  std::sort(stamps.begin(), stamps.end());
  const auto distinct = std::unique(stamps.begin(), stamps.end()) - stamps.begin();
  if (distinct < o_.time.confirm_count) return false;
  if (!have_clock_) return true;  // nothing to contradict the first clock
  const long double span_us =
      static_cast<long double>(stamps.back()) - static_cast<long double>(stamps.front());
  const auto count = static_cast<int64_t>(agree.size());
  if (span_us < static_cast<long double>(o_.time.confirm_span_s) * 1e6L &&
      2 * count < o_.time.max_held)
    return false;
  // The streams at the clock since the first of them arrived: going on, they contradict it.
  const int64_t since = passed_ - held_[agree.front()].passed_at;
  if (since < count) return true;
  ++jumps_contradicted_;
  if (jumps_contradicted_ <= o_.log_lines || jumps_contradicted_ % 1000 == 0)
    std::fprintf(stderr,
                 "%s: message clock stays at %lld: %lld messages at it since %lld held ones "
                 "began to agree on %lld (contradicted %lld times)\n",
                 o_.process.c_str(), static_cast<long long>(clock_utime_),
                 static_cast<long long>(since), static_cast<long long>(count),
                 static_cast<long long>(held_[agree.back()].utime),
                 static_cast<long long>(jumps_contradicted_));
  return false;
}

void Inbox::jump(const std::vector<size_t>& agree, int64_t utime) {
  if (have_clock_) ++clock_jumps_;
  const std::string how =
      have_clock_ ? "jumps from " + std::to_string(clock_utime_) + " to" : std::string("starts at");
  std::fprintf(stderr, "%s: message clock %s %lld (%zu messages agree; %lld jumps)\n",
               o_.process.c_str(), how.c_str(), static_cast<long long>(utime), agree.size(),
               static_cast<long long>(clock_jumps_));
  have_clock_ = true;
  clock_utime_ = utime;
  std::deque<Held> release;
  std::deque<Held> keep;
  size_t next = 0;
  for (size_t k = 0; k < held_.size(); ++k) {
    if (next < agree.size() && agree[next] == k) {
      release.push_back(std::move(held_[k]));
      ++next;
    } else {
      keep.push_back(std::move(held_[k]));
    }
  }
  held_ = std::move(keep);
  for (Held& h : release) {
    deliver(*h.entry, h.bytes.data(), static_cast<int64_t>(h.bytes.size()), h.utime);
  }
  expireHeld();
}

void Inbox::expireHeld() {
  while (!held_.empty() && passed_ - held_.front().passed_at > o_.time.expire_count)
    refuseOldestHeld("more than the time window from the stream's clock " +
                     std::to_string(clock_utime_));
}

void Inbox::refuseOldestHeld(const std::string& why) {
  Held old = std::move(held_.front());
  held_.pop_front();
  ChannelCounts& c = counts_[old.entry->channel];
  ++c.time_refused;
  log(old.entry->channel, c.time_refused,
      old.entry->channel + ": refused utime " + std::to_string(old.utime) + ": " + why);
}

void Inbox::deliver(Entry& e, const void* data, int64_t size, int64_t utime) {
  ChannelCounts& c = counts_[e.channel];
  ++passed_;
  // The clock follows the newest message passed on (a result may carry an older time).
  if (have_clock_ && utime > clock_utime_) clock_utime_ = utime;
  try {
    Verdict v = e.handler(data, size);
    if (v.kind == Verdict::kMalformed) {
      ++c.malformed;
      log(e.channel, c.malformed, v.message);
    } else if (v.kind == Verdict::kRefused) {
      ++c.refused;
      log(e.channel, c.refused, v.message);
    }
  } catch (const std::exception& ex) {
    ++c.failed;
    log(e.channel, c.failed, e.channel + ": handler failed: " + ex.what());
  } catch (...) {
    ++c.failed;
    log(e.channel, c.failed, e.channel + ": handler failed (unknown exception)");
  }
}

void Inbox::countRefused(const std::string& channel, const std::string& why) {
  ChannelCounts& c = counts_[channel];
  ++c.refused;
  log(channel, c.refused, why);
}

void Inbox::log(const std::string&, int64_t count, const std::string& line) {
  if (count <= o_.log_lines || count % 1000 == 0) {
    std::fprintf(
        stderr, "%s: dropped: %s%s\n", o_.process.c_str(), line.c_str(),
        count > o_.log_lines ? (" (" + std::to_string(count) + " of this kind)").c_str() : "");
  }
}

ChannelCounts Inbox::total() const {
  ChannelCounts t;
  for (const auto& [channel, c] : counts_) {
    t.received += c.received;
    t.malformed += c.malformed;
    t.time_refused += c.time_refused;
    t.refused += c.refused;
    t.failed += c.failed;
    t.unauthenticated += c.unauthenticated;
    t.replayed += c.replayed;
    t.other_sender += c.other_sender;
  }
  return t;
}

std::string Inbox::summary() const {
  std::string s;
  for (const auto& [channel, c] : counts_) {
    if (!s.empty()) s += "; ";
    s += channel + " " + std::to_string(c.received) + " received, " + std::to_string(c.malformed) +
         " malformed, " + std::to_string(c.time_refused) + " time-refused, " +
         std::to_string(c.refused) + " refused, " + std::to_string(c.failed) + " failed";
    if (c.unauthenticated > 0) s += ", " + std::to_string(c.unauthenticated) + " unauthenticated";
    if (c.replayed > 0) s += ", " + std::to_string(c.replayed) + " replayed";
    if (c.other_sender > 0) s += ", " + std::to_string(c.other_sender) + " from another sender";
    // LCM's own queue (lcm_receive_guard.h): what never reached receive().
    if (const int64_t lost = lcmQueueDropped(channel); lost > 0) {
      s += ", " + std::to_string(lost) + " dropped by LCM's full queue";
    }
  }
  if (!held_.empty()) s += "; " + std::to_string(held_.size()) + " held";
  if (clock_jumps_ > 0 || jumps_contradicted_ > 0)
    s += "; message clock jumped " + std::to_string(clock_jumps_) + " times, " +
         std::to_string(jumps_contradicted_) + " jumps contradicted";
  if (lcmPacketsRefused() > 0) {
    s += "; " + std::to_string(lcmPacketsRefused()) + " LCM fragments refused";
  }
  return s;
}

evermap::input_stats_t Inbox::statsMessage(int64_t utime) const {
  evermap::input_stats_t m{};
  m.utime = utime;
  m.process = o_.process;
  m.pid = static_cast<int32_t>(::getpid());
  for (const auto& [channel, c] : counts_) {
    m.channels.push_back(channel);
    m.received.push_back(c.received);
    m.malformed.push_back(c.malformed);
    m.time_refused.push_back(c.time_refused);
    // input_stats_t has no fields of their own for the envelope's refusals: refused.
    m.refused.push_back(c.refused + c.unauthenticated + c.replayed + c.other_sender);
    m.failed.push_back(c.failed);
    m.queue_dropped.push_back(lcmQueueDropped(channel));
  }
  m.num_channels = static_cast<int32_t>(m.channels.size());
  m.held = static_cast<int64_t>(held_.size());
  m.lcm_packets_refused = lcmPacketsRefused();
  return m;
}

void Inbox::publishStatsEvery(double period_s) {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_stats_ < std::chrono::duration<double>(period_s)) return;
  last_stats_ = now;
  const evermap::input_stats_t m = statsMessage(have_clock_ ? clock_utime_ : 0);
  Outbox(lcm_, o_.signer).publish("INPUT_STATS", m);
}

}  // namespace evermap::messages
