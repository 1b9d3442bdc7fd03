// core/messages/lcm_receive_guard.h: LCM fragments whose header would overflow LCM 1.3.1's
// bounds check (issue 17: two packets, the second with fragment_offset = 0xffffff00, killed
// every subscriber) are turned into empty datagrams before LCM sees them; every other packet
// passes untouched. Tested on the header check and through the interposed recvmsg() on a
// local datagram socket pair (no network).
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/messages/lcm_receive_guard.h"

namespace evermap::messages {
namespace {

// A fragment of message 7 on `channel` (lcmFragmentPacket).
std::vector<uint8_t> fragment(uint32_t msg_size, uint32_t offset, uint16_t no, uint16_t count,
                              size_t payload, const std::string& channel = "IMU") {
  return lcmFragmentPacket(7, msg_size, offset, no, count, channel, payload);
}

TEST(LcmReceiveGuard, TheTwoPacketsOfIssue17AreRefusedAndHonestFragmentsPass) {
  const auto first = fragment(100000, 0, 0, 2, 60000);
  const auto evil = fragment(100000, 0xffffff00u, 1, 2, 1000);  // wraps in uint32_t
  EXPECT_TRUE(lcmPacketIsSafe(first.data(), first.size()));
  EXPECT_FALSE(lcmPacketIsSafe(evil.data(), evil.size()));
  const auto last = fragment(100000, 60000, 1, 2, 40000);
  EXPECT_TRUE(lcmPacketIsSafe(last.data(), last.size()));
  const auto past_end = fragment(100000, 60000, 1, 2, 40001);
  EXPECT_FALSE(lcmPacketIsSafe(past_end.data(), past_end.size()));
}

TEST(LcmReceiveGuard, InconsistentHeadersAreRefused) {
  for (const auto& b : {fragment(1u << 29, 0, 0, 2, 100),  // larger than LCM_MAX_MESSAGE_SIZE
                        fragment(1000, 0, 2, 2, 10),       // fragment number out of range
                        fragment(1000, 0, 0, 0, 10),       // no fragments
                        fragment(1000, 0, 0, 1, 10, std::string(80, 'C'))}) {  // channel too long
    EXPECT_FALSE(lcmPacketIsSafe(b.data(), b.size()));
  }
  std::vector<uint8_t> short_header = fragment(1000, 0, 1, 2, 0);
  short_header.resize(12);
  EXPECT_FALSE(lcmPacketIsSafe(short_header.data(), short_header.size()));
}

TEST(LcmReceiveGuard, PacketsThatAreNotLcmFragmentsPassUntouched) {
  std::vector<uint8_t> small = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 1, 'I', 'M', 'U', 0, 1, 2, 3};
  EXPECT_TRUE(lcmPacketIsSafe(small.data(), small.size()));  // "LC02": a short message
  const std::string text = "hello";
  EXPECT_TRUE(lcmPacketIsSafe(text.data(), text.size()));
  EXPECT_TRUE(lcmPacketIsSafe(text.data(), 0));
}

TEST(LcmReceiveGuard, TheInterposedRecvmsgTurnsABadFragmentIntoAnEmptyDatagram) {
  ASSERT_TRUE(lcmReceiveGuardLinked());
  int fds[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_DGRAM, 0, fds), 0);
  const auto evil = fragment(100000, 0xffffff00u, 1, 2, 1000);
  const auto good = fragment(100000, 60000, 1, 2, 40000);
  ASSERT_EQ(send(fds[0], evil.data(), evil.size(), 0), static_cast<ssize_t>(evil.size()));
  ASSERT_EQ(send(fds[0], good.data(), good.size(), 0), static_cast<ssize_t>(good.size()));
  std::vector<uint8_t> buf(65536);
  auto receive = [&] {
    iovec v{buf.data(), buf.size()};
    msghdr m{};
    m.msg_iov = &v;
    m.msg_iovlen = 1;
    return recvmsg(fds[1], &m, 0);
  };
  const int64_t before = lcmPacketsRefused();
  EXPECT_EQ(receive(), 0);
  EXPECT_EQ(lcmPacketsRefused(), before + 1);
  EXPECT_EQ(receive(), static_cast<ssize_t>(good.size()));
  close(fds[0]);
  close(fds[1]);
}

}  // namespace
}  // namespace evermap::messages
