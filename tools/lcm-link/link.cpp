#include "tools/lcm-link/link.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace evermap::link {

namespace {
constexpr uint32_t kShortMagic = 0x4c433032;     // "LC02": a whole message
constexpr uint32_t kFragmentMagic = 0x4c433033;  // "LC03": a fragment
constexpr size_t kShortHeader = 8, kFragmentHeader = 20;

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

// The NUL-terminated channel name at `from`, or "" when there is none.
std::string nameAt(const uint8_t* data, size_t size, size_t from) {
  if (from >= size) return "";
  const void* end = std::memchr(data + from, 0, size - from);
  if (!end) return "";
  return std::string(reinterpret_cast<const char*>(data + from),
                     static_cast<const uint8_t*>(end) - (data + from));
}
}  // namespace

void LinkOptions::declareOptions(OptionList& o) {
  o.add("loss_pct", &loss_pct, "%",
        "each IP packet is lost with this probability (a datagram: if any of its packets is)")
      .in(0, 100);
  o.add("mtu", &mtu, "bytes",
        "the link's MTU: a datagram crosses as ceil((size + 8) / (mtu - 20)) IP packets")
      .in(576, 65535);
  o.add("delay_ms", &delay_ms, "ms", "one-way delay of each datagram").in(0, 60000);
  o.add("jitter_ms", &jitter_ms, "ms", "delay plus uniform(-jitter, +jitter), never below 0")
      .in(0, 60000);
  o.add("partition_start_s", &partition_start_s, "s", "the partition begins this long after start")
      .nonNegative();
  o.add("partition_s", &partition_s, "s", "nothing crosses for this long (0: no partition)")
      .nonNegative();
  o.add("seed", &seed, "", "random seed: the same seed loses the same datagrams").any();
  o.add("local", &local, "",
        "channels that stay on their host, never forwarded (regex on the whole name)");
}

PacketHeader parseHeader(const uint8_t* data, size_t size) {
  PacketHeader h;
  if (size < kShortHeader) return h;
  const uint32_t magic = be32(data);
  h.seqno = be32(data + 4);
  if (magic == kShortMagic) {
    h.channel = nameAt(data, size, kShortHeader);
    h.valid = !h.channel.empty();
  } else if (magic == kFragmentMagic && size >= kFragmentHeader) {
    h.fragment = be16(data + 16);
    h.fragments = be16(data + 18);
    if (h.fragment == 0) h.channel = nameAt(data, size, kFragmentHeader);
    h.valid = h.fragments > 0 && h.fragment < h.fragments && (h.fragment > 0 || !h.channel.empty());
  }
  return h;
}

Direction::Direction(const LinkOptions& options, uint64_t seed)
    : options_(options), local_(options.local), rng_(seed) {}

// A datagram is lost when any of the IP packets it is cut into is (UDP header 8 bytes, IP 20).
double Direction::lossProbability(size_t size) const {
  const double payload = static_cast<double>(options_.mtu - 20);
  const double packets = std::ceil((static_cast<double>(size) + 8.0) / payload);
  return 1.0 - std::pow(1.0 - options_.loss_pct / 100.0, packets);
}

bool Direction::inPartition(double now_s) const {
  return options_.partition_s > 0.0 && now_s >= options_.partition_start_s &&
         now_s < options_.partition_start_s + options_.partition_s;
}

// The channel of the datagram (a later fragment takes its first's); `*msg` is the message
// under way of a fragmented one, else null.
std::string Direction::channelOf(uint64_t sender, const PacketHeader& h, Message** msg) {
  *msg = nullptr;
  if (h.fragments <= 1) return h.channel;
  const auto key = std::make_pair(sender, h.seqno);
  if (h.fragment == 0) {
    if (open_.size() > 4096) open_.clear();  // senders that vanished mid-message
    open_[key] = Message{h.channel, false};
  }
  const auto it = open_.find(key);
  if (it == open_.end()) return "(unknown)";  // its first fragment came before we started
  *msg = &it->second;
  return it->second.channel;
}

bool Direction::admit(uint64_t sender, const uint8_t* data, size_t size, double now_s,
                      double* leave_s) {
  const PacketHeader h = parseHeader(data, size);
  Message* msg = nullptr;
  const std::string channel = h.valid ? channelOf(sender, h, &msg) : "(not LCM)";
  ChannelCount& c = counts_[channel];
  if (h.valid && h.fragment == 0) ++c.messages;
  const bool last = h.valid && h.fragment + 1 == h.fragments;
  bool pass = true;
  if (std::regex_match(channel, local_)) {
    ++c.local;
    pass = false;
  } else {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const bool lost = unit(rng_) < lossProbability(size);  // drawn for every datagram
    if (lost || inPartition(now_s)) {
      ++c.dropped;
      const bool counted = msg ? msg->hit : false;
      if (!counted) ++c.messages_hit;
      if (msg) msg->hit = true;
      pass = false;
    }
  }
  if (last && msg) open_.erase(std::make_pair(sender, h.seqno));
  if (!pass) return false;
  double delay_s = options_.delay_ms / 1000.0;
  if (options_.jitter_ms > 0.0) {
    std::uniform_real_distribution<double> jitter(-options_.jitter_ms, options_.jitter_ms);
    delay_s += jitter(rng_) / 1000.0;
  }
  last_leave_s_ = std::max({last_leave_s_, now_s + std::max(0.0, delay_s)});
  *leave_s = last_leave_s_;
  ++c.datagrams;
  c.bytes += static_cast<int64_t>(size);
  return true;
}

std::vector<std::string> countLines(const std::string& name,
                                    const std::map<std::string, ChannelCount>& counts) {
  std::vector<std::string> lines;
  ChannelCount total;
  auto line = [&](const std::string& channel, const ChannelCount& c) {
    lines.push_back(name + " " + channel + " datagrams " + std::to_string(c.datagrams) + " bytes " +
                    std::to_string(c.bytes) + " dropped " + std::to_string(c.dropped) +
                    " messages " + std::to_string(c.messages) + " messages_hit " +
                    std::to_string(c.messages_hit) + " local " + std::to_string(c.local));
  };
  for (const auto& [channel, c] : counts) {
    line(channel, c);
    total.datagrams += c.datagrams;
    total.bytes += c.bytes;
    total.dropped += c.dropped;
    total.messages += c.messages;
    total.messages_hit += c.messages_hit;
    total.local += c.local;
  }
  line("total", total);
  return lines;
}

}  // namespace evermap::link
