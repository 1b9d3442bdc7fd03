// evermap-lcm-fuzz: publishes hostile messages on evermap's channels, as an attacker on the
// multicast group would (issue 17), to test that no packet kills a process. Run it inside
// scripts/lcm-sandbox only (it publishes on LCM_DEFAULT_URL).
//
// Per channel, `--count` messages: mutations (tools/lcmlog/mutate.h) of a message of the
// channel's type (the first one on that channel in `--log`, else a default-constructed one).
// `--stamp UTIME` instead sends well-formed lies (issue 47): unmutated copies of that message,
// the k-th stamped UTIME + k * `--stamp-step-s` (a clock that jumps, a log replayed by mistake).
// `--fragment-attack` instead sends the two UDP packets that overflow LCM 1.3.1's fragment
// check (fragment_offset = 0xffffff00) to the group of LCM_DEFAULT_URL.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/all_types.hpp>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/messages/channels.h"
#include "core/messages/lcm_receive_guard.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/lcmlog/mutate.h"

namespace {

using namespace evermap;
using Bytes = std::vector<uint8_t>;

template <typename Msg>
Bytes encodeDefault() {
  Msg m{};
  Bytes b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// The type of each input channel (core/messages/channels.h).
const std::map<std::string, std::function<Bytes()>>& channelTypes() {
  static const std::map<std::string, std::function<Bytes()>> m = {
      {channels::kStereo, encodeDefault<stereo_image_t>},
      {channels::kStereoCalib, encodeDefault<stereo_calib_t>},
      {channels::kRgbd, encodeDefault<rgbd_image_t>},
      {channels::kRgbdCalib, encodeDefault<rgbd_calib_t>},
      {channels::kAccel, encodeDefault<accel_t>},
      {channels::kImu, encodeDefault<imu_t>},
      {channels::kWheelOdom, encodeDefault<wheel_odom_t>},
      {channels::kVoDelta, encodeDefault<vo_delta_t>},
      {channels::kKeyframe, encodeDefault<keyframe_t>},
      {channels::kKeyframeRequest, encodeDefault<keyframe_request_t>},
      {channels::kKeyframePart, encodeDefault<keyframe_part_t>},
      {channels::kAttitude, encodeDefault<attitude_t>},
      {channels::kFloor, encodeDefault<floor_t>},
      {channels::kNodeAdded, encodeDefault<node_added_t>},
      {channels::kRegisterRequest, encodeDefault<register_request_t>},
      {channels::kRegisterResult, encodeDefault<register_result_t>},
      {channels::kDeputyOrder, encodeDefault<deputy_order_t>},
      {channels::kDeputyStatus, encodeDefault<deputy_status_t>},
      // The mapper's outputs: evermap-viewer's inputs.
      {channels::kPose, encodeDefault<pose_t>},
      {channels::kMapGraph, encodeDefault<map_graph_t>},
      {channels::kMapperStats, encodeDefault<mapper_stats_t>},
  };
  return m;
}

// "udpm://239.255.76.67:7667?ttl=0..." -> address and port (LCM's defaults otherwise).
bool lcmGroup(sockaddr_in* to) {
  std::string url = std::getenv("LCM_DEFAULT_URL") ? std::getenv("LCM_DEFAULT_URL") : "";
  std::string host = "239.255.76.67";
  int port = 7667;
  if (url.rfind("udpm://", 0) == 0) {
    std::string rest =
        url.substr(7, url.find('?') == std::string::npos ? std::string::npos : url.find('?') - 7);
    const size_t colon = rest.find(':');
    if (!rest.empty()) host = rest.substr(0, colon);
    if (colon != std::string::npos) port = std::atoi(rest.c_str() + colon + 1);
  } else if (!url.empty()) {
    return false;
  }
  std::memset(to, 0, sizeof *to);
  to->sin_family = AF_INET;
  to->sin_port = htons(static_cast<uint16_t>(port));
  return inet_pton(AF_INET, host.c_str(), &to->sin_addr) == 1;
}

int fragmentAttack(const std::vector<std::string>& channel_list) {
  sockaddr_in to{};
  if (!lcmGroup(&to)) {
    std::fprintf(stderr, "evermap-lcm-fuzz: LCM_DEFAULT_URL is not udpm://ADDR:PORT\n");
    return 2;
  }
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) {
    std::perror("evermap-lcm-fuzz: socket");
    return 1;
  }
  const unsigned char ttl = 0;
  setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  uint32_t seqno = 0x5eed0000;
  int sent = 0;
  for (const std::string& ch : channel_list) {
    const Bytes first = messages::lcmFragmentPacket(seqno, 100000, 0, 0, 2, ch, 1000, 0x41);
    const Bytes evil =
        messages::lcmFragmentPacket(seqno, 100000, 0xffffff00u, 1, 2, ch, 1000, 0x41);
    ++seqno;
    for (const Bytes* b : {&first, &evil}) {
      if (sendto(fd, b->data(), b->size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) ==
          static_cast<ssize_t>(b->size()))
        ++sent;
    }
  }
  close(fd);
  std::printf("fragment_packets_sent %d\n", sent);
  return 0;
}

// A copy of `message` (an evermap type: utime first, after the 8-byte hash) stamped
// utime0 + k * step_s, big-endian as LCM encodes it.
Bytes stamped(const Bytes& message, int64_t utime0, double step_s, int64_t k) {
  Bytes b = message;
  if (b.size() < 16) return b;
  auto utime = static_cast<uint64_t>(utime0 + static_cast<int64_t>(std::llround(step_s * 1e6)) * k);
  for (int i = 7; i >= 0; --i, utime >>= 8) b[8 + static_cast<size_t>(i)] = utime & 0xff;
  return b;
}

// The fuzzer's settings (--help lists them, --print-config prints them).
struct FuzzOptions {
  int64_t count = 1000;
  int64_t seed = 1;
  double rate_hz = 2000.0;
  int64_t stamp = 0;  // 0: mutate
  double stamp_step_s = 0.5;
  void declareOptions(evermap::OptionList& o) {
    o.add("count", &count, "", "messages per channel").in(0, 1e8);
    o.add("seed", &seed, "", "random seed: the same seed sends the same bytes").any();
    o.add("rate_hz", &rate_hz, "Hz",
          "messages per second over all channels (0: as fast as possible)")
        .in(0, 1e7);
    o.add("stamp", &stamp, "us",
          "send unmutated copies stamped from this utime on instead of mutations; 0: mutate")
        .min(0);
    o.add("stamp_step_s", &stamp_step_s, "s", "step between the stamps of --stamp's copies")
        .in(0, 1e6);
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string channel_text, log_file;
  FuzzOptions options;
  const int64_t &count = options.count, &seed = options.seed;
  const double& rate_hz = options.rate_hz;
  bool fragment_attack = false;
  CommandLine cli(
      "evermap-lcm-fuzz",
      "Hostile messages on evermap's input channels (inside scripts/lcm-sandbox only).");
  cli.value("--channels", &channel_text, "A,B,...", "the channels to fuzz", /*required=*/true);
  cli.options(&options);
  cli.alias("--count", "count", "N");
  cli.alias("--seed", "seed", "S");
  cli.alias("--rate-hz", "rate_hz", "HZ");
  cli.alias("--stamp", "stamp", "UTIME");
  cli.alias("--stamp-step-s", "stamp_step_s", "S");
  cli.value("--log", &log_file, "LOG", "mutate the first message of each channel in this LCM log");
  cli.flag("--fragment-attack", &fragment_attack,
           "send the 2-packet LCM 1.3.1 fragment overflow on each channel instead");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  std::vector<std::string> channel_list;
  std::stringstream ss(channel_text);
  for (std::string c; std::getline(ss, c, ',');) {
    if (!channelTypes().count(c)) {
      std::fprintf(stderr, "evermap-lcm-fuzz: --channels: unknown input channel \"%s\"\n",
                   c.c_str());
      return 2;
    }
    channel_list.push_back(c);
  }
  if (fragment_attack) return fragmentAttack(channel_list);

  std::map<std::string, Bytes> seeds;
  for (const std::string& c : channel_list) seeds[c] = channelTypes().at(c)();
  if (!log_file.empty()) {
    evermap::messages::LogReader log(log_file);
    std::map<std::string, bool> taken;
    while (const evermap::messages::LogReader::Event* ev = log.next()) {
      if (seeds.count(ev->channel) && !taken[ev->channel]) {
        seeds[ev->channel] = Bytes(ev->data, ev->data + ev->datalen);
        taken[ev->channel] = true;
      }
    }
    if (evermap::Status s = log.status(); !s) {
      std::fprintf(stderr, "evermap-lcm-fuzz: %s\n", s.error().message.c_str());
      return 2;
    }
  }
  lcm::LCM lcm;
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-lcm-fuzz: cannot open LCM\n");
    return 1;
  }
  std::mt19937_64 rng(static_cast<uint64_t>(seed));
  const auto start = std::chrono::steady_clock::now();
  int64_t sent = 0;
  for (int64_t k = 0; k < count; ++k) {
    for (const std::string& c : channel_list) {
      const Bytes b = options.stamp > 0 ? stamped(seeds[c], options.stamp, options.stamp_step_s, k)
                                        : messages::mutateLcm(seeds[c], rng);
      lcm.publish(c, b.data(), static_cast<unsigned>(b.size()));
      ++sent;
      if (rate_hz > 0.0)
        std::this_thread::sleep_until(start + std::chrono::duration<double>(sent / rate_hz));
    }
  }
  std::printf("fuzzed_messages_sent %lld\n", static_cast<long long>(sent));
  return 0;
}
