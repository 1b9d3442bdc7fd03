#pragma once
// The link of evermap-lcm-link (docs/deployment.md): what happens to each UDP datagram of LCM
// that crosses from one host to the other (seeded loss, delay with jitter, a partition
// window, channels kept on their host), and per direction and channel what crossed and what
// was lost. Datagrams are LCM's packets as they are: one lost fragment loses its whole
// message at the receiver, as on a real link. No sockets here (main.cpp has them).
#include <cstdint>
#include <deque>
#include <map>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "core/common/option_fields.h"

namespace evermap::link {

// The faults of the link, the same in both directions.
struct LinkOptions {
  double loss_pct = 0.0;           // each IP packet lost with this probability
  int64_t mtu = 1500;              // a datagram crosses as ceil((size + 8) / (mtu - 20)) IP packets
  double delay_ms = 0.0;           // one-way delay
  double jitter_ms = 0.0;          // delay + uniform(-jitter, +jitter), never below 0
  double partition_start_s = 0.0;  // from the link's start
  double partition_s = 0.0;        // nothing crosses for this long (0: no partition)
  int64_t seed = 1;                // the same seed loses the same datagrams
  std::string local = "STEREO|RGBD";  // channels that stay on their host (regex, whole name)
  void declareOptions(OptionList& o);
};

// An LCM datagram's channel and message: "LC02" (a whole message) or "LC03" (a fragment;
// only fragment 0 names the channel).
struct PacketHeader {
  bool valid = false;
  uint32_t seqno = 0;
  uint16_t fragment = 0, fragments = 1;
  std::string channel;  // empty for fragments after the first
};
PacketHeader parseHeader(const uint8_t* data, size_t size);

// What crossed one direction on one channel.
struct ChannelCount {
  int64_t datagrams = 0, bytes = 0;  // forwarded (UDP payload bytes)
  int64_t dropped = 0;               // datagrams lost or cut by the partition
  int64_t messages = 0;              // messages seen (first datagrams)
  int64_t messages_hit = 0;          // messages with at least one datagram dropped
  int64_t local = 0;                 // datagrams kept on their host (not forwarded)
};

// One direction: decides each datagram's fate and keeps the counts. Datagrams leave in the
// order they came (a FIFO after the delay, as netem with a rate or a pfifo child): LCM drops a
// half-assembled message when a fragment of the sender's next message arrives first.
class Direction {
 public:
  Direction(const LinkOptions& options, uint64_t seed);

  // The datagram from `sender` (address and port, any stable key) that arrived at `now_s`
  // (seconds from the link's start): true with the time it may leave, false when it is
  // dropped or stays local.
  bool admit(uint64_t sender, const uint8_t* data, size_t size, double now_s, double* leave_s);

  const std::map<std::string, ChannelCount>& counts() const { return counts_; }

 private:
  struct Message {
    std::string channel;
    bool hit = false;
  };
  bool inPartition(double now_s) const;
  double lossProbability(size_t size) const;
  std::string channelOf(uint64_t sender, const PacketHeader& h, Message** msg);

  LinkOptions options_;
  std::regex local_;
  std::mt19937_64 rng_;
  double last_leave_s_ = 0.0;
  std::map<std::pair<uint64_t, uint32_t>, Message> open_;  // fragmented messages under way
  std::map<std::string, ChannelCount> counts_;
};

// "robot->base KEYFRAME datagrams 12 bytes 3400 dropped 1 messages 4 messages_hit 1 local 0"
// per channel, then "robot->base total ..." ("name", counts).
std::vector<std::string> countLines(const std::string& name,
                                    const std::map<std::string, ChannelCount>& counts);

}  // namespace evermap::link
