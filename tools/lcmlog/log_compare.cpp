#include "tools/lcmlog/log_compare.h"

#include <cstring>
#include <sstream>

#include "core/messages/envelope.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/lcmlog/type_registry.h"

namespace evermap::messages {

Expected<LogComparator> LogComparator::fromLog(const std::filesystem::path& log) {
  auto opened = LogReader::open(log);
  if (!opened) return opened.error();
  LogReader& file = *opened;
  LogComparator c;
  while (const LogReader::Event* ev = file.next()) {
    const uint8_t* p = ev->data;
    c.expected_[ev->channel].emplace_back(p, p + ev->datalen);
    ChannelReport& r = c.reports_[ev->channel];
    ++r.expected;
    if (r.type.empty()) {
      const auto t = identify(ev->data, ev->datalen);
      r.type = t ? t->name : "?";
    }
    ++c.expected_total_;
  }
  if (Status s = file.status(); !s) return s.error();
  if (c.expected_total_ == 0) return makeError(log.string(), ": log holds no events");
  return c;
}

void LogComparator::onMessage(const std::string& channel, const void* data, size_t size) {
  // LCM's own probe: the udpm provider publishes it once when a process that publishes also
  // subscribes (evermap-sim-measure --serve); it is not part of any log.
  if (channel == "LCM_SELF_TEST") return;
  ++received_total_;
  ChannelReport& r = reports_[channel];
  if (r.type.empty()) {
    const auto t = identify(data, size);
    r.type = t ? t->name : "?";
  }
  ++r.received;
  r.bytes += static_cast<int64_t>(size);
  // A sender's envelope (evermap-sim-measure --serve signs what it publishes) is not part of
  // the message: the log holds the message alone.
  size = static_cast<size_t>(messages::messageSize(data, static_cast<int64_t>(size)));
  if (!decodesCleanly(data, size)) ++r.undecodable;
  const auto it = expected_.find(channel);
  if (it == expected_.end()) return;
  // Match against the next logged messages of this channel: a message lost on the way shows
  // up as skipped, one that arrives changed as corrupt.
  const auto& want = it->second;
  int64_t& cursor = cursors_[channel];
  for (int64_t j = cursor; j < static_cast<int64_t>(want.size()); ++j) {
    if (want[j].size() == size && std::memcmp(want[j].data(), data, size) == 0) {
      ++r.intact;
      cursor = j + 1;
      return;
    }
  }
  ++r.corrupt;
}

CompareSummary LogComparator::summary() const {
  CompareSummary s;
  s.channels = reports_;
  for (const auto& [name, r] : reports_) {
    s.expected += r.expected;
    s.received += r.received;
    s.intact += r.intact;
  }
  return s;
}

std::string CompareSummary::table() const {
  std::ostringstream o;
  o << "channel              type                 expected  received    intact   corrupt "
       "undecodable        bytes\n";
  char line[256];
  for (const auto& [name, r] : channels) {
    std::snprintf(line, sizeof line, "%-20s %-20s %8lld  %8lld  %8lld  %8lld    %8lld %12lld\n",
                  name.c_str(), r.type.c_str(), static_cast<long long>(r.expected),
                  static_cast<long long>(r.received), static_cast<long long>(r.intact),
                  static_cast<long long>(r.corrupt), static_cast<long long>(r.undecodable),
                  static_cast<long long>(r.bytes));
    o << line;
  }
  std::snprintf(line, sizeof line, "%-20s %-20s %8lld  %8lld  %8lld\n", "total", "",
                static_cast<long long>(expected), static_cast<long long>(received),
                static_cast<long long>(intact));
  o << line;
  return o.str();
}

}  // namespace evermap::messages
