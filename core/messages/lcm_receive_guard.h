#pragma once
// The fragment guard: LCM UDP packets are checked before Debian's LCM 1.3.1 reassembles them.
//
// lcm_udpm.c (1.3.1) accepts a fragment when `fragment_offset + frag_size > data_size` is
// false, computed in uint32_t: a fragment with fragment_offset = 0xffffff00 wraps around,
// passes, and memcpy() writes 4 GB before the buffer (SIGSEGV in every subscriber of the
// channel, from two UDP packets anyone on the multicast group can send). LCM 1.3.1 has no
// hook between the socket and the reassembly, so every evermap process that links this file
// defines recvmsg(): it calls the C library's, and a packet with LCM's fragment magic whose
// header is inconsistent (offset + size beyond the message, fragment number out of range, a
// message larger than LCM's own limit, no channel terminator in the first fragment) is
// returned as an empty datagram, which LCM discards as too short ("bad packet"). Everything
// else passes untouched. docs/lcm.md says why this and not a rebuilt Debian package.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace evermap::messages {

// Whether one received UDP datagram is safe to hand to LCM 1.3.1 (a packet that is not an LCM
// fragment is: short messages are bounded by the datagram itself).
bool lcmPacketIsSafe(const void* data, size_t size);

// Packets the guard turned into empty datagrams since the process started.
int64_t lcmPacketsRefused();

// Messages LCM 1.3.1 discarded on `channel` because every subscription's queue was full
// (lcm_subscription_set_queue_capacity), since the process started; 0 for a channel never
// seen. LCM has no counter for them: the executable also interposes liblcm's exported
// lcm_try_enqueue_message(), which every provider (udpm, memq, ...) calls once per received
// message to ask whether any subscription has room, and counts each "no". Process-wide, per
// channel name (all lcm_t instances of the process together).
int64_t lcmQueueDropped(const std::string& channel);

// True: the guard is linked into this executable (calling it makes sure it is).
bool lcmReceiveGuardLinked();

// One LCM 1.3.1 fragment as sent on the wire: "LC03", seqno, msg_size, fragment_offset,
// fragment_no, fragment count (big-endian), the channel and its NUL in the first fragment
// only, then `payload` bytes of `fill`. Any header, consistent or not (tests, the fuzzer).
std::vector<uint8_t> lcmFragmentPacket(uint32_t seqno, uint32_t msg_size, uint32_t offset,
                                       uint16_t fragment_no, uint16_t fragment_count,
                                       const std::string& channel, size_t payload,
                                       uint8_t fill = 0xab);

}  // namespace evermap::messages
