#include "core/messages/lcm_receive_guard.h"

#include <dlfcn.h>
#include <sys/socket.h>
#include <sys/types.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <string_view>

namespace evermap::messages {
namespace {

// lcm_internal.h / udpm_util.h of LCM 1.3.1: the long (fragment) header, network byte order.
constexpr uint32_t kMagicLong = 0x4c433033;      // "LC03"
constexpr size_t kLongHeaderBytes = 20;          // magic seqno msg_size offset no count
constexpr uint32_t kMaxMessageBytes = 1u << 28;  // LCM_MAX_MESSAGE_SIZE
constexpr size_t kMaxChannelBytes = 63;          // LCM_MAX_CHANNEL_NAME_LENGTH

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

std::atomic<int64_t>& refusedCount() {
  static std::atomic<int64_t> n{0};
  return n;
}

// LCM's queue drops per channel: written by LCM's receive thread (or the publisher, for
// memq), read by the Inbox's thread.
struct QueueDrops {
  std::mutex mutex;
  std::map<std::string, int64_t, std::less<>> by_channel;
};
QueueDrops& queueDrops() {
  static QueueDrops d;
  return d;
}

}  // namespace

int64_t lcmQueueDropped(const std::string& channel) {
  QueueDrops& d = queueDrops();
  std::lock_guard<std::mutex> lock(d.mutex);
  const auto it = d.by_channel.find(channel);
  return it == d.by_channel.end() ? 0 : it->second;
}

bool lcmPacketIsSafe(const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  if (size < 4 || be32(p) != kMagicLong) return true;
  if (size < kLongHeaderBytes) return false;
  const uint32_t msg_size = be32(p + 8);
  const uint32_t offset = be32(p + 12);
  const uint16_t fragment_no = be16(p + 16);
  const uint16_t fragments = be16(p + 18);
  if (msg_size > kMaxMessageBytes || fragments == 0 || fragment_no >= fragments) return false;
  uint64_t payload = size - kLongHeaderBytes;
  if (fragment_no == 0) {
    const uint8_t* channel = p + kLongHeaderBytes;
    const size_t max = std::min<size_t>(payload, kMaxChannelBytes + 1);
    const void* nul = std::memchr(channel, 0, max);
    if (nul == nullptr) return false;
    payload -= static_cast<const uint8_t*>(nul) - channel + 1;
  }
  return uint64_t{offset} + payload <= uint64_t{msg_size};  // 64-bit: no wrap-around
}

int64_t lcmPacketsRefused() { return refusedCount().load(); }

bool lcmReceiveGuardLinked() { return true; }

std::vector<uint8_t> lcmFragmentPacket(uint32_t seqno, uint32_t msg_size, uint32_t offset,
                                       uint16_t fragment_no, uint16_t fragment_count,
                                       const std::string& channel, size_t payload, uint8_t fill) {
  std::vector<uint8_t> b;
  const auto put32 = [&b](uint32_t v) {
    for (int k = 0; k < 4; ++k) b.push_back(static_cast<uint8_t>(v >> (24 - 8 * k)));
  };
  const auto put16 = [&b](uint16_t v) {
    b.push_back(static_cast<uint8_t>(v >> 8));
    b.push_back(static_cast<uint8_t>(v));
  };
  put32(0x4c433033);
  put32(seqno);
  put32(msg_size);
  put32(offset);
  put16(fragment_no);
  put16(fragment_count);
  if (fragment_no == 0) {
    b.insert(b.end(), channel.begin(), channel.end());
    b.push_back(0);
  }
  b.resize(b.size() + payload, fill);
  return b;
}

}  // namespace evermap::messages

// Interposes the C library's recvmsg() for the whole process (the executable's definition
// comes first in symbol lookup, so liblcm's calls land here). LCM's read thread calls it with
// one iovec per datagram.
extern "C" ssize_t recvmsg(int fd, struct msghdr* msg, int flags) {
  using Recvmsg = ssize_t (*)(int, struct msghdr*, int);
  static const Recvmsg real = [] {
    auto f = reinterpret_cast<Recvmsg>(dlsym(RTLD_NEXT, "recvmsg"));
    if (f == nullptr) {  // a broken contract of the platform: nothing could be received
      std::fprintf(stderr, "evermap: the C library's recvmsg() not found: %s\n", dlerror());
      std::abort();
    }
    return f;
  }();
  const ssize_t n = real(fd, msg, flags);
  if (n <= 0 || msg == nullptr || msg->msg_iovlen < 1 || msg->msg_iov == nullptr) return n;
  const size_t seen = std::min(static_cast<size_t>(n), msg->msg_iov[0].iov_len);
  if (evermap::messages::lcmPacketIsSafe(msg->msg_iov[0].iov_base, seen)) return n;
  const int64_t refused = ++evermap::messages::refusedCount();
  if (refused <= 20 || refused % 1000 == 0) {
    std::fprintf(stderr,
                 "evermap: dropped: an LCM fragment with an inconsistent header (%lld so far)\n",
                 static_cast<long long>(refused));
  }
  return 0;  // LCM discards a datagram shorter than its header
}

// Interposes liblcm's lcm_try_enqueue_message() (exported, and called through the PLT by
// lcm_udpm.c, lcm_memq.c and the other providers; lcm.c of 1.3.1): it returns 0 when no
// subscription of the channel has room, and the provider then discards the message. The
// real function runs unchanged; each 0 is counted for the channel.
extern "C" int lcm_try_enqueue_message(void* lcm, const char* channel) {
  using TryEnqueue = int (*)(void*, const char*);
  static const TryEnqueue real = [] {
    auto f = reinterpret_cast<TryEnqueue>(dlsym(RTLD_NEXT, "lcm_try_enqueue_message"));
    if (f == nullptr) {  // a broken contract: liblcm without the function LCM 1.3.1 exports
      std::fprintf(stderr, "evermap: liblcm's lcm_try_enqueue_message() not found: %s\n",
                   dlerror());
      std::abort();
    }
    return f;
  }();
  const int kept = real(lcm, channel);
  if (kept == 0 && channel != nullptr) {
    auto& d = evermap::messages::queueDrops();
    std::lock_guard<std::mutex> lock(d.mutex);
    const std::string_view name(channel);
    auto it = d.by_channel.find(name);
    if (it == d.by_channel.end()) it = d.by_channel.emplace(std::string(name), 0).first;
    ++it->second;
  }
  return kept;
}
